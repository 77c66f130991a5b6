//! The grid of an experiment: every training run its tables and figures need, named so that a
//! run two tables share is trained once, and split into disjoint slices for a cluster.
//!
//! A *cell* is one setting of one agent (task, network size, reward, exploration σ); its runs
//! are the cell's seeds `0..seeds`. Each cell is a `sweep` output folder of its own,
//! `OUT/runs/{cell}/`, holding `{task}__{algo}__{seed}/` run folders as `sweep` and `train`
//! make them, so every run resumes and is skipped when finished exactly as in a sweep.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::algorithms::{dcp, Algo};
use crate::nn::hidden::Hidden;
use crate::run::config::{RewardKind, TrainConfig};

/// The experiments `reproduce` rebuilds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Experiment {
    /// Blind navigation among walls: tables 1–3 and figures 4–7.
    Exp1,
    /// Badminton teams: tables 5–7, team scores, the influence of T, heat maps (claim 4).
    Exp2,
}

impl fmt::Display for Experiment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Experiment::Exp1 => "exp1",
            Experiment::Exp2 => "exp2",
        })
    }
}

/// An agent of experiment 1: an algorithm with the settings that make it the paper's agent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Agent {
    /// Its name in folders and tables.
    pub name: &'static str,
    /// The algorithm it trains with.
    pub algo: Algo,
    /// DCP as the paper describes it (`dcp::Config::paper()`) rather than DCP's defaults.
    pub paper_dcp: bool,
}

/// The six agents of experiment 1, in table order: DCP as this toolkit adopts it, the paper's
/// DCP, and the baselines.
pub const AGENTS: [Agent; 6] = [
    Agent::of("dcp", Algo::Dcp, false),
    Agent::of("dcp-paper", Algo::Dcp, true),
    Agent::of("ddpg", Algo::Ddpg, false),
    Agent::of("td3", Algo::Td3, false),
    Agent::of("ppo", Algo::Ppo, false),
    Agent::of("dqn", Algo::Dqn, false),
];

impl Agent {
    const fn of(name: &'static str, algo: Algo, paper_dcp: bool) -> Agent {
        Agent {
            name,
            algo,
            paper_dcp,
        }
    }

    /// The agent of this name.
    pub fn named(name: &str) -> Option<Agent> {
        AGENTS.into_iter().find(|a| a.name == name)
    }
}

/// The network sizes of table 1 [paper: "from 2×32 to 6×64"].
pub const SIZES: [(usize, usize); 5] = [(2, 32), (3, 40), (4, 48), (5, 56), (6, 64)];
/// The reward forms of table 2.
pub const REWARDS: [RewardKind; 3] = [RewardKind::Lr, RewardKind::Gr, RewardKind::Lrgr];
/// The large exploration noises of table 3 (the action box is [−1, 1]).
pub const LARGE_SIGMAS: [f32; 2] = [0.5, 1.0];
/// The agents of table 3: those that explore with Gaussian noise on a deterministic actor.
pub const NOISE_AGENTS: [&str; 4] = ["dcp", "dcp-paper", "ddpg", "td3"];

/// The walls of a cell's task.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Walls {
    /// The pinwheel (`nav-walls`).
    With,
    /// The same arena without walls (`nav-open`).
    Without,
}

/// One setting of one agent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// The agent.
    pub agent: Agent,
    /// With or without walls.
    pub walls: Walls,
    /// Hidden layers (depth, width).
    pub size: (usize, usize),
    /// The reward.
    pub reward: RewardKind,
    /// Exploration σ, or the default.
    pub sigma: Option<f32>,
}

impl Cell {
    /// The headline setting of an agent: the pinwheel, 4×48, GR, default σ.
    pub fn headline(agent: Agent) -> Cell {
        Cell {
            agent,
            walls: Walls::With,
            size: (4, 48),
            reward: RewardKind::Gr,
            sigma: None,
        }
    }

    /// The cell's folder name, e.g. `walls-4x48-gr-dcp-paper` or `open-4x48-gr-sigma0.5-ddpg`:
    /// every setting spelled out, so two tables that need the same runs name the same folder.
    pub fn name(&self) -> String {
        let walls = match self.walls {
            Walls::With => "walls",
            Walls::Without => "open",
        };
        let reward = match self.reward {
            RewardKind::Lr => "lr",
            RewardKind::Gr => "gr",
            RewardKind::Lrgr => "lrgr",
        };
        let sigma = self.sigma.map(|s| format!("-sigma{s}")).unwrap_or_default();
        let (depth, width) = self.size;
        format!(
            "{walls}-{depth}x{width}-{reward}{sigma}-{}",
            self.agent.name
        )
    }

