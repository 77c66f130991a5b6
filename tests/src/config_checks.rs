//! What must hold for any text given to host-trainer as a `--config` file.
//!
//! Shared by the fuzz target `fuzz/fuzz_targets/train_config.rs` and the proptest in
//! `tests/tests/config_mutations.rs`.

use std::path::Path;

use host_trainer::run::config::TrainConfig;
use host_trainer::run::trainer::Trainer;
use policy_core::model::Model;

/// Episodes trained from an accepted config: enough to fill a small replay and update.
const EPISODES: usize = 2;

/// Parses `text` as a train config: refused in one line (unreadable, out of range, or setting
/// what its algorithm does not read), or it trains a few episodes and exports a blob that loads.
pub fn check(text: &str) {
    let config = match TrainConfig::parse(text, Path::new("fuzz.toml")) {
        Ok(config) => config,
        Err(e) => return crate::assert_one_line(&e.to_string()),
    };
    if let Err(e) = config.check_read(&[config.algo]) {
        return crate::assert_one_line(&e.to_string());
    }
    check_accepted(config);
}

/// A config that passed the parser trains two episodes (its budget capped so the check
/// stays fast) or is refused in one line when the trainer is built; a trained one exports a
/// blob that policy-core loads.
pub fn check_accepted(mut config: TrainConfig) {
    config.episodes = config.episodes.min(EPISODES);
    let mut trainer = match Trainer::new(config) {
        Ok(trainer) => trainer,
        Err(e) => return crate::assert_one_line(&e.to_string()),
    };
    while !trainer.done() {
        if let Err(e) = trainer.run_episode() {
            return crate::assert_one_line(&e.to_string());
        }
    }
    match trainer.policy_blob("fuzz") {
        Ok(blob) => {
            if let Err(e) = Model::from_blob(&blob) {
                panic!("the exported blob does not load: {e}");
            }
        }
        Err(e) => crate::assert_one_line(&e.to_string()),
    }
}
