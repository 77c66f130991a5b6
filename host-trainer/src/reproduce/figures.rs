//! Experiment 1's figures 4–7 as SVG, drawn with plotters from the run folders alone.
//!
//! - Figures 4 and 5: trajectories of each agent's exported blob from the same test starts,
//!   with walls and without, one panel per agent (the run of the lowest finished seed).
//! - Figure 6: the settled error of the successful tests, per agent, with and without walls, as
//!   box plots over every finished seed's tests.
//! - Figure 7: steps to the goal (within 0.1 for 10 steps), per agent, with and without walls:
//!   the mean over seeds of each run's mean, with its 95 % interval.
//! - Figure 8 (not the paper's): the performance profile of success over the five network
//!   sizes, per agent: the share of runs whose success is above each threshold, with its 95 %
//!   stratified bootstrap band, as rliable draws it.

use std::path::Path;

use firmware_sim::boot::{self, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::files;
use firmware_sim::heads::HeadsPolicy;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{self, EvalConfig};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::folder::{Finished, Outcome};
use super::grid::{Agent, Cell, GridRun, Walls, AGENTS};
use crate::algorithms::Algo;
use crate::run::folder;
use crate::stats::aggregate::performance_profile_ci;
use crate::stats::bootstrap::Interval;
use crate::stats::student_t::mean_interval;
use crate::stats::{CONFIDENCE, REPS, SEED};
use crate::Error;

/// Test starts drawn per panel of figures 4–5.
pub const TRAJECTORY_STARTS: usize = 12;
/// The seed of those starts: every panel starts from the same points.
pub const TRAJECTORY_SEED: u64 = 0;

type Drawn = Result<(), DrawingAreaErrorKind<std::io::Error>>;

fn drawing(what: &str, e: impl std::fmt::Display) -> Error {
    Error::Sim {
        context: format!("drawing {what}"),
        message: e.to_string(),
    }
}

/// The task's walls and arena, as `train` read them.
fn scenario(walls: Walls) -> Result<Scenario, Error> {
    crate::run::trainer::scenario(match walls {
        Walls::With => "nav-walls",
        Walls::Without => "nav-open",
    })
}

/// The paths of a finished run's blob from the figure's starts, run as firmware-sim runs it
/// (an actor of several heads with its critic choosing).
pub fn paths(run: &Finished, scenario: &Scenario) -> Result<Vec<Vec<[f32; 2]>>, Error> {
    let read = |name: &str| {
        let path = run.dir.join(name);
        files::read_blob(&path).map_err(|source| Error::Io { path, source })
    };
    let sim = |e: firmware_sim::Error| Error::Sim {
        context: format!("the blob of {}", run.dir.display()),
        message: e.to_string(),
    };
    let blob = read(folder::POLICY)?;
    let plant = PlantSizes::of(scenario).map_err(sim)?;
    let heads = run.config.algo == Algo::Dcp && run.config.dcp.heads > 1;
    let critic = if heads {
        read(folder::CRITIC)?
    } else {
        Vec::new()
    };
    let mut policy: Box<dyn Controller + '_> = if heads {
        Box::new(HeadsPolicy::boot(&blob, &critic, &plant).map_err(sim)?)
    } else {
        Box::new(boot::boot(&blob, &plant).map_err(sim)?)
    };
    let config = EvalConfig {
        episodes: TRAJECTORY_STARTS,
        seed: TRAJECTORY_SEED,
        record_trajectories: true,
        ..EvalConfig::default()
    };
    let report =
        test_protocol::evaluate_controller(policy.as_mut(), scenario, &config).map_err(sim)?;
    Ok(report.episodes.into_iter().map(|e| e.trajectory).collect())
}

/// The run of the lowest finished seed of a cell.
fn first_finished<'a>(all: &'a [(GridRun, Outcome)], cell: &Cell) -> Option<&'a Finished> {
    all.iter()
        .filter(|(run, _)| run.cell == *cell)
        .find_map(|(_, o)| match o {
            Outcome::Finished(f) => Some(&**f),
            _ => None,
        })
}

fn cell_of(agent: Agent, walls: Walls) -> Cell {
    Cell {
        walls,
        ..Cell::headline(agent)
    }
}

