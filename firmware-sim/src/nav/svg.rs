//! Trajectory plots as SVG: the arena, the walls, and every test's path (like the paper's
//! trajectory figures). Green paths settled near the centre, red ones got stuck at a wall,
//! orange ones did neither (wandered, looped, or left the arena). The picture says so itself:
//! a title, a legend, the arena's coordinates along two edges, and a wall added or moved by
//! `--faults wall:...` drawn in blue (a moved wall's first place dashed), so no path stops in
//! mid-air.
//!
//! [`render`] draws a whole report; [`SvgWriter`] draws the same document one episode at a
//! time, for evaluations too large to keep (every trajectory is drawn either way).
//!
//! Written by hand rather than with plotters, which draws the other figures: plotters' SVG
//! backend builds the whole document in one `String` (its file target writes that string only
//! when the drawing is presented) and has no `io::Write` target, so a long `firmware-sim run
//! --svg` would hold every episode's path until the end. Here each path goes to the writer as
//! its episode ends. [`render`] is the same writer run over a finished report, so both give the
//! same bytes; it stays with the writer rather than becoming a second, different drawing.

use std::fmt::Write;
use std::io;

use super::faults::WallChange;
use super::metrics::EpisodeRecord;
use super::scenario::{Scenario, Wall};
use super::test_protocol::Report;

/// Pixels per arena unit.
const SCALE: f64 = 40.0;
/// Blank border around the arena, in pixels, on the right.
const BORDER: f64 = 20.0;
/// Room for the y coordinates, left of the arena.
const LEFT: f64 = 44.0;
/// Room for the title, above the arena.
const TOP: f64 = 30.0;
/// Room for the x coordinates below the arena, then one legend row per entry.
const BELOW: f64 = 28.0;
/// A legend row's height.
const ROW: f64 = 16.0;
/// The narrowest picture: the legend's text must fit beside a small arena.
const MIN_WIDTH: f64 = 380.0;

const SETTLED: &str = "#2a8a2a";
const STUCK: &str = "#c0392b";
const NEITHER: &str = "#e67e22";
const FAULT_WALL: &str = "#1f5fbf";

/// Renders the scenario's walls and the report's trajectories (empty paths if the evaluation
/// did not record them).
///
/// ```
/// use firmware_sim::nav::straight::Straight;
/// use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};
/// use firmware_sim::nav::scenario::Scenario;
/// use firmware_sim::nav::svg::render;
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let cfg = EvalConfig { episodes: 3, record_trajectories: true, ..EvalConfig::default() };
/// let r = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg).unwrap();
/// let svg = render(&s, &r);
/// assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
/// assert_eq!(svg.matches("<polyline").count(), 3);
/// assert_eq!(svg.matches("class=\"wall\"").count(), 13);
/// ```
pub fn render(scenario: &Scenario, report: &Report) -> String {
    render_with_faults(scenario, report, None)
}

/// [`render`], with the wall that `--faults wall:...` added or moved drawn too.
///
/// ```
/// use firmware_sim::nav::faults::Faults;
/// use firmware_sim::nav::straight::Straight;
/// use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};
/// use firmware_sim::nav::scenario::Scenario;
/// use firmware_sim::nav::svg::render_with_faults;
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let faults: Faults = "wall:20@-2/0/2/0".parse().unwrap();
/// let cfg = EvalConfig { episodes: 2, record_trajectories: true, faults, ..EvalConfig::default() };
/// let r = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg).unwrap();
/// let svg = render_with_faults(&s, &r, cfg.faults.wall);
/// assert_eq!(svg.matches("class=\"wall fault\"").count(), 1);
/// assert!(svg.contains("wall from --faults, from tick 20"));
/// ```
pub fn render_with_faults(
    scenario: &Scenario,
    report: &Report,
    wall_change: Option<WallChange>,
) -> String {
    let mut plot = Plot::start(scenario, &report.controller, wall_change);
    for e in &report.episodes {
        plot.episode(e);
    }
    plot.finish()
}

