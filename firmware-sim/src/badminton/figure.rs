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
const COLOURS: [&str; 2] = ["#1f77b4", "#d62728"];

/// The rally as an SVG document: the court from above (x to the right, y up) with the shuttle's
/// and both players' paths, and from the side (x to the right, z up) with the net; hits are
/// numbered circles.
pub fn rally_svg(rally: &Rally, config: &Config, title: &str) -> String {
    let (l, w, net) = (
        config.court.half_length,
        config.court.half_width,
        config.court.net_height,
    );
    let xs = rally.shuttle.iter().map(|p| p[0]);
    let x_lo = xs.clone().fold(-l, f64::min) - 0.5;
    let x_hi = xs.fold(l, f64::max) + 0.5;
    let y_hi = rally.shuttle.iter().fold(w, |m, p| m.max(p[1].abs())) + 0.5;
    let z_hi = rally.shuttle.iter().fold(net + 1.0, |m, p| m.max(p[2])) + 0.5;
    let width = (x_hi - x_lo) * SCALE + 2.0 * PAD;
    let top_h = 2.0 * y_hi * SCALE + 2.0 * PAD;
    let side_h = z_hi * SCALE + 2.0 * PAD;
    let px = |x: f64| PAD + (x - x_lo) * SCALE;
    let top = |p: [f64; 2]| (px(p[0]), PAD + 20.0 + (y_hi - p[1]) * SCALE);
    let side_y0 = 20.0 + top_h + PAD + z_hi * SCALE;
    let side = |p: Vec3| (px(p[0]), side_y0 - p[2] * SCALE);
    let height = 20.0 + top_h + side_h + 10.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(s, r#"<text x="{PAD}" y="16">{}</text>"#, escape(title));
    // From above: the court, the net line, the paths.
    let (c0, c1) = (top([-l, w]), top([l, -w]));
    let _ = writeln!(
        s,
        r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#eef6ee" stroke="black"/>"##,
        c0.0,
        c0.1,
        c1.0 - c0.0,
        c1.1 - c0.1
    );
    let (n0, n1) = (top([0.0, y_hi]), top([0.0, -y_hi]));
    let _ = writeln!(
        s,
        r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="black" stroke-dasharray="4 3"/>"#,
        n0.0, n0.1, n1.0, n1.1
    );
    let _ = writeln!(
        s,
        r#"<text x="{PAD}" y="{:.1}">from above</text>"#,
        c0.1 - 8.0
    );
    for (player, colour) in COLOURS.iter().enumerate() {
        let path: Vec<(f64, f64)> = rally.players.iter().map(|p| top(p[player])).collect();
        polyline(&mut s, &path, colour, 2.0);
    }
    let path: Vec<(f64, f64)> = rally.shuttle.iter().map(|p| top([p[0], p[1]])).collect();
    polyline(&mut s, &path, "black", 1.0);
    // From the side: the floor, the net, the shuttle's path.
    let (f0, f1) = (side([x_lo, 0.0, 0.0]), side([x_hi, 0.0, 0.0]));
    let _ = writeln!(
        s,
        r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="black"/>"#,
        f0.0, f0.1, f1.0, f1.1
    );
    let (b0, b1) = (side([0.0, 0.0, 0.0]), side([0.0, 0.0, net]));
    let _ = writeln!(
        s,
        r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="black" stroke-width="3"/>"#,
        b0.0, b0.1, b1.0, b1.1
    );
    for x in [-l, l] {
        let (t0, t1) = (side([x, 0.0, 0.0]), side([x, 0.0, 0.3]));
        let _ = writeln!(
            s,
            r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="black"/>"#,
            t0.0, t0.1, t1.0, t1.1
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{PAD}" y="{:.1}">from the side</text>"#,
        side([x_lo, 0.0, z_hi]).1 + 4.0
    );
    let path: Vec<(f64, f64)> = rally.shuttle.iter().map(|&p| side(p)).collect();
    polyline(&mut s, &path, "black", 1.0);
    for (n, &(i, player)) in rally.hits.iter().enumerate() {
        let Some(&p) = rally.shuttle.get(i) else {
            continue;
        };
        for (x, y) in [top([p[0], p[1]]), side(p)] {
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
    s.push_str("</svg>\n");
    s
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