/// Figure 4 (`Walls::With`) or 5 (`Walls::Without`): one panel per agent.
pub fn trajectories(all: &[(GridRun, Outcome)], walls: Walls) -> Result<String, Error> {
    let scenario = scenario(walls)?;
    let mut panels = Vec::new();
    for agent in AGENTS {
        let cell = cell_of(agent, walls);
        let paths = match first_finished(all, &cell) {
            Some(run) => Some((run.config.seed, paths(run, &scenario)?)),
            None => None,
        };
        panels.push((agent.name, paths));
    }
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (960, 660)).into_drawing_area();
        draw_trajectories(&root, &scenario, &panels).map_err(|e| drawing("trajectories", e))?;
    }
    Ok(text)
}

type Panel = (&'static str, Option<(u64, Vec<Vec<[f32; 2]>>)>);

fn draw_trajectories(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    scenario: &Scenario,
    panels: &[Panel],
) -> Drawn {
    root.fill(&WHITE)?;
    let h = scenario.arena_half_size;
    let title = format!(
        "{}: {TRAJECTORY_STARTS} test starts (seed {TRAJECTORY_SEED}), the same for every agent",
        scenario.name
    );
    let root = root.titled(&title, ("sans-serif", 16))?;
    for (area, (name, paths)) in root.split_evenly((2, 3)).iter().zip(panels) {
        let caption = match paths {
            Some((seed, _)) => format!("{name} (run of seed {seed})"),
            None => format!("{name}: no finished run"),
        };
        let mut chart = ChartBuilder::on(area)
            .caption(caption, ("sans-serif", 13))
            .margin(6)
            .x_label_area_size(18)
            .y_label_area_size(24)
            .build_cartesian_2d(-h..h, -h..h)?;
        chart.configure_mesh().disable_mesh().draw()?;
        chart.draw_series(scenario.walls.iter().map(|w| {
            PathElement::new(
                [(w.from[0], w.from[1]), (w.to[0], w.to[1])],
                BLACK.stroke_width(2),
            )
        }))?;
        chart.draw_series(std::iter::once(Circle::new((0.0, 0.0), 3, RED.filled())))?;
        if let Some((_, paths)) = paths {
            for (i, path) in paths.iter().enumerate() {
                let colour = Palette99::pick(i).mix(0.8);
                let points: Vec<(f64, f64)> = path
                    .iter()
                    .map(|p| (f64::from(p[0]), f64::from(p[1])))
                    .collect();
                if let Some(&start) = points.first() {
                    chart.draw_series(std::iter::once(Circle::new(start, 2, colour.filled())))?;
                }
                chart.draw_series(std::iter::once(PathElement::new(points, colour)))?;
            }
        }
    }
    root.present()
}

/// The settled errors of every finished seed's successful tests.
fn settled_errors(all: &[(GridRun, Outcome)], cell: &Cell) -> Vec<f64> {
    all.iter()
        .filter(|(run, _)| run.cell == *cell)
        .filter_map(|(_, o)| match o {
            Outcome::Finished(f) => Some(&f.report.episodes),
            _ => None,
        })
        .flatten()
        .filter(|e| e.success)
        .map(|e| e.error)
        .collect()
}

/// Quartiles by linear interpolation, and the whiskers at the extremes.
fn five_numbers(values: &[f64]) -> Option<[f64; 5]> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| {
        let pos = q * (v.len() - 1) as f64;
        let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
        v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
    };
    Some([v[0], at(0.25), at(0.5), at(0.75), v[v.len() - 1]])
}

const WALLS_COLOUR: RGBColor = RGBColor(31, 119, 180);
const OPEN_COLOUR: RGBColor = RGBColor(255, 127, 14);

/// Figure 6: settled error of successful tests, per agent, with walls (blue) and without
/// (orange).
pub fn settled_error_boxes(all: &[(GridRun, Outcome)]) -> Result<String, Error> {
    let boxes: Vec<Boxes> = AGENTS
        .iter()
        .map(|&agent| {
            let (w, o) = (
                settled_errors(all, &cell_of(agent, Walls::With)),
                settled_errors(all, &cell_of(agent, Walls::Without)),
            );
            (five_numbers(&w), five_numbers(&o), w.len(), o.len())
        })
        .collect();
    let top = boxes
        .iter()
        .flat_map(|b| [b.0, b.1])
        .flatten()
        .map(|f| f[4])
        .fold(0.1_f64, f64::max);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (900, 420)).into_drawing_area();
        draw_boxes(&root, &boxes, top * 1.1).map_err(|e| drawing("box plots", e))?;
    }
    Ok(text)
}