/// A plot drawn piece by piece, so the CLI can stream it: [`SvgWriter::start`] writes the
/// header, [`SvgWriter::episode`] one trajectory as soon as its episode ends, and
/// [`SvgWriter::finish`] the walls (drawn over the paths) and the closing tag. Only one
/// episode's path is held at a time.
///
/// ```
/// use firmware_sim::nav::straight::Straight;
/// use firmware_sim::nav::test_protocol::{evaluate_controller, evaluate_streaming, EvalConfig};
/// use firmware_sim::nav::scenario::Scenario;
/// use firmware_sim::nav::svg::{render, SvgWriter};
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let cfg = EvalConfig { episodes: 3, record_trajectories: true, ..EvalConfig::default() };
/// let mut svg = SvgWriter::start(Vec::new(), &s, "straight").unwrap();
/// evaluate_streaming(&mut Straight { max_step: 0.25 }, &s, &cfg, |e| svg.episode(&e)).unwrap();
/// let streamed = svg.finish().unwrap();
/// let r = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg).unwrap();
/// assert_eq!(String::from_utf8(streamed).unwrap(), render(&s, &r));
/// ```
#[derive(Debug)]
pub struct SvgWriter<W: io::Write> {
    out: W,
    plot: Plot,
}

impl<W: io::Write> SvgWriter<W> {
    /// Writes the header: the arena, its coordinates, the success circle, the title, the
    /// legend.
    pub fn start(out: W, scenario: &Scenario, controller: &str) -> io::Result<Self> {
        Self::start_with_faults(out, scenario, controller, None)
    }

    /// [`start`](Self::start), for a run whose `--faults` add or move a wall (drawn with
    /// the scenario's).
    pub fn start_with_faults(
        mut out: W,
        scenario: &Scenario,
        controller: &str,
        wall_change: Option<WallChange>,
    ) -> io::Result<Self> {
        let mut plot = Plot::start(scenario, controller, wall_change);
        out.write_all(plot.take().as_bytes())?;
        Ok(SvgWriter { out, plot })
    }

    /// Draws one episode's trajectory (nothing if it was not recorded).
    pub fn episode(&mut self, e: &EpisodeRecord) -> io::Result<()> {
        self.plot.episode(e);
        self.out.write_all(self.plot.take().as_bytes())
    }

    /// Draws the walls and closes the document; returns the writer.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.write_all(self.plot.finish().as_bytes())?;
        Ok(self.out)
    }
}

/// The SVG text of a plot, built in order; `pending` holds what is not yet written out.
#[derive(Debug)]
struct Plot {
    half_size: f64,
    walls: Vec<Wall>,
    wall_change: Option<WallChange>,
    pending: String,
}

impl Plot {
    fn start(scenario: &Scenario, controller: &str, wall_change: Option<WallChange>) -> Plot {
        let h = scenario.arena_half_size;
        let mut plot = Plot {
            half_size: h,
            walls: scenario.walls.clone(),
            wall_change,
            pending: String::new(),
        };
        let side = 2.0 * h * SCALE;
        let legend = legend(scenario, wall_change);
        let width = (LEFT + side + BORDER).max(MIN_WIDTH);
        let height = TOP + side + BELOW + ROW * legend.len() as f64;
        let c = (plot.px(0.0), plot.py(0.0));
        let out = &mut plot.pending;
        let _ = writeln!(
            out,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">"#
        );
        let title = format!("{} — {}", escape(&scenario.name), escape(controller));
        let _ = writeln!(out, "<title>{title}</title>");
        let _ = writeln!(
            out,
            r##"<text x="{LEFT}" y="{:.1}" font-size="14">{title}</text>"##,
            TOP - 10.0
        );
        let _ = writeln!(
            out,
            r##"<rect x="{LEFT}" y="{TOP}" width="{side}" height="{side}" fill="#fbfbf8" stroke="#888" stroke-dasharray="6 4"/>"##
        );
        plot.axes();
        let out = &mut plot.pending;
        let r = scenario.metrics.success_radius * SCALE;
        let _ = writeln!(
            out,
            r##"<circle cx="{}" cy="{}" r="{r}" fill="none" stroke="#9c9" stroke-dasharray="3 3"/>"##,
            c.0, c.1
        );
        let top = TOP + side + BELOW;
        for (k, (swatch, text)) in legend.iter().enumerate() {
            let y = top + ROW * k as f64 + ROW / 2.0;
            let _ = writeln!(out, "{}", swatch.draw(LEFT, y));
            let _ = writeln!(
                out,
                r##"<text x="{:.1}" y="{:.1}">{}</text>"##,
                LEFT + 30.0,
                y + 4.0,
                escape(text)
            );
        }
        plot
    }

