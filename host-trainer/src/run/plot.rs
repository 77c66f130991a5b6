//! Learning curves as SVG line charts, drawn with plotters.
//!
//! The chart stacks panels that share the x axis (episodes): return per episode with its moving
//! average, and the success rate over a trailing window.

use plotters::coord::Shift;
use plotters::prelude::*;

/// One line of a panel.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Colour as `#rrggbb` (anything else draws black).
    pub color: &'static str,
    /// Stroke opacity: a faint raw curve (below 1, drawn thin) under a bold average (1).
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

const WIDTH: u32 = 720;
const PANEL_HEIGHT: u32 = 260;
/// Room for the title and the bottom border, pixels.
const FRAME: u32 = 46;

type Drawn = Result<(), DrawingAreaErrorKind<std::io::Error>>;

/// Renders panels stacked vertically into an SVG document.
///
/// Each series is one polyline plus a legend entry (and a dot when it has a single point); an
/// empty panel list, an empty series, a single point and an all-equal y range all draw (the
/// range is padded). Drawing into a string cannot fail in practice; if plotters reports an
/// error anyway, the document says so instead of the chart.
///
/// ```
/// use host_trainer::run::plot::{svg, Panel, Series};
/// let line = Series { name: "return".into(), color: "#1f77b4", opacity: 1.0, points: vec![(1.0, -3.0), (2.0, -1.0)] };
/// let doc = svg("run", "episode", &[Panel { y_label: "return".into(), series: vec![line], y_range: None }]);
/// assert!(doc.starts_with("<svg") && doc.trim_end().ends_with("</svg>"));
/// // The series' polyline and its legend sample, both in the series' colour.
/// assert_eq!(doc.matches(r##"<polyline fill="none" opacity="1" stroke="#1F77B4""##).count(), 2);
/// assert!(doc.contains(">\nreturn\n</text>") && doc.contains(">\nepisode\n</text>"));
/// ```
pub fn svg(title: &str, x_label: &str, panels: &[Panel]) -> String {
    let rows = u32::try_from(panels.len()).unwrap_or(u32::MAX);
    let height = rows.saturating_mul(PANEL_HEIGHT).saturating_add(FRAME);
    let mut text = String::new();
    let drawn = {
        let root = SVGBackend::with_string(&mut text, (WIDTH, height)).into_drawing_area();
        draw(&root, title, x_label, panels)
    };
    match drawn {
        Ok(()) => text,
        Err(e) => failed(&e),
    }
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

fn draw(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    x_label: &str,
    panels: &[Panel],
) -> Drawn {
    root.fill(&WHITE)?;
    let body = root.titled(title, ("sans-serif", 17))?;
    if !panels.is_empty() {
        let x = x_extent(panels);
        for (area, panel) in body.split_evenly((panels.len(), 1)).iter().zip(panels) {
            draw_panel(area, panel, x, x_label)?;
        }
    }
    root.present()
}

fn draw_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    panel: &Panel,
    x: (f64, f64),
    x_label: &str,
) -> Drawn {
    let y = match panel.y_range {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && hi > lo => (lo, hi),
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() => padded((lo.min(hi), lo.max(hi))),
        _ => padded(extent(panel.series.iter().flat_map(|s| {
            s.points.iter().filter(|p| p.0.is_finite()).map(|p| p.1)
        }))),
    };
    let mut chart = ChartBuilder::on(area)
        .margin(8)
        .margin_right(20)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .bold_line_style(RGBColor(221, 221, 221))
        .light_line_style(TRANSPARENT)
        .x_labels(8)
        .y_labels(6)
        .x_label_formatter(&|v| label(*v))
        .y_label_formatter(&|v| label(*v))
        .x_desc(x_label)
        .y_desc(panel.y_label.as_str())
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .draw()?;
    for series in &panel.series {
        let opacity = f64::from(series.opacity).clamp(0.0, 1.0);
        let width = if opacity < 1.0 { 1 } else { 2 };
        let style = rgb(series.color).mix(opacity).stroke_width(width);
        let points: Vec<(f64, f64)> = series
            .points
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .map(|&(px, py)| (px, py.clamp(y.0, y.1)))
            .collect();
        // A line through one point draws nothing: mark it.
        if let [point] = points[..] {
            chart.draw_series(std::iter::once(Circle::new(point, 3, style.filled())))?;
        }
        chart
            .draw_series(std::iter::once(PathElement::new(points, style)))?
            .label(series.name.as_str())
            .legend(move |(lx, ly)| PathElement::new([(lx, ly), (lx + 20, ly)], style));
    }
    if !panel.series.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(RGBColor(200, 200, 200))
            .label_font(("sans-serif", 13))
            .draw()?;
    }
    Ok(())
}

