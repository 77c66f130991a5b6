//! A hand-written SVG line chart for learning curves (no plotting dependency needed).
//!
//! The chart stacks panels that share the x axis (episodes): return per episode with its moving
//! average, and the success rate over a trailing window.

use std::fmt::Write;

/// One line of a panel.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// CSS colour.
    pub color: &'static str,
    /// Stroke opacity (a faint raw curve under a bold average).
    pub opacity: f32,
    /// `(x, y)` points in data units; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
}

/// One panel with its own y axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// The y-axis label.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
    /// Fixed y range, or `None` to fit the data.
    pub y_range: Option<(f64, f64)>,
}

const WIDTH: f64 = 720.0;
const PANEL_HEIGHT: f64 = 220.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 36.0;
const GAP: f64 = 40.0;

/// Renders panels stacked vertically into an SVG document.
///
/// ```
/// use host_trainer::run::plot::{svg, Panel, Series};
/// let line = Series { name: "return".into(), color: "#1f77b4", opacity: 1.0, points: vec![(1.0, -3.0), (2.0, -1.0)] };
/// let doc = svg("run", "episode", &[Panel { y_label: "return".into(), series: vec![line], y_range: None }]);
/// assert!(doc.starts_with("<svg") && doc.contains("<polyline") && doc.ends_with("</svg>\n"));
/// ```
pub fn svg(title: &str, x_label: &str, panels: &[Panel]) -> String {
    let height = TOP + panels.len() as f64 * (PANEL_HEIGHT + GAP) + 10.0;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" viewBox="0 0 {WIDTH} {height}" font-family="sans-serif" font-size="11">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{}" y="20" font-size="14" text-anchor="middle">{}</text>"#,
        WIDTH / 2.0,
        escape(title)
    );
    let x_range = x_extent(panels);
    for (i, panel) in panels.iter().enumerate() {
        let top = TOP + i as f64 * (PANEL_HEIGHT + GAP);
        draw_panel(&mut out, panel, top, x_range, x_label);
    }
    out.push_str("</svg>\n");
    out
}

/// Trailing moving average over `window` points (shorter at the start).
///
/// ```
/// assert_eq!(host_trainer::run::plot::moving_average(&[1.0, 3.0, 5.0], 2), vec![1.0, 2.0, 4.0]);
/// ```
pub fn moving_average(values: &[f64], window: usize) -> Vec<f64> {
    let window = window.max(1);
    let mut sum = 0.0;
    let mut out = Vec::with_capacity(values.len());
    for (i, v) in values.iter().enumerate() {
        sum += v;
        if i >= window {
            sum -= values[i - window];
        }
        out.push(sum / (i + 1).min(window) as f64);
    }
    out
}

/// A data-to-pixel mapping for one panel.
#[derive(Clone, Copy)]
struct Frame {
    x: (f64, f64),
    y: (f64, f64),
    top: f64,
}

impl Frame {
    fn px(&self, x: f64) -> f64 {
        LEFT + (x - self.x.0) / (self.x.1 - self.x.0) * (WIDTH - LEFT - RIGHT)
    }
    fn py(&self, y: f64) -> f64 {
        self.top + PANEL_HEIGHT - (y - self.y.0) / (self.y.1 - self.y.0) * PANEL_HEIGHT
    }
}

fn draw_panel(out: &mut String, panel: &Panel, top: f64, x: (f64, f64), x_label: &str) {
    let y = panel.y_range.unwrap_or_else(|| {
        padded(extent(
            panel
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1)),
        ))
    });
    let frame = Frame { x, y, top };
    draw_axes(out, &frame, &panel.y_label, x_label);
    for (k, series) in panel.series.iter().enumerate() {
        draw_series(out, &frame, series);
        let ly = top + 14.0 + 14.0 * k as f64;
        let _ = writeln!(
            out,
            r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="{}" stroke-opacity="{}" stroke-width="2"/><text x="{}" y="{}">{}</text>"#,
            WIDTH - 170.0,
            WIDTH - 150.0,
            series.color,
            series.opacity,
            WIDTH - 145.0,
            ly + 4.0,
            escape(&series.name)
        );
    }
}