    /// The task name `train` takes.
    pub fn task(&self) -> &'static str {
        match self.walls {
            Walls::With => "nav-walls",
            Walls::Without => "nav-open",
        }
    }

    /// The cell's run settings (seed 0); `quick` shrinks the budget to a test of the machinery.
    pub fn config(&self, quick: bool) -> TrainConfig {
        let mut c = TrainConfig {
            task: self.task().into(),
            algo: self.agent.algo,
            reward: self.reward,
            // The experiments' protocols: a fixed budget, the last networks.
            validation: None,
            ..TrainConfig::default()
        };
        if self.agent.paper_dcp {
            c.dcp = dcp::Config::paper();
        }
        let (depth, width) = self.size;
        c.agent.hidden = Hidden { depth, width };
        if let Some(sigma) = self.sigma {
            c.agent.sigma = sigma;
        }
        if quick {
            // `TrainConfig::smoke`'s budget, the cell's settings kept: every code path runs,
            // nothing is learnt.
            let smoke = TrainConfig::smoke(self.agent.algo, 0);
            c.episodes = smoke.episodes;
            c.checkpoint_every = smoke.checkpoint_every;
            c.eval_episodes = QUICK_EVAL_EPISODES;
            c.agent.batch = smoke.agent.batch;
            c.agent.warmup_steps = smoke.agent.warmup_steps;
            c.dcp.t = smoke.dcp.t;
            c.ppo.rollout = smoke.ppo.rollout;
            c.ppo.minibatch = smoke.ppo.minibatch;
            c.ppo.epochs = smoke.ppo.epochs;
        }
        c
    }
}

/// Test starts of a quick grid's evaluations.
pub const QUICK_EVAL_EPISODES: usize = 10;

/// The fewest seeds a full grid runs ([design §7](../../docs/design.md): at least 5 per cell).
pub const MIN_SEEDS: u64 = 5;

/// Every cell of experiment 1, each once, in the order the page shows them.
pub fn exp1_cells() -> Vec<Cell> {
    let mut cells: Vec<Cell> = Vec::new();
    let mut add = |cell: Cell| {
        if !cells.iter().any(|c| c.name() == cell.name()) {
            cells.push(cell);
        }
    };
    for agent in AGENTS {
        for size in SIZES {
            add(Cell {
                size,
                ..Cell::headline(agent)
            });
        }
    }
    for agent in AGENTS {
        for reward in REWARDS {
            add(Cell {
                reward,
                ..Cell::headline(agent)
            });
        }
    }
    for name in NOISE_AGENTS {
        let agent = Agent::named(name).expect("the noise agents are agents");
        for sigma in LARGE_SIGMAS {
            add(Cell {
                sigma: Some(sigma),
                ..Cell::headline(agent)
            });
        }
    }
    for agent in AGENTS {
        add(Cell {
            walls: Walls::Without,
            ..Cell::headline(agent)
        });
    }
    cells
}

/// One run of the grid: a cell and a seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridRun {
    /// The cell.
    pub cell: Cell,
    /// The seed.
    pub seed: u64,
}

/// A grid: the experiment, its seeds and its budget.
// An unknown key in `grid.json` is refused: a misspelt `seed` or `quik` would otherwise read as
// a grid of other settings than the one written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Which experiment.
    pub experiment: Experiment,
    /// Seeds `0..seeds` of every cell.
    pub seeds: u64,
    /// The quick budget (a test of the machinery, not a result).
    pub quick: bool,
}

impl Grid {
    /// The experiment's navigation cells (none for experiment 2, whose runs are teams:
    /// [`teams`](super::teams)).
    pub fn cells(&self) -> Vec<Cell> {
        match self.experiment {
            Experiment::Exp1 => exp1_cells(),
            Experiment::Exp2 => Vec::new(),
        }
    }

    /// Every run, cell by cell and seed by seed within a cell.
    pub fn runs(&self) -> Vec<GridRun> {
        let seeds = 0..self.seeds;
        self.cells()
            .into_iter()
            .flat_map(|cell| seeds.clone().map(move |seed| GridRun { cell, seed }))
            .collect()
    }

