//! A run's metrics: one row per episode, `metrics.csv` and the learning curve.

use serde::{Deserialize, Serialize};

use crate::run::plot::{self, Panel, Series};
use crate::run::validation::Round;

/// One row of `metrics.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRow {
    /// Episode number, from 1.
    pub episode: usize,
    /// Sum of rewards.
    pub ret: f32,
    /// Steps taken.
    pub steps: usize,
    /// Reached the centre, or settled within 2 units of it (docs/design.md §2's test rule,
    /// applied to however many of the last 20 positions the episode has).
    pub success: bool,
    /// Distance from the centre at the end.
    pub final_distance: f32,
    /// The algorithm's own columns ([`Algorithm::stat_names`](crate::algorithms::algorithm::Algorithm::stat_names)), e.g. DCP's critic loss, actor
    /// loss and kept fraction (NaN where nothing ran).
    pub stats: Vec<f32>,
    /// Environment steps since the start of the run.
    pub total_steps: u64,
    /// Environment steps per second in this episode, updates included (wall clock).
    pub steps_per_s: f32,
}

/// The header of `metrics.csv`, with the algorithm's columns (`names`) in the middle.
pub fn csv_header(names: &[&str]) -> String {
    let mut h = String::from("episode,return,steps,success,final_distance");
    for n in names {
        h.push(',');
        h.push_str(n);
    }
    h.push_str(",total_steps,steps_per_s");
    h
}

impl EpisodeRow {
    /// The row as CSV (NaN written as an empty field).
    pub fn csv(&self) -> String {
        let f = |v: f32| {
            if v.is_nan() {
                String::new()
            } else {
                format!("{v}")
            }
        };
        let mut out = format!(
            "{},{},{},{},{}",
            self.episode,
            f(self.ret),
            self.steps,
            u8::from(self.success),
            f(self.final_distance),
        );
        for &v in &self.stats {
            out.push(',');
            out.push_str(&f(v));
        }
        out.push_str(&format!(",{},{}", self.total_steps, f(self.steps_per_s)));
        out
    }

    /// The value of the algorithm's column `name` (its position in `names`).
    pub fn stat(&self, names: &[&str], name: &str) -> Option<f32> {
        let i = names.iter().position(|n| *n == name)?;
        self.stats.get(i).copied()
    }
}

/// The whole `metrics.csv`.
pub fn metrics_csv(names: &[&str], rows: &[EpisodeRow]) -> String {
    let mut out = csv_header(names);
    out.push('\n');
    for r in rows {
        out.push_str(&r.csv());
        out.push('\n');
    }
    out
}

/// The learning curve: return (raw and 100-episode average) and the 100-episode success rate;
/// with validation rounds, their success rate beside it and their mean settled error (or mean
/// return, on a plant of the user's) in a panel of its own.
pub fn learning_curve(title: &str, rows: &[EpisodeRow], rounds: &[Round]) -> String {
    let x: Vec<f64> = rows.iter().map(|r| r.episode as f64).collect();
    let ret: Vec<f64> = rows.iter().map(|r| f64::from(r.ret)).collect();
    let success: Vec<f64> = rows
        .iter()
        .map(|r| f64::from(u8::from(r.success)))
        .collect();
    let zip = |ys: Vec<f64>| x.iter().copied().zip(ys).collect::<Vec<_>>();
    let returns = Panel {
        y_label: "return".into(),
        y_range: None,
        series: vec![
            Series {
                name: "episode".into(),
                color: "#1f77b4",
                opacity: 0.25,
                points: zip(ret.clone()),
            },
            Series {
                name: "mean of 100".into(),
                color: "#1f77b4",
                opacity: 1.0,
                points: zip(plot::moving_average(&ret, 100)),
            },
        ],
    };
    let mut rate = Panel {
        y_label: "success rate".into(),
        y_range: Some((0.0, 1.0)),
        series: vec![Series {
            name: "mean of 100".into(),
            color: "#2ca02c",
            opacity: 1.0,
            points: zip(plot::moving_average(&success, 100)),
        }],
    };
    if rounds.is_empty() {
        return plot::svg(title, "episode", &[returns, rate]);
    }
    let at = |f: fn(&Round) -> Option<f64>| -> Vec<(f64, f64)> {
        rounds
            .iter()
            .filter_map(|r| Some((r.episode as f64, f(r)?)))
            .collect()
    };
    rate.series.push(Series {
        name: "validation".into(),
        color: "#ff7f0e",
        opacity: 1.0,
        points: at(|r| Some(r.success)),
    });
    // A scenario's rounds have a settled error; a plant of the user's, a mean return.
    let scenario = rounds.iter().any(|r| r.error.is_some());
    let (label, figure): (&str, fn(&Round) -> Option<f64>) = if scenario {
        ("validation settled error", |r| r.error)
    } else {
        ("validation mean return", |r| r.mean_return)
    };
    let validation = Panel {
        y_label: label.into(),
        y_range: None,
        series: vec![Series {
            name: "validation round".into(),
            color: "#ff7f0e",
            opacity: 1.0,
            points: at(figure),
        }],
    };
    plot::svg(title, "episode", &[returns, rate, validation])
}