/// A small label centred on its point and standing on it, so it never covers the mark below.
fn label_above() -> TextStyle<'static> {
    ("sans-serif", 10)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Bottom))
}

type Boxes = (Option<[f64; 5]>, Option<[f64; 5]>, usize, usize);

/// The label at `x` of an axis whose categories `names` sit at 0, 1, 2, ...: the name at whole
/// numbers, nothing between them.
pub(crate) fn category_label(names: &[&str], x: f64) -> String {
    let i = x.round();
    if (x - i).abs() < 1e-6 && i >= 0.0 {
        names
            .get(i as usize)
            .map_or(String::new(), |n| n.to_string())
    } else {
        String::new()
    }
}

type AgentChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A white chart with the agents along x (each at a whole number) and `0..top` along y.
fn agent_chart<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, Shift>,
    caption: &str,
    top: f64,
    y_desc: &str,
) -> Result<AgentChart<'a, 'b>, DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 14))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(-0.5..AGENTS.len() as f64 - 0.5, 0.0..top)?;
    let names = AGENTS.map(|a| a.name);
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(AGENTS.len())
        .x_label_formatter(&|x| category_label(&names, *x))
        .y_desc(y_desc)
        .draw()?;
    Ok(chart)
}

fn draw_boxes(root: &DrawingArea<SVGBackend<'_>, Shift>, boxes: &[Boxes], top: f64) -> Drawn {
    let mut chart = agent_chart(
        root,
        "Settled error of successful tests: pinwheel (blue) and open arena (orange)",
        top,
        "settled error (distance to the centre)",
    )?;
    for (i, (walls, open, nw, no)) in boxes.iter().enumerate() {
        for (offset, five, colour, n) in [
            (-0.18, walls, WALLS_COLOUR, nw),
            (0.18, open, OPEN_COLOUR, no),
        ] {
            let x = i as f64 + offset;
            let Some([lo, q1, median, q3, hi]) = *five else {
                continue;
            };
            let half = 0.14;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - half, q1), (x + half, q3)],
                colour.mix(0.35).filled(),
            )))?;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - half, q1), (x + half, q3)],
                colour.stroke_width(1),
            )))?;
            for line in [
                vec![(x - half, median), (x + half, median)],
                vec![(x, lo), (x, q1)],
                vec![(x, q3), (x, hi)],
                vec![(x - half / 2.0, lo), (x + half / 2.0, lo)],
                vec![(x - half / 2.0, hi), (x + half / 2.0, hi)],
            ] {
                chart.draw_series(std::iter::once(PathElement::new(
                    line,
                    colour.stroke_width(2),
                )))?;
            }
            chart.draw_series(std::iter::once(Text::new(
                format!("n={n}"),
                (x, hi + top * 0.01),
                label_above(),
            )))?;
        }
    }
    root.present()
}

/// Each finished run's mean steps to the goal, for the runs that reached it at least once.
fn steps(all: &[(GridRun, Outcome)], cell: &Cell) -> (Vec<f64>, usize) {
    let runs: Vec<&Finished> = all
        .iter()
        .filter(|(run, _)| run.cell == *cell)
        .filter_map(|(_, o)| match o {
            Outcome::Finished(f) => Some(&**f),
            _ => None,
        })
        .collect();
    let means = runs
        .iter()
        .filter_map(|f| f.report.mean_steps_to_goal)
        .collect();
    (means, runs.len())
}

/// Figure 7: steps to the goal per agent, with walls and without.
pub fn steps_to_goal(all: &[(GridRun, Outcome)]) -> Result<String, Error> {
    let bars: Vec<Bar> = AGENTS
        .iter()
        .map(|&agent| {
            [Walls::With, Walls::Without].map(|walls| {
                let (means, runs) = steps(all, &cell_of(agent, walls));
                let m = mean_interval(&means).map(|m| (m.mean, m.half_width.unwrap_or(0.0)));
                (m, means.len(), runs)
            })
        })
        .collect();
    let top = bars
        .iter()
        .flatten()
        .filter_map(|b| b.0)
        .map(|(m, h)| m + h)
        .fold(10.0_f64, f64::max);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (900, 420)).into_drawing_area();
        draw_steps(&root, &bars, top * 1.1).map_err(|e| drawing("steps to the goal", e))?;
    }
    Ok(text)
}

