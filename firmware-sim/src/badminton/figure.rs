//! One rally drawn from above and from the side, like the paper's figures, with plotters.
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
//! // Each player's path once from above, in the player's colour; the shuttle's in both views.
//! let paths = |stroke: &str| svg.matches(&format!(r#"stroke="{stroke}" stroke-width="2" points"#)).count();
//! assert_eq!((paths("#1F77B4"), paths("#D62728")), (1, 1));
//! let shuttle = svg.lines().filter(|l| l.contains(r##"stroke="#000000" stroke-width="1" points"##)
//!     && l.matches(',').count() == 3).count();
//! assert_eq!(shuttle, 2);
//! // The hit: a dot in the hitter's colour in each view.
//! assert_eq!(svg.matches(r##"<circle"##).count(), 2);
//! ```

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::config::Config;
use super::game::Rally;

/// Pixels per metre, the same along every axis.
const SCALE: f64 = 40.0;
/// Blank border around each view, pixels.
const MARGIN: u32 = 10;
/// Room above each view for its name, pixels.
const CAPTION: u32 = 22;
/// Room for the tick labels left of the views, pixels.
const Y_AREA: u32 = 48;
/// Room for the tick labels under the top view, and labels and axis name under the side view.
const X_AREA: [u32; 2] = [24, 40];
/// The players' colours: player 0 blue, player 1 red.
const COLOURS: [RGBColor; 2] = [RGBColor(31, 119, 180), RGBColor(214, 39, 40)];
const COURT: RGBColor = RGBColor(238, 246, 238);

type Drawn = Result<(), DrawingAreaErrorKind<std::io::Error>>;

/// The rally as an SVG document: the court from above (x to the right, y up) with the shuttle's
/// and both players' paths, and from the side (x to the right, z up) with the net; hits are
/// numbered dots in the hitter's colour. Both views share the x axis and draw a metre as the
/// same number of pixels on every axis. Non-finite samples are left out.
pub fn rally_svg(rally: &Rally, config: &Config, title: &str) -> String {
    let title_font = ("sans-serif", 15).into_font();
    let title_width = title_font.box_size(title).map_or(0, |(w, _)| w);
    let view = View::fit(rally, config, title_width + 2 * MARGIN);
    let mut text = String::new();
    let drawn = {
        let root =
            SVGBackend::with_string(&mut text, (view.width, view.height)).into_drawing_area();
        view.draw(&root, rally, title, title_font)
    };
    match drawn {
        Ok(()) => text,
        Err(e) => failed(&e),
    }
}

/// Where things go: both views share the x axis; the top view is above the side view.
struct View {
    half_length: f64,
    half_width: f64,
    net: f64,
    x: (f64, f64),
    y_hi: f64,
    z_hi: f64,
    /// Pixel heights of the title and of each view's area.
    heights: [u32; 3],
    width: u32,
    height: u32,
}

impl View {
    /// Fits the court and every sample of the rally (an out ball may fly past the lines), and
    /// widens the x range if the title needs more room than the court.
    fn fit(rally: &Rally, config: &Config, min_width: u32) -> View {
        let c = &config.court;
        let samples = || {
            rally
                .shuttle
                .iter()
                .filter(|p| p.iter().all(|v| v.is_finite()))
        };
        let x_lo = samples().fold(-c.half_length, |m, p| m.min(p[0])) - 0.5;
        let x_hi = samples().fold(c.half_length, |m, p| m.max(p[0])) + 0.5;
        let y_hi = samples().fold(c.half_width, |m, p| m.max(p[1].abs())) + 0.5;
        let z_hi = samples().fold(c.net_height + 1.0, |m, p| m.max(p[2])) + 0.5;
        let px = |metres: f64| (metres * SCALE).ceil() as u32;
        let frame = Y_AREA + 2 * MARGIN;
        let width = (px(x_hi - x_lo) + frame).max(min_width);
        let extra = f64::from(width - frame) / SCALE - (x_hi - x_lo);
        let title = 15 + 10;
        let top = px(2.0 * y_hi) + CAPTION + 2 * MARGIN + X_AREA[0];
        let side = px(z_hi) + CAPTION + 2 * MARGIN + X_AREA[1];
        View {
            half_length: c.half_length,
            half_width: c.half_width,
            net: c.net_height,
            x: (x_lo - extra / 2.0, x_hi + extra / 2.0),
            y_hi,
            z_hi,
            heights: [title, top, side],
            width,
            height: title + top + side,
        }
    }

