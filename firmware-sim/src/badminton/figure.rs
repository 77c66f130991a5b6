//! One rally drawn from above and from the side, like the paper's figures.
//!
//! ```
//! use firmware_sim::badminton::figure::rally_svg;
//! use firmware_sim::badminton::game::Rally;
//! use firmware_sim::badminton::Config;
//! let rally = Rally {
//!     shuttle: vec![[-2.0, 0.0, 1.2], [0.0, 0.5, 5.0], [5.0, 1.0, 0.3]],
//!     players: vec![[[-2.0, 0.0], [2.0, 0.0]]; 3],
//!     hits: vec![(0, 0)],
//!     end: None,
//! };
//! let svg = rally_svg(&rally, &Config::builtin(), "a serve");
//! assert!(svg.starts_with("<svg") && svg.contains("from above") && svg.contains("from the side"));
//! assert_eq!(svg.matches("<polyline").count(), 4); // shuttle twice, two players
//! ```

use std::fmt::Write;

use super::config::Config;
use super::court::Vec3;
use super::game::Rally;

/// Pixels per metre.
const SCALE: f64 = 40.0;
/// Margin around each view, pixels.
const PAD: f64 = 30.0;
/// Room for the title, pixels.
const TITLE: f64 = 20.0;
const COLOURS: [&str; 2] = ["#1f77b4", "#d62728"];

/// The rally as an SVG document: the court from above (x to the right, y up) with the shuttle's
/// and both players' paths, and from the side (x to the right, z up) with the net; hits are
/// numbered circles in the hitter's colour.
pub fn rally_svg(rally: &Rally, config: &Config, title: &str) -> String {
    let view = View::fit(rally, config);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{:.0}" height="{:.0}" font-family="sans-serif" font-size="12">"#,
        view.width, view.height
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(s, r#"<text x="{PAD}" y="16">{}</text>"#, escape(title));
    view.draw_top(&mut s, rally);
    view.draw_side(&mut s, rally);
    view.draw_hits(&mut s, rally);
    s.push_str("</svg>\n");
    s
}

/// Where things go: both views share the x axis; the top view is above the side view.
struct View {
    half_length: f64,
    half_width: f64,
    net: f64,
    x_lo: f64,
    x_hi: f64,
    y_hi: f64,
    z_hi: f64,
    side_floor: f64,
    width: f64,
    height: f64,
}

impl View {
    /// Fits the court and every sample of the rally (an out ball may fly past the lines).
    fn fit(rally: &Rally, config: &Config) -> View {
        let c = &config.court;
        let xs = rally.shuttle.iter().map(|p| p[0]);
        let x_lo = xs.clone().fold(-c.half_length, f64::min) - 0.5;
        let x_hi = xs.fold(c.half_length, f64::max) + 0.5;
        let y_hi = rally
            .shuttle
            .iter()
            .fold(c.half_width, |m, p| m.max(p[1].abs()))
            + 0.5;
        let z_hi = rally
            .shuttle
            .iter()
            .fold(c.net_height + 1.0, |m, p| m.max(p[2]))
            + 0.5;
        let top_h = 2.0 * y_hi * SCALE + 2.0 * PAD;
        let side_floor = TITLE + top_h + PAD + z_hi * SCALE;
        View {
            half_length: c.half_length,
            half_width: c.half_width,
            net: c.net_height,
            x_lo,
            x_hi,
            y_hi,
            z_hi,
            side_floor,
            width: (x_hi - x_lo) * SCALE + 2.0 * PAD,
            height: side_floor + PAD,
        }
    }

    fn px(&self, x: f64) -> f64 {
        PAD + (x - self.x_lo) * SCALE
    }

    /// A floor point in the top view.
    fn top(&self, p: [f64; 2]) -> (f64, f64) {
        (self.px(p[0]), PAD + TITLE + (self.y_hi - p[1]) * SCALE)
    }

    /// A point of space in the side view.
    fn side(&self, p: Vec3) -> (f64, f64) {
        (self.px(p[0]), self.side_floor - p[2] * SCALE)
    }

    fn draw_top(&self, s: &mut String, rally: &Rally) {
        let (l, w) = (self.half_length, self.half_width);
        let (c0, c1) = (self.top([-l, w]), self.top([l, -w]));
        let _ = writeln!(
            s,
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#eef6ee" stroke="black"/>"##,
            c0.0,
            c0.1,
            c1.0 - c0.0,
            c1.1 - c0.1
        );
        let net = (self.top([0.0, self.y_hi]), self.top([0.0, -self.y_hi]));
        line(s, net, r#"stroke="black" stroke-dasharray="4 3""#);
        let _ = writeln!(
            s,
            r#"<text x="{PAD}" y="{:.1}">from above</text>"#,
            c0.1 - 8.0
        );
        for (player, colour) in COLOURS.iter().enumerate() {
            let path: Vec<(f64, f64)> = rally.players.iter().map(|p| self.top(p[player])).collect();
            polyline(s, &path, colour, 2.0);
        }
        let path: Vec<(f64, f64)> = rally
            .shuttle
            .iter()
            .map(|p| self.top([p[0], p[1]]))
            .collect();
        polyline(s, &path, "black", 1.0);
    }

    fn draw_side(&self, s: &mut String, rally: &Rally) {
        let floor = (
            self.side([self.x_lo, 0.0, 0.0]),
            self.side([self.x_hi, 0.0, 0.0]),
        );
        line(s, floor, r#"stroke="black""#);
        let net = (self.side([0.0, 0.0, 0.0]), self.side([0.0, 0.0, self.net]));
        line(s, net, r#"stroke="black" stroke-width="3""#);
        for x in [-self.half_length, self.half_length] {
            let tick = (self.side([x, 0.0, 0.0]), self.side([x, 0.0, 0.3]));
            line(s, tick, r#"stroke="black""#);
        }
        let label = self.side([self.x_lo, 0.0, self.z_hi]).1 + 4.0;
        let _ = writeln!(s, r#"<text x="{PAD}" y="{label:.1}">from the side</text>"#);
        let path: Vec<(f64, f64)> = rally.shuttle.iter().map(|&p| self.side(p)).collect();
        polyline(s, &path, "black", 1.0);
    }

    fn draw_hits(&self, s: &mut String, rally: &Rally) {
        for (n, &(i, player)) in rally.hits.iter().enumerate() {
            let Some(&p) = rally.shuttle.get(i) else {
                continue;
            };
            for (x, y) in [self.top([p[0], p[1]]), self.side(p)] {
                let _ = writeln!(
                    s,
                    r#"<circle cx="{x:.1}" cy="{y:.1}" r="4" fill="{}"/><text x="{:.1}" y="{:.1}">{}</text>"#,
                    COLOURS[player],
                    x + 5.0,
                    y - 5.0,
                    n + 1
                );
            }
        }
    }
}

fn line(s: &mut String, ends: ((f64, f64), (f64, f64)), style: &str) {
    let ((x1, y1), (x2, y2)) = ends;
    let _ = writeln!(
        s,
        r#"<line x1="{x1:.1}" y1="{y1:.1}" x2="{x2:.1}" y2="{y2:.1}" {style}/>"#
    );
}

fn polyline(s: &mut String, points: &[(f64, f64)], colour: &str, width: f64) {
    let coords: Vec<String> = points
        .iter()
        .map(|(x, y)| format!("{x:.1},{y:.1}"))
        .collect();
    let _ = writeln!(
        s,
        r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="{width}"/>"#,
        coords.join(" ")
    );
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