    /// The arena's coordinates: ticks and numbers below it (x) and left of it (y), about ten
    /// each way, at a round step.
    fn axes(&mut self) {
        let h = self.half_size;
        let step = (-3..12)
            .flat_map(|e| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(e)))
            .find(|step| 2.0 * h / step <= 12.0)
            .unwrap_or(2.0 * h);
        let first = (-h / step).ceil() as i64;
        let last = (h / step).floor() as i64;
        let (bottom, left) = (self.py(-h), self.px(-h));
        let mut out = std::mem::take(&mut self.pending);
        for k in first..=last {
            let v = k as f64 * step;
            let (x, y) = (self.px(v), self.py(v));
            let _ = writeln!(
                out,
                r##"<line x1="{x:.1}" y1="{bottom:.1}" x2="{x:.1}" y2="{:.1}" stroke="#888"/><text x="{x:.1}" y="{:.1}" text-anchor="middle" fill="#555">{v}</text>"##,
                bottom + 4.0,
                bottom + 16.0
            );
            let _ = writeln!(
                out,
                r##"<line x1="{left:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#888"/><text x="{:.1}" y="{:.1}" text-anchor="end" fill="#555">{v}</text>"##,
                left - 4.0,
                left - 6.0,
                y + 4.0
            );
        }
        let _ = writeln!(
            out,
            r##"<text x="{:.1}" y="{:.1}" text-anchor="end" fill="#555">x, y in arena units</text>"##,
            self.px(h),
            TOP - 10.0
        );
        self.pending = out;
    }

    fn px(&self, x: f64) -> f64 {
        LEFT + (x + self.half_size) * SCALE
    }

    fn py(&self, y: f64) -> f64 {
        TOP + (self.half_size - y) * SCALE
    }

    fn episode(&mut self, e: &EpisodeRecord) {
        let mut out = std::mem::take(&mut self.pending);
        path(&mut out, e, &|x| self.px(x), &|y| self.py(y));
        self.pending = out;
    }

    fn finish(mut self) -> String {
        let mut out = std::mem::take(&mut self.pending);
        let moved = self.wall_change.and_then(|c| c.replaces);
        for (i, w) in self.walls.iter().enumerate() {
            let style = if moved == Some(i) {
                // Where the moved wall stood until its tick.
                r##"class="wall moved" stroke="#222" stroke-width="2" stroke-dasharray="6 4""##
            } else {
                r##"class="wall" stroke="#222" stroke-width="4" stroke-linecap="round""##
            };
            let _ = writeln!(out, "{}", self.line(w, style));
        }
        if let Some(change) = self.wall_change {
            let style = format!(
                r##"class="wall fault" stroke="{FAULT_WALL}" stroke-width="4" stroke-linecap="round""##
            );
            let _ = writeln!(out, "{}", self.line(&change.wall, &style));
        }
        let _ = writeln!(
            out,
            r##"<circle cx="{c}" cy="{c}" r="4" fill="#070"/>"##,
            c = self.px(0.0)
        );
        out.push_str("</svg>\n");
        self.pending = out;
        self.take()
    }

    /// The text not yet written out.
    fn take(&mut self) -> String {
        std::mem::take(&mut self.pending)
    }

    fn line(&self, w: &Wall, style: &str) -> String {
        format!(
            r##"<line {style} x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}"/>"##,
            self.px(w.from[0]),
            self.py(w.from[1]),
            self.px(w.to[0]),
            self.py(w.to[1])
        )
    }
}