    fn draw(
        &self,
        root: &DrawingArea<SVGBackend<'_>, Shift>,
        rally: &Rally,
        title: &str,
        title_font: FontDesc<'_>,
    ) -> Drawn {
        root.fill(&WHITE)?;
        let centre = Pos::new(HPos::Center, VPos::Center);
        root.draw_text(
            title,
            &title_font.into_text_style(root).pos(centre),
            ((self.width / 2) as i32, (self.heights[0] / 2) as i32),
        )?;
        let (_, body) = root.split_vertically(self.heights[0]);
        let (top, side) = body.split_vertically(self.heights[1]);
        self.draw_top(&top, rally)?;
        self.draw_side(&side, rally)?;
        root.present()
    }

    fn draw_top(&self, area: &DrawingArea<SVGBackend<'_>, Shift>, rally: &Rally) -> Drawn {
        let mut chart = self.chart(area, 0, (-self.y_hi, self.y_hi))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .y_desc("y (m)")
            .draw()?;
        let (l, w) = (self.half_length, self.half_width);
        chart.draw_series([
            Rectangle::new([(-l, -w), (l, w)], COURT.filled()),
            Rectangle::new([(-l, -w), (l, w)], BLACK.stroke_width(1)),
        ])?;
        chart.draw_series(std::iter::once(DashedPathElement::new(
            [(0.0, self.y_hi), (0.0, -self.y_hi)],
            4,
            3,
            BLACK,
        )))?;
        for (player, colour) in COLOURS.iter().enumerate() {
            let path = rally.players.iter().map(|p| p[player]).map(|[x, y]| (x, y));
            chart.draw_series(std::iter::once(PathElement::new(
                finite(path),
                colour.stroke_width(2),
            )))?;
        }
        let path = rally.shuttle.iter().map(|p| (p[0], p[1]));
        chart.draw_series(std::iter::once(PathElement::new(finite(path), BLACK)))?;
        self.draw_hits(&mut chart, rally, |p| (p[0], p[1]))?;
        caption(area, "from above")
    }

    fn draw_side(&self, area: &DrawingArea<SVGBackend<'_>, Shift>, rally: &Rally) -> Drawn {
        let mut chart = self.chart(area, 1, (0.0, self.z_hi))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (m), player 0 plays from x < 0")
            .y_desc("height (m)")
            .draw()?;
        chart.draw_series(std::iter::once(PathElement::new(
            [(0.0, 0.0), (0.0, self.net)],
            BLACK.stroke_width(3),
        )))?;
        chart.draw_series(
            [-self.half_length, self.half_length]
                .map(|x| PathElement::new([(x, 0.0), (x, 0.3)], BLACK.stroke_width(2))),
        )?;
        let path = rally.shuttle.iter().map(|p| (p[0], p[2]));
        chart.draw_series(std::iter::once(PathElement::new(finite(path), BLACK)))?;
        self.draw_hits(&mut chart, rally, |p| (p[0], p[2]))?;
        caption(area, "from the side")
    }

    /// A view's chart: the shared x range, `y` upwards, a metre as `SCALE` pixels.
    fn chart<'a, 'b>(
        &self,
        area: &'a DrawingArea<SVGBackend<'b>, Shift>,
        which: usize,
        y: (f64, f64),
    ) -> Result<Chart<'a, 'b>, DrawingAreaErrorKind<std::io::Error>> {
        ChartBuilder::on(area)
            .margin(MARGIN)
            .margin_top(MARGIN + CAPTION)
            .x_label_area_size(X_AREA[which])
            .y_label_area_size(Y_AREA)
            .build_cartesian_2d(self.x.0..self.x.1, y.0..y.1)
    }

    /// Numbered dots where the shuttle was hit, in the hitter's colour.
    fn draw_hits(
        &self,
        chart: &mut Chart<'_, '_>,
        rally: &Rally,
        project: impl Fn(&[f64; 3]) -> (f64, f64),
    ) -> Drawn {
        let dots = rally
            .hits
            .iter()
            .enumerate()
            .filter_map(|(n, &(i, player))| {
                let p = project(rally.shuttle.get(i)?);
                let colour = *COLOURS.get(player)?;
                (p.0.is_finite() && p.1.is_finite()).then(|| {
                    EmptyElement::at(p)
                        + Circle::new((0, 0), 4, colour.filled())
                        + Text::new(format!("{}", n + 1), (5, -16), ("sans-serif", 13))
                })
            });
        chart.draw_series(dots)?;
        Ok(())
    }
}

