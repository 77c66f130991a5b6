//! The studies behind `docs/results/`: each turns the runs a study recorded into its page, with
//! the statistics of `host_trainer::stats`. They live apart from `host-trainer/examples/`, which
//! holds programs that show a user how to use the library.

#![deny(missing_docs)]

pub mod standard_tasks;
