//! host-trainer's config files, mutated line by line (proptest).
//!
//! The smoke config of each algorithm, as `config.toml` holds it (every section, the other
//! algorithms' at their defaults), has a few `key = value` lines kept, dropped, duplicated or
//! given another value (an edge number, a non-finite one, a value of another type), and
//! sometimes an unknown key; the text goes through [`tests::config_checks::check`], the same
//! properties the `train_config` fuzz target checks: refused in one line, or a few episodes
//! trained and a blob that loads. A changed line in another algorithm's section is a setting
//! the run does not read, which must be refused too.

use host_trainer::algorithms::Algo;
use host_trainer::run::config::TrainConfig;
use proptest::prelude::*;
use tests::config_checks;

use crate::line_edits::{self, Edit};

/// Values of every TOML type, at the edges of the settings' rules.
const VALUES: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "0.0",
    "-0.0",
    "1e-7",
    "0.5",
    "0.999",
    "1.0",
    "2.0",
    "1e38",
    "1e308",
    "nan",
    "inf",
    "-inf",
    "4294967295",
    "18446744073709551615",
    "\"\"",
    "\"1x1\"",
    "\"9x65\"",
    "\"ou\"",
    "\"relu\"",
    "\"nav-open\"",
    "true",
    "[]",
    "{}",
];

const ALGOS: [Algo; 5] = [Algo::Dcp, Algo::Ddpg, Algo::Td3, Algo::Ppo, Algo::Dqn];

fn render(algo: Algo, edits: &[Edit], extra: Option<&str>) -> String {
    let base = TrainConfig::smoke(algo, 1).to_toml();
    line_edits::apply(&base, edits, VALUES, extra.map(|e| ("seed", e)))
}

#[test]
fn the_smoke_config_of_every_algorithm_trains() {
    for algo in ALGOS {
        let text = render(algo, &[], None);
        let config = TrainConfig::parse(&text, "smoke.toml".as_ref()).expect("parses");
        assert_eq!(config, TrainConfig::smoke(algo, 1));
        config_checks::check(&text);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// A few lines changed at a time, so that many cases parse and train (a text with every
    /// line at risk would almost never pass validation).
    #[test]
    fn mutated_train_configs_train_or_are_refused_in_one_line(
        algo in prop::sample::select(&ALGOS[..]),
        changes in prop::collection::vec((0usize..80, line_edits::edit(6, VALUES.len(), -10.0..100.0)), 1..3),
        extra in prop::option::weighted(0.1, "[a-z_]{1,8}"),
    ) {
        let mut edits = vec![Edit::Keep; 80];
        for (line, e) in changes {
            edits[line] = e;
        }
        config_checks::check(&render(algo, &edits, extra.as_deref()));
    }
}