/// A document saying the chart could not be drawn (best effort: it is what is left to say).
fn failed(e: &DrawingAreaErrorKind<std::io::Error>) -> String {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (WIDTH, 40)).into_drawing_area();
        let message = format!("the chart could not be drawn: {e}");
        let _ = root.draw(&Text::new(message, (10, 20), ("sans-serif", 14)));
    }
    text
}

/// `#rrggbb` as a colour; black for anything else.
fn rgb(css: &str) -> RGBColor {
    let hex = css.strip_prefix('#').unwrap_or("");
    let channel = |i: usize| {
        hex.get(i..i + 2)
            .and_then(|h| u8::from_str_radix(h, 16).ok())
    };
    match (hex.len(), channel(0), channel(2), channel(4)) {
        (6, Some(r), Some(g), Some(b)) => RGBColor(r, g, b),
        _ => BLACK,
    }
}

fn x_extent(panels: &[Panel]) -> (f64, f64) {
    let e = extent(panels.iter().flat_map(|p| {
        p.series
            .iter()
            .flat_map(|s| s.points.iter().filter(|q| q.1.is_finite()).map(|q| q.0))
    }));
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

/// 5 % of room above and below; one unit each way when the range is a single value.
fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    let pad = if hi > lo { (hi - lo) * 0.05 } else { 1.0 };
    (lo - pad, hi + pad)
}