fn draw_axes(out: &mut String, f: &Frame, y_label: &str, x_label: &str) {
    let (x0, x1, y0, y1) = (LEFT, WIDTH - RIGHT, f.top, f.top + PANEL_HEIGHT);
    let _ = writeln!(
        out,
        r##"<rect x="{x0}" y="{y0}" width="{}" height="{PANEL_HEIGHT}" fill="none" stroke="#444"/>"##,
        x1 - x0
    );
    for tick in ticks(f.y) {
        let py = f.py(tick);
        let _ = writeln!(
            out,
            r##"<line x1="{x0}" y1="{py:.1}" x2="{x1}" y2="{py:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"##,
            x0 - 4.0,
            py + 4.0,
            label(tick)
        );
    }
    for tick in ticks(f.x) {
        let px = f.px(tick);
        let _ = writeln!(
            out,
            r#"<text x="{px:.1}" y="{}" text-anchor="middle">{}</text>"#,
            y1 + 14.0,
            label(tick)
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        (x0 + x1) / 2.0,
        y1 + 28.0,
        escape(x_label)
    );
    let mid = (y0 + y1) / 2.0;
    let _ = writeln!(
        out,
        r#"<text x="16" y="{mid}" text-anchor="middle" transform="rotate(-90 16 {mid})">{}</text>"#,
        escape(y_label)
    );
}

fn draw_series(out: &mut String, f: &Frame, s: &Series) {
    let mut pts = String::new();
    for &(x, y) in s
        .points
        .iter()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
    {
        let y = y.clamp(f.y.0, f.y.1);
        let _ = write!(pts, "{:.1},{:.1} ", f.px(x), f.py(y));
    }
    let _ = writeln!(
        out,
        r#"<polyline fill="none" stroke="{}" stroke-opacity="{}" stroke-width="1.5" points="{}"/>"#,
        s.color,
        s.opacity,
        pts.trim_end()
    );
}

fn x_extent(panels: &[Panel]) -> (f64, f64) {
    let e = extent(
        panels
            .iter()
            .flat_map(|p| p.series.iter().flat_map(|s| s.points.iter().map(|q| q.0))),
    );
    if e.1 > e.0 {
        e
    } else {
        (e.0 - 1.0, e.0 + 1.0)
    }
}

fn extent(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    let pad = if hi > lo { (hi - lo) * 0.05 } else { 1.0 };
    (lo - pad, hi + pad)
}

/// About five round tick values inside the range.
fn ticks((lo, hi): (f64, f64)) -> Vec<f64> {
    let raw = (hi - lo) / 5.0;
    if raw <= 0.0 || !raw.is_finite() {
        return vec![lo];
    }
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

fn label(v: f64) -> String {
    if v.abs() >= 1000.0 || v == v.trunc() {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside_the_range() {
        let t = ticks((0.0, 3000.0));
        assert_eq!(t, vec![0.0, 1000.0, 2000.0, 3000.0]);
        assert_eq!(ticks((-0.05, 1.05)), vec![0.0, 0.5, 1.0]);
        assert_eq!(ticks((-180.0, -40.0)), vec![-150.0, -100.0, -50.0]);
    }

    #[test]
    fn non_finite_points_are_skipped_and_markup_is_escaped() {
        let s = Series {
            name: "a<b".into(),
            color: "red",
            opacity: 1.0,
            points: vec![(0.0, 1.0), (1.0, f64::NAN), (2.0, 2.0)],
        };
        let doc = svg(
            "t&t",
            "x",
            &[Panel {
                y_label: "y".into(),
                series: vec![s],
                y_range: None,
            }],
        );
        assert!(doc.contains("a&lt;b") && doc.contains("t&amp;t"));
        assert!(!doc.contains("NaN"));
    }
}