/// What a legend row shows before its text.
enum Swatch {
    /// A path of this colour.
    Path(&'static str),
    /// A wall: its colour and dash pattern.
    Wall(&'static str, Option<&'static str>),
    /// The success circle.
    Circle,
}

impl Swatch {
    fn draw(&self, x: f64, y: f64) -> String {
        let (x1, x2) = (x, x + 22.0);
        match self {
            Swatch::Path(colour) => format!(
                r##"<line x1="{x1}" y1="{y}" x2="{x2}" y2="{y}" stroke="{colour}" stroke-width="2"/>"##
            ),
            Swatch::Wall(colour, dash) => format!(
                r##"<line x1="{x1}" y1="{y}" x2="{x2}" y2="{y}" stroke="{colour}" stroke-width="{}"{}/>"##,
                if dash.is_some() { 2 } else { 4 },
                dash.map(|d| format!(r#" stroke-dasharray="{d}""#))
                    .unwrap_or_default()
            ),
            Swatch::Circle => format!(
                r##"<circle cx="{}" cy="{y}" r="6" fill="none" stroke="#9c9" stroke-dasharray="3 3"/>"##,
                x + 11.0
            ),
        }
    }
}

/// The legend's rows: the three path colours, the walls, the success circle.
fn legend(scenario: &Scenario, wall_change: Option<WallChange>) -> Vec<(Swatch, String)> {
    let radius = scenario.metrics.success_radius;
    let mut rows = vec![
        (
            Swatch::Path(SETTLED),
            format!("settled: within {radius} of the goal at the end"),
        ),
        (Swatch::Path(STUCK), "stuck at a wall (margin)".to_string()),
        (
            Swatch::Path(NEITHER),
            "neither: wandered, looped or left the arena".to_string(),
        ),
        (Swatch::Wall("#222", None), "wall".to_string()),
        (Swatch::Circle, format!("success radius {radius}")),
    ];
    if let Some(change) = wall_change {
        let tick = change.at_tick;
        rows.push((
            Swatch::Wall(FAULT_WALL, None),
            match change.replaces {
                Some(i) => format!("wall from --faults, from tick {tick}: wall {i} moved here"),
                None => format!("wall from --faults, from tick {tick}"),
            },
        ));
        if change.replaces.is_some() {
            rows.push((
                Swatch::Wall("#222", Some("6 4")),
                format!("that wall before tick {tick}"),
            ));
        }
    }
    rows
}

fn path(out: &mut String, e: &EpisodeRecord, px: &dyn Fn(f64) -> f64, py: &dyn Fn(f64) -> f64) {
    if e.trajectory.is_empty() {
        return;
    }
    let colour = if e.success && !e.stuck {
        SETTLED
    } else if e.stuck {
        STUCK
    } else {
        NEITHER
    };
    let points = thin(
        e.trajectory
            .iter()
            .map(|p| (px(f64::from(p[0])), py(f64::from(p[1])))),
    );
    let _ = writeln!(
        out,
        r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="1.2" stroke-opacity="0.7"/>"#,
        points.join(" ")
    );
    let _ = writeln!(
        out,
        r#"<circle cx="{:.1}" cy="{:.1}" r="2.5" fill="{colour}"/>"#,
        px(e.start[0]),
        py(e.start[1])
    );
}

/// The points as `x,y` pairs, dropping those within half a pixel of the last one kept (an
/// agent stuck at a wall repeats its position for most of the episode).
fn thin(points: impl Iterator<Item = (f64, f64)>) -> Vec<String> {
    let mut kept: Vec<(f64, f64)> = Vec::new();
    let mut last_seen = None;
    for p in points {
        last_seen = Some(p);
        if kept
            .last()
            .is_none_or(|k| (k.0 - p.0).hypot(k.1 - p.1) >= 0.5)
        {
            kept.push(p);
        }
    }
    if let (Some(p), Some(k)) = (last_seen, kept.last()) {
        if *k != p {
            kept.push(p);
        }
    }
    kept.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect()
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
