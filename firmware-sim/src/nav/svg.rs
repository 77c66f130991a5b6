//! Trajectory plots as SVG: the arena, the walls, and every test's path (like the paper's
//! trajectory figures). Green paths settled near the centre, red ones got stuck at a wall,
//! orange ones did neither (wandered, looped, or left the arena).
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

use super::metrics::EpisodeRecord;
use super::scenario::{Scenario, Wall};
use super::test_protocol::Report;

/// Pixels per arena unit.
const SCALE: f64 = 40.0;
/// Blank border around the arena, in pixels.
const BORDER: f64 = 20.0;

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
    let mut plot = Plot::start(scenario, &report.controller);
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
    /// Writes the header: the arena, the success circle, the title.
    pub fn start(mut out: W, scenario: &Scenario, controller: &str) -> io::Result<Self> {
        let mut plot = Plot::start(scenario, controller);
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
    pending: String,
}

impl Plot {
    fn start(scenario: &Scenario, controller: &str) -> Plot {
        let h = scenario.arena_half_size;
        let mut plot = Plot {
            half_size: h,
            walls: scenario.walls.clone(),
            pending: String::new(),
        };
        let size = 2.0 * h * SCALE + 2.0 * BORDER;
        let c = plot.px(0.0);
        let out = &mut plot.pending;
        let _ = writeln!(
            out,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size}" viewBox="0 0 {size} {size}">"#
        );
        let _ = writeln!(
            out,
            "<title>{} — {}</title>",
            escape(&scenario.name),
            escape(controller)
        );
        let _ = writeln!(
            out,
            r##"<rect x="{b}" y="{b}" width="{w}" height="{w}" fill="#fbfbf8" stroke="#888" stroke-dasharray="6 4"/>"##,
            b = BORDER,
            w = 2.0 * h * SCALE
        );
        let r = scenario.metrics.success_radius * SCALE;
        let _ = writeln!(
            out,
            r##"<circle cx="{c}" cy="{c}" r="{r}" fill="none" stroke="#9c9" stroke-dasharray="3 3"/>"##
        );
        plot
    }

    fn px(&self, x: f64) -> f64 {
        BORDER + (x + self.half_size) * SCALE
    }

    fn py(&self, y: f64) -> f64 {
        BORDER + (self.half_size - y) * SCALE
    }

    fn episode(&mut self, e: &EpisodeRecord) {
        let mut out = std::mem::take(&mut self.pending);
        path(&mut out, e, &|x| self.px(x), &|y| self.py(y));
        self.pending = out;
    }

    fn finish(mut self) -> String {
        let mut out = std::mem::take(&mut self.pending);
        for w in &self.walls {
            let _ = writeln!(
                out,
                r##"<line class="wall" x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="#222" stroke-width="4" stroke-linecap="round"/>"##,
                self.px(w.from[0]),
                self.py(w.from[1]),
                self.px(w.to[0]),
                self.py(w.to[1])
            );
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
}

fn path(out: &mut String, e: &EpisodeRecord, px: &dyn Fn(f64) -> f64, py: &dyn Fn(f64) -> f64) {
    if e.trajectory.is_empty() {
        return;
    }
    let colour = if e.success && !e.stuck {
        "#2a8a2a"
    } else if e.stuck {
        "#c0392b"
    } else {
        "#e67e22"
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
