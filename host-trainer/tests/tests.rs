//! host-trainer's integration tests: one binary, one module per concern.

/// The `host-trainer` binary on bad input: one clear line, exit 2, nothing lost.
mod cli;
/// Kill -9 at seeded points, inside checkpoint writes included, and a panicking worker thread:
/// resume gives the same blob.
mod crash;
/// Ctrl-C during training: a checkpoint, a clean exit, a hint how to resume.
mod interrupt;
/// Plants in another process (`--plant-cmd`) and given in process: the same bytes as a
/// scenario, recorded and checked on resume.
mod plant_link;
/// `train --race K`: the winner and its bytes do not depend on timing or on a kill mid-race.
mod race;
/// `host-trainer reproduce`: an experiment's grid in slices, merged into its page.
mod reproduce;
/// `scripts/runs-archive.sh`: archives that hold links or are corrupt are refused by name.
mod runs_archive;
/// Shared helpers: scratch folders, running the binary, tiny configs.
mod support;
/// `host-trainer sweep`: parallel runs, summary, and re-running after a kill, failure or Ctrl-C.
mod sweep;
/// Training runs with tiny budgets: smoke, determinism, resume, divergence, checkpoints.
mod training;
/// The gate's verdict from `eval`: 0 and PASS, 1 and FAIL with the reason, as `firmware-sim run`
/// gives it; an error is 2.
mod verdict;