type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The view's name in the room left above it.
fn caption(area: &DrawingArea<SVGBackend<'_>, Shift>, name: &str) -> Drawn {
    area.draw_text(
        name,
        &("sans-serif", 14).into_text_style(area),
        (MARGIN as i32, MARGIN as i32),
    )
}

/// The finite points, dropping those closer than `STEP` pixels to the last one kept (the last
/// point is always kept): plotters draws on whole pixels, so samples a pixel apart would draw a
/// staircase.
fn finite(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    const STEP: f64 = 3.0 / SCALE;
    let mut kept: Vec<(f64, f64)> = Vec::new();
    let mut last = None;
    for p in points.filter(|p| p.0.is_finite() && p.1.is_finite()) {
        last = Some(p);
        if kept
            .last()
            .is_none_or(|k| (k.0 - p.0).hypot(k.1 - p.1) >= STEP)
        {
            kept.push(p);
        }
    }
    if let (Some(p), Some(k)) = (last, kept.last()) {
        if *k != p {
            kept.push(p);
        }
    }
    kept
}

/// A document saying the figure could not be drawn (best effort: it is what is left to say).
fn failed(e: &DrawingAreaErrorKind<std::io::Error>) -> String {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (720, 40)).into_drawing_area();
        let message = format!("the rally could not be drawn: {e}");
        let _ = root.draw(&Text::new(message, (10, 20), ("sans-serif", 14)));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The point counts of the black one-pixel polylines (the shuttle's paths, the net's dashes).
    fn shuttle_paths(svg: &str) -> Vec<usize> {
        svg.lines()
            .filter(|l| l.contains(r##"stroke="#000000" stroke-width="1" points"##))
            .map(|l| l.matches(',').count())
            .collect()
    }

    #[test]
    fn non_finite_samples_and_hits_that_point_nowhere_are_left_out() {
        let rally = Rally {
            shuttle: vec![
                [-2.0, 0.0, 1.2],
                [f64::NAN, 0.5, 5.0],
                [0.0, 0.5, 5.0],
                [5.0, 1.0, 0.3],
            ],
            players: vec![[[-2.0, 0.0], [2.0, 0.0]]; 4],
            hits: vec![(0, 0), (1, 1), (9, 0), (3, 7)],
            end: None,
        };
        let svg = rally_svg(&rally, &Config::builtin(), "t");
        assert!(!svg.contains("NaN"));
        // The net's dashes are two-point paths too; the shuttle's keep the three finite samples.
        let paths = shuttle_paths(&svg);
        let shuttle: Vec<usize> = paths.into_iter().filter(|&n| n > 2).collect();
        assert_eq!(shuttle, vec![3, 3], "both views, without the NaN sample");
        // Only the first hit has a finite sample, a sample and a player.
        assert_eq!(svg.matches("<circle").count(), 2);
    }

    #[test]
    fn an_empty_rally_draws_the_court_alone() {
        let rally = Rally {
            shuttle: vec![],
            players: vec![],
            hits: vec![(0, 0)],
            end: None,
        };
        let svg = rally_svg(&rally, &Config::builtin(), "nothing");
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("from above") && svg.contains(">\nnothing\n</text>"));
        assert_eq!(svg.matches("<circle").count(), 0);
        assert_eq!(svg.matches(r##"fill="#EEF6EE""##).count(), 1, "the court");
    }

    #[test]
    fn dense_samples_are_thinned_but_keep_both_ends() {
        let dense = (0..=100).map(|i| (f64::from(i) * 0.001, 0.0));
        let kept = finite(dense);
        assert_eq!(kept.first(), Some(&(0.0, 0.0)));
        assert_eq!(kept.last(), Some(&(0.1, 0.0)));
        // 0.1 m is 4 pixels: the start, one point 3 pixels on, and the end.
        assert_eq!(kept.len(), 3, "{kept:?}");
    }
}