type Bar = [(Option<(f64, f64)>, usize, usize); 2];

fn draw_steps(root: &DrawingArea<SVGBackend<'_>, Shift>, bars: &[Bar], top: f64) -> Drawn {
    let mut chart = agent_chart(
        root,
        "Steps to the goal (within 0.1 for 10 steps), mean over seeds ± 95 %: pinwheel (blue), open (orange); k/n runs ever reached it",
        top,
        "steps",
    )?;
    for (i, pair) in bars.iter().enumerate() {
        for ((m, k, n), (offset, colour)) in pair
            .iter()
            .zip([(-0.18, WALLS_COLOUR), (0.18, OPEN_COLOUR)])
        {
            let x = i as f64 + offset;
            if let Some((mean, half)) = m {
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(x - 0.14, 0.0), (x + 0.14, *mean)],
                    colour.mix(0.6).filled(),
                )))?;
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(x, mean - half), (x, mean + half)],
                    BLACK.stroke_width(1),
                )))?;
            }
            chart.draw_series(std::iter::once(Text::new(
                format!("{k}/{n}"),
                (x, top * 0.01 + m.map_or(0.0, |(mean, half)| mean + half)),
                label_above(),
            )))?;
        }
    }
    root.present()
}

/// The thresholds of figure 8: success from 0 to 1 in steps of 0.02.
fn profile_taus() -> Vec<f64> {
    (0..=50).map(|i| f64::from(i) / 50.0).collect()
}

/// Figure 8: per agent, the share of its runs over the five sizes (each size weighing the
/// same) whose success is above each threshold, with the 95 % stratified bootstrap band.
pub fn success_profile(all: &[(GridRun, Outcome)]) -> Result<String, Error> {
    let taus = profile_taus();
    let curves: Vec<(&str, Vec<Interval>)> = AGENTS
        .iter()
        .filter_map(|&agent| {
            let tasks = super::page::size_tasks(all, agent);
            (!tasks.iter().all(Vec::is_empty)).then(|| {
                let band = performance_profile_ci(&tasks, &taus, CONFIDENCE, REPS, SEED);
                (agent.name, band)
            })
        })
        .collect();
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (900, 480)).into_drawing_area();
        draw_profile(&root, &taus, &curves).map_err(|e| drawing("the success profile", e))?;
    }
    Ok(text)
}

fn draw_profile(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    taus: &[f64],
    curves: &[(&str, Vec<Interval>)],
) -> Drawn {
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(
            "Success over the five network sizes (pinwheel, GR): share of runs above each threshold, 95 % stratified bootstrap band",
            ("sans-serif", 14),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..1.0, 0.0..1.02)?;
    chart
        .configure_mesh()
        .x_desc("success threshold τ")
        .y_desc("share of runs with success > τ")
        .draw()?;
    for (i, (name, band)) in curves.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let upper = taus.iter().zip(band).map(|(&t, b)| (t, b.hi));
        let lower = taus.iter().zip(band).rev().map(|(&t, b)| (t, b.lo));
        chart.draw_series(std::iter::once(Polygon::new(
            upper.chain(lower).collect::<Vec<_>>(),
            colour.mix(0.12).filled(),
        )))?;
        let line: Vec<(f64, f64)> = taus
            .iter()
            .zip(band)
            .map(|(&t, b)| (t, b.estimate))
            .collect();
        chart
            .draw_series(std::iter::once(PathElement::new(
                line,
                colour.stroke_width(2),
            )))?
            .label(*name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()
}

/// Writes the five figures into `dir`, atomically each; returns their file names.
pub fn write_all(dir: &Path, all: &[(GridRun, Outcome)]) -> Result<Vec<&'static str>, Error> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let figures = [
        (FIGURE_4, trajectories(all, Walls::With)?),
        (FIGURE_5, trajectories(all, Walls::Without)?),
        (FIGURE_6, settled_error_boxes(all)?),
        (FIGURE_7, steps_to_goal(all)?),
        (FIGURE_8, success_profile(all)?),
    ];
    for (name, svg) in &figures {
        let path = dir.join(name);
        files::write_atomic(&path, svg.as_bytes()).map_err(|source| Error::Io { path, source })?;
    }
    Ok(figures.map(|f| f.0).to_vec())
}