    /// The runs of one slice: run `i` of [`Grid::runs`] belongs to slice `i mod count`, so
    /// every slice holds every agent's runs in about equal shares (an agent's runs take about
    /// equally long), the slices are disjoint and together are the grid.
    pub fn slice(&self, slice: Slice) -> Vec<GridRun> {
        self.runs()
            .into_iter()
            .enumerate()
            .filter(|(i, _)| *i as u64 % slice.count == slice.index)
            .map(|(_, run)| run)
            .collect()
    }

    /// The runs claims 2 and 3 gained after the grid (docs/results/reproduction.md, "Added
    /// seeds for claims 2 and 3"): seeds `seeds..seeds + 4` of claim 2's cells (the paper's DCP
    /// and DDPG under LR and GR) and `seeds..seeds + 5` of claim 3's (the same agents at each
    /// large σ), cell by cell; none for experiment 2. Seeds only: every run has its cell's
    /// settings, and goes in its cell's folder beside the grid's own runs.
    ///
    /// ```
    /// use host_trainer::reproduce::grid::{Experiment, Grid};
    /// let grid = Grid { experiment: Experiment::Exp1, seeds: 5, quick: false };
    /// let added = grid.added_runs();
    /// assert_eq!(added.len(), 4 * 4 + 4 * 5);
    /// assert!(added.iter().all(|r| (5..10).contains(&r.seed)));
    /// assert!(Grid { experiment: Experiment::Exp2, ..grid }.added_runs().is_empty());
    /// ```
    pub fn added_runs(&self) -> Vec<GridRun> {
        if self.experiment != Experiment::Exp1 {
            return Vec::new();
        }
        let mut runs = Vec::new();
        for agent in CLAIM_AGENTS {
            let claim2 = [
                Cell::headline(agent),
                Cell {
                    reward: RewardKind::Lr,
                    ..Cell::headline(agent)
                },
            ];
            let claim3 = LARGE_SIGMAS.map(|sigma| Cell {
                sigma: Some(sigma),
                ..Cell::headline(agent)
            });
            for (cells, added) in [(&claim2, CLAIM2_ADDED), (&claim3, CLAIM3_ADDED)] {
                for &cell in cells {
                    runs.extend(
                        (self.seeds..self.seeds + added).map(|seed| GridRun { cell, seed }),
                    );
                }
            }
        }
        runs
    }

    /// The folder of a cell's runs.
    pub fn cell_dir(out: &Path, cell: &Cell) -> std::path::PathBuf {
        out.join(RUNS).join(cell.name())
    }

    /// How the grid is written on the command line, e.g. `exp1 --seeds 5 --quick`.
    pub fn describe(&self) -> String {
        let quick = if self.quick { " --quick" } else { "" };
        format!("{} --seeds {}{quick}", self.experiment, self.seeds)
    }
}

/// The agents claims 2 and 3 compare: the paper's DCP and DDPG.
pub const CLAIM_AGENTS: [Agent; 2] = [AGENTS[1], AGENTS[2]];
/// Seeds claim 2's cells gained after the grid: 9 pairs per agent with the grid's 5.
pub const CLAIM2_ADDED: u64 = 4;
/// Seeds claim 3's cells gained after the grid: 20 runs per agent with the grid's 5 per σ.
pub const CLAIM3_ADDED: u64 = 5;

/// The folder under `--out` holding one folder per cell.
pub const RUNS: &str = "runs";

/// The most slices a grid may be cut into.
pub const MAX_SLICES: u64 = 100_000;

/// `--slice I/N`: the I-th (from 0) of N disjoint parts of the grid.
///
/// ```
/// use host_trainer::reproduce::grid::Slice;
/// let s: Slice = "1/4".parse().unwrap();
/// assert_eq!((s.index, s.count), (1, 4));
/// assert!("4/4".parse::<Slice>().is_err());
/// assert!("0/0".parse::<Slice>().is_err());
/// assert!("1-4".parse::<Slice>().is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slice {
    /// Which part, from 0.
    pub index: u64,
    /// Of how many.
    pub count: u64,
}

impl Slice {
    /// The whole grid as one part.
    pub const WHOLE: Slice = Slice { index: 0, count: 1 };
}

impl FromStr for Slice {
    type Err = String;

    fn from_str(text: &str) -> Result<Slice, String> {
        let malformed = || format!("expected I/N with 0 <= I < N (e.g. 0/4), found {text:?}");
        let (i, n) = text.split_once('/').ok_or_else(malformed)?;
        let (index, count) = (
            i.trim().parse::<u64>().map_err(|_| malformed())?,
            n.trim().parse::<u64>().map_err(|_| malformed())?,
        );
        if count == 0 || count > MAX_SLICES {
            return Err(format!(
                "the slice count must be 1 to {MAX_SLICES}, found {text:?}"
            ));
        }
        if index >= count {
            return Err(format!(
                "slice {index} of {count} does not exist (slices are 0 to {}), found {text:?}",
                count - 1
            ));
        }
        Ok(Slice { index, count })
    }
}

