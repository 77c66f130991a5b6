//! `host-trainer sweep`: one training run per (algo, seed), as parallel `train` processes.
//!
//! Why processes and not threads: a run is single-threaded and deterministic, and a child
//! process is exactly the run `train` would make alone (same blob bytes), with its own
//! Ctrl-C checkpoint, its own crash safety and its own exit code; a run that panics or is
//! killed takes no other run with it.
//!
//! A sweep is safe to re-run: the run folders are the only state. In order:
//! 1. [`plan`] looks at each run folder before anything starts: finished runs are skipped,
//!    started but unfinished ones are continued, absent or empty ones are trained afresh.
//! 2. [`supervise`] runs them, at most `jobs` at once; each child's stdout and stderr are appended
//!    to `OUT/sweep-logs/{run}.log` as it runs, so nothing it printed is lost to a kill. A run that
//!    fails is recorded with its exit code and last line, and the others go on.
//! 3. [`report`] summarises the runs: one row each; per (task, algo) the mean with a 95 %
//!    percentile bootstrap interval over the finished seeds and the failed trainings with their
//!    exact interval; per task, each pair of algos by the sign-flip permutation test on the
//!    seeds both finished. [`record`] is what became of each run.

pub mod plan;
pub mod record;
pub mod report;
pub mod supervise;