/// Figure 4's file.
pub const FIGURE_4: &str = "fig4-trajectories-walls.svg";
/// Figure 5's file.
pub const FIGURE_5: &str = "fig5-trajectories-open.svg";
/// Figure 6's file.
pub const FIGURE_6: &str = "fig6-settled-error.svg";
/// Figure 7's file.
pub const FIGURE_7: &str = "fig7-steps-to-goal.svg";
/// Figure 8's file.
pub const FIGURE_8: &str = "fig8-success-profile.svg";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reproduce::grid::{Experiment, Grid};
    use firmware_sim::nav::reference::reference;

    /// Every run of a one-seed grid "finished" with the oracle's report on its task.
    fn oracle_outcomes() -> Vec<(GridRun, Outcome)> {
        let grid = Grid {
            experiment: Experiment::Exp1,
            seeds: 2,
            quick: true,
        };
        let report = |walls| {
            let s = scenario(walls).expect("in the test");
            let mut oracle = reference("oracle", &s).expect("in the test");
            let cfg = EvalConfig {
                episodes: 10,
                ..EvalConfig::default()
            };
            test_protocol::evaluate_controller(oracle.as_mut(), &s, &cfg).expect("in the test")
        };
        let (walls, open) = (report(Walls::With), report(Walls::Without));
        grid.runs()
            .into_iter()
            .map(|run| {
                let report = match run.cell.walls {
                    Walls::With => walls.clone(),
                    Walls::Without => open.clone(),
                };
                let finished = Finished {
                    dir: "unused".into(),
                    training_seconds: Some(100.0 + run.seed as f64),
                    config: run.cell.config(true),
                    report,
                };
                (run, Outcome::Finished(Box::new(finished)))
            })
            .collect()
    }

    #[test]
    fn the_summary_figures_draw_a_box_and_a_bar_per_agent_and_task() {
        let all = oracle_outcomes();
        let successes = settled_errors(&all, &Cell::headline(AGENTS[0]));
        assert!(!successes.is_empty(), "the oracle succeeds");
        // One filled and one outlined rectangle per box, one bar per reached cell.
        let boxes = settled_error_boxes(&all).expect("in the test");
        assert_eq!(boxes.matches("<rect").count(), 1 + 2 * 2 * AGENTS.len());
        let bars = steps_to_goal(&all).expect("in the test");
        assert_eq!(bars.matches("<rect").count(), 1 + 2 * AGENTS.len());
        assert_eq!(bars.matches("2/2").count(), 2 * AGENTS.len()); // every run reached it
                                                                   // With no finished run, nothing but the background.
        let none: Vec<_> = all
            .into_iter()
            .map(|(run, _)| (run, Outcome::Missing))
            .collect();
        assert_eq!(
            settled_error_boxes(&none)
                .expect("in the test")
                .matches("<rect")
                .count(),
            1
        );
        assert!(trajectories(&none, Walls::With)
            .expect("in the test")
            .contains("no finished run"));
    }

    #[test]
    fn the_profile_draws_a_band_and_a_named_curve_per_agent_with_runs() {
        let all = oracle_outcomes();
        let svg = success_profile(&all).expect("in the test");
        assert_eq!(svg.matches("<polygon").count(), AGENTS.len());
        for agent in AGENTS {
            assert!(
                svg.contains(&format!(">\n{}\n<", agent.name)),
                "{}",
                agent.name
            );
        }
        let none: Vec<_> = all
            .into_iter()
            .map(|(run, _)| (run, Outcome::Missing))
            .collect();
        assert_eq!(
            success_profile(&none)
                .expect("in the test")
                .matches("<polygon")
                .count(),
            0
        );
        assert_eq!(profile_taus().first(), Some(&0.0));
        assert_eq!(profile_taus().last(), Some(&1.0));
    }

    #[test]
    fn five_numbers_interpolate() {
        assert_eq!(five_numbers(&[]), None);
        assert_eq!(five_numbers(&[2.0]), Some([2.0; 5]));
        assert_eq!(
            five_numbers(&[4.0, 1.0, 3.0, 2.0, 5.0]),
            Some([1.0, 2.0, 3.0, 4.0, 5.0])
        );
        assert_eq!(five_numbers(&[0.0, 1.0]).expect("in the test")[2], 0.5);
    }
}