impl fmt::Display for Slice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(seeds: u64) -> Grid {
        Grid {
            experiment: Experiment::Exp1,
            seeds,
            quick: true,
        }
    }

    #[test]
    fn the_added_runs_are_the_claims_cells_at_new_seeds_only() {
        assert_eq!(CLAIM_AGENTS.map(|a| a.name), ["dcp-paper", "ddpg"]);
        let g = grid(5);
        let grid_runs = g.runs();
        let added = g.added_runs();
        let names: std::collections::BTreeSet<String> =
            added.iter().map(|r| r.cell.name()).collect();
        let expected: std::collections::BTreeSet<String> = [
            "walls-4x48-gr-dcp-paper",
            "walls-4x48-lr-dcp-paper",
            "walls-4x48-gr-sigma0.5-dcp-paper",
            "walls-4x48-gr-sigma1-dcp-paper",
            "walls-4x48-gr-ddpg",
            "walls-4x48-lr-ddpg",
            "walls-4x48-gr-sigma0.5-ddpg",
            "walls-4x48-gr-sigma1-ddpg",
        ]
        .map(String::from)
        .into();
        assert_eq!(names, expected);
        for run in &added {
            assert!(g.cells().contains(&run.cell), "{}", run.cell.name());
            assert!(
                !grid_runs.contains(run),
                "{} seed {}",
                run.cell.name(),
                run.seed
            );
            let last = if run.cell.sigma.is_some() { 10 } else { 9 };
            assert!((5..last).contains(&run.seed));
        }
    }

    #[test]
    fn a_run_two_tables_share_is_one_cell() {
        let cells = exp1_cells();
        // 6 agents × 5 sizes, + 6 × 2 other rewards (GR is table 1's 4×48), + 4 × 2 large
        // noises, + 6 without walls.
        assert_eq!(cells.len(), 30 + 12 + 8 + 6);
        let mut names: Vec<String> = cells.iter().map(Cell::name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), cells.len());
        assert!(names.contains(&"walls-4x48-gr-dcp-paper".to_string()));
        assert!(names.contains(&"walls-4x48-gr-sigma0.5-ddpg".to_string()));
        assert!(names.contains(&"open-4x48-gr-dqn".to_string()));
    }

    #[test]
    fn slices_are_disjoint_and_cover_the_grid() {
        let g = grid(3);
        let all = g.runs();
        for count in [1, 2, 3, 7, 500] {
            let mut seen = 0;
            for index in 0..count {
                let part = g.slice(Slice { index, count });
                seen += part.len();
                for run in &part {
                    let at = all.iter().position(|r| r == run).expect("in the test");
                    assert_eq!(at as u64 % count, index);
                }
            }
            assert_eq!(seen, all.len());
        }
    }

    #[test]
    fn cells_set_their_settings_and_the_paper_dcp() {
        let paper = Cell {
            size: (2, 32),
            sigma: Some(1.0),
            ..Cell::headline(Agent::named("dcp-paper").expect("in the test"))
        };
        let c = paper.config(false);
        assert_eq!(c.dcp, dcp::Config::paper());
        assert_eq!((c.agent.hidden.depth, c.agent.hidden.width), (2, 32));
        assert_eq!(c.agent.sigma, 1.0);
        assert_eq!(c.episodes, TrainConfig::default().episodes);
        let adopted = Cell::headline(AGENTS[0]).config(false);
        assert_eq!(
            adopted,
            TrainConfig {
                validation: None,
                ..TrainConfig::default()
            }
        );
        let quick = Cell::headline(AGENTS[0]).config(true);
        assert_eq!(quick.episodes, TrainConfig::smoke(Algo::Dcp, 0).episodes);
        assert_eq!(quick.agent.hidden, TrainConfig::default().agent.hidden);
    }

    #[test]
    fn slices_parse_and_refuse() {
        assert_eq!("0/1".parse::<Slice>(), Ok(Slice::WHOLE));
        for bad in ["", "1", "a/2", "2/2", "-1/2", "0/0", "0/100001", "1/2/3"] {
            assert!(bad.parse::<Slice>().is_err(), "{bad}");
        }
    }
}