/// Whole numbers without decimals, others with two.
fn label(v: f64) -> String {
    if v.abs() >= 1000.0 || v == v.trunc() {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(color: &'static str, points: Vec<(f64, f64)>) -> Series {
        Series {
            name: "line".into(),
            color,
            opacity: 1.0,
            points,
        }
    }

    fn one_panel(series: Vec<Series>, y_range: Option<(f64, f64)>) -> String {
        svg(
            "t",
            "x",
            &[Panel {
                y_label: "y".into(),
                series,
                y_range,
            }],
        )
    }

    /// The `points` of the first polyline stroked in `stroke` (`#RRGGBB`), as pixel pairs.
    fn polyline(doc: &str, stroke: &str) -> Vec<(i32, i32)> {
        let tag = format!(r#"stroke="{stroke}""#);
        let start = doc.find(&tag).expect("a polyline in that colour");
        let rest = &doc[start..];
        let points = rest
            .split("points=\"")
            .nth(1)
            .and_then(|p| p.split('"').next())
            .expect("a points attribute");
        points
            .split_whitespace()
            .map(|xy| {
                let (x, y) = xy.split_once(',').expect("x,y");
                (
                    x.parse().expect("an integer x"),
                    y.parse().expect("an integer y"),
                )
            })
            .collect()
    }

    #[test]
    fn every_series_is_a_polyline_in_its_colour_with_a_legend_entry() {
        let doc = svg(
            "run",
            "episode",
            &[
                Panel {
                    y_label: "return".into(),
                    series: vec![
                        Series {
                            name: "raw".into(),
                            opacity: 0.25,
                            ..series("#1f77b4", vec![(0.0, 1.0), (1.0, 3.0), (2.0, 2.0)])
                        },
                        Series {
                            name: "mean of 100".into(),
                            ..series("#1f77b4", vec![(0.0, 1.0), (1.0, 2.0), (2.0, 2.0)])
                        },
                    ],
                    y_range: None,
                },
                Panel {
                    y_label: "success rate".into(),
                    series: vec![series("#2ca02c", vec![(0.0, 0.0), (2.0, 1.0)])],
                    y_range: Some((0.0, 1.0)),
                },
            ],
        );
        // Each series once in the chart and once as its legend sample.
        assert_eq!(
            doc.matches(r##"opacity="0.25" stroke="#1F77B4""##).count(),
            2
        );
        assert_eq!(doc.matches(r##"opacity="1" stroke="#1F77B4""##).count(), 2);
        assert_eq!(doc.matches(r##"opacity="1" stroke="#2CA02C""##).count(), 2);
        for text in [
            "raw",
            "mean of 100",
            "line",
            "return",
            "success rate",
            "episode",
        ] {
            assert!(
                doc.contains(&format!(">\n{text}\n</text>")),
                "{text} missing"
            );
        }
        // The panels share the x axis: the first and last points line up across panels.
        let top = polyline(&doc, "#1F77B4");
        let bottom = polyline(&doc, "#2CA02C");
        assert_eq!((top[0].0, top[2].0), (bottom[0].0, bottom[1].0));
        assert!(
            bottom[0].1 > top[0].1,
            "the second panel is below the first"
        );
    }

    #[test]
    fn non_finite_points_are_skipped_and_markup_is_escaped() {
        let s = Series {
            name: "a<b".into(),
            ..series(
                "#ff0000",
                vec![
                    (0.0, 1.0),
                    (1.0, f64::NAN),
                    (f64::INFINITY, 5.0),
                    (2.0, 2.0),
                ],
            )
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
        assert!(!doc.contains("NaN") && !doc.contains("inf"));
        let line = polyline(&doc, "#FF0000");
        assert_eq!(line.len(), 2, "only the two finite points: {line:?}");
        // The y range fits the finite points: 1 is low in the panel, 2 high.
        assert!(line[0].1 > line[1].1);
    }

    #[test]
    fn an_all_equal_range_is_padded_so_the_line_sits_inside_the_panel() {
        let flat = one_panel(vec![series("#00aa00", vec![(0.0, 3.0), (5.0, 3.0)])], None);
        let line = polyline(&flat, "#00AA00");
        assert_eq!(line.len(), 2);
        assert_eq!(line[0].1, line[1].1);
        // Mid-panel: the panel spans about 36..296 pixels (title, then one 260-pixel panel).
        assert!((100..240).contains(&line[0].1), "{line:?}");
        let fixed = one_panel(
            vec![series("#00aa00", vec![(0.0, 3.0), (5.0, 3.0)])],
            Some((3.0, 3.0)),
        );
        assert_eq!(polyline(&fixed, "#00AA00")[0].1, line[0].1);
    }

    #[test]
    fn empty_and_single_point_series_still_draw_a_document() {
        for (points, drawn) in [
            (vec![], 0),
            (vec![(1.0, 1.0)], 1),
            (vec![(f64::NAN, f64::NAN)], 0),
        ] {
            let doc = one_panel(vec![series("#123456", points.clone())], None);
            assert!(doc.starts_with("<svg") && doc.trim_end().ends_with("</svg>"));
            assert!(doc.contains(">\nline\n</text>"), "legend for {points:?}");
            assert_eq!(polyline(&doc, "#123456").len(), drawn, "{points:?}");
            let dot = usize::from(drawn == 1);
            assert_eq!(
                doc.matches("<circle").count(),
                dot,
                "a lone point is marked"
            );
        }
        let none = svg("nothing", "x", &[]);
        assert!(none.contains(">\nnothing\n</text>") && !none.contains("<polyline"));
    }

    #[test]
    fn colours_other_than_hex_draw_black() {
        assert_eq!(rgb("#2ca02c"), RGBColor(44, 160, 44));
        assert_eq!(rgb("red"), BLACK);
        assert_eq!(rgb("#12345"), BLACK);
        assert_eq!(rgb("#12345g"), BLACK);
    }
}
