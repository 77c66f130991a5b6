//! The resumable training state, as one postcard file.
//!
//! A checkpoint holds everything the next episode depends on: the configuration, the networks,
//! the optimiser moments, the normaliser, the whole replay buffer, the metrics so far and the
//! exact position of every random stream. Resuming from it therefore continues the very run
//! that was interrupted: a run of N episodes and a run stopped at k and resumed to N produce
//! the same blob bytes (tested in `tests/train_runs.rs`).
//!
//! Layout: the 8 bytes `DCPCKPT2` (magic and version), then the postcard encoding of
//! [`Checkpoint`]. The config is stored as its TOML text so that the file stays readable by
//! `export` even if a config field is added later with a default.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::agent::Agent;
use crate::run_dir::write_atomic;
use crate::seed::Rng;
use crate::train::EpisodeRow;
use crate::Error;

/// Magic and format version at the start of every checkpoint file.
pub const MAGIC: &[u8; 8] = b"DCPCKPT2";

/// Everything needed to continue a run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Checkpoint {
    /// The run's configuration, as TOML text.
    pub config_toml: String,
    /// Networks, optimisers, normaliser, replay buffer.
    pub agent: Agent,
    /// Completed episodes.
    pub episode: usize,
    /// Environment steps so far.
    pub total_steps: u64,
    /// One row per completed episode.
    pub metrics: Vec<EpisodeRow>,
    /// The random streams, in the trainer's fixed order.
    pub rngs: Vec<RngState>,
}

/// The position of a ChaCha stream, enough to continue it exactly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RngState {
    /// The key.
    pub seed: [u8; 32],
    /// The stream id.
    pub stream: u64,
    /// The next 32-bit word to be produced.
    pub word_pos: u128,
}

impl RngState {
    /// Captures a generator's position.
    ///
    /// ```
    /// use host_trainer::{checkpoint::RngState, seed};
    /// use rand_core::Rng as _;
    /// let mut rng = seed::stream(7, "explore");
    /// rng.next_u32();
    /// let mut copy = RngState::of(&rng).restore();
    /// assert_eq!(rng.next_u64(), copy.next_u64());
    /// ```
    pub fn of(rng: &Rng) -> RngState {
        RngState {
            seed: rng.get_seed(),
            stream: rng.get_stream(),
            word_pos: rng.get_word_pos(),
        }
    }

    /// A generator at the captured position.
    pub fn restore(&self) -> Rng {
        use rand_core::SeedableRng;
        let mut rng = Rng::from_seed(self.seed);
        rng.set_stream(self.stream);
        rng.set_word_pos(self.word_pos);
        rng
    }
}

impl Checkpoint {
    /// The file's bytes: magic, then postcard.
    pub fn to_bytes(&self) -> Result<Vec<u8>, String> {
        let body = postcard::to_allocvec(self).map_err(|e| e.to_string())?;
        Ok([MAGIC.as_slice(), &body].concat())
    }

    /// Parses a checkpoint file's bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Checkpoint, String> {
        let body = bytes.strip_prefix(MAGIC.as_slice()).ok_or_else(|| {
            let found = &bytes[..bytes.len().min(MAGIC.len())];
            format!(
                "expected the magic \"DCPCKPT2\" (this build's checkpoint format), found {:?}",
                String::from_utf8_lossy(found)
            )
        })?;
        postcard::from_bytes(body).map_err(|e| format!("corrupt or truncated checkpoint ({e})"))
    }

    /// Writes the checkpoint atomically.
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        let bytes = self.to_bytes().map_err(|message| Error::Checkpoint {
            path: path.to_path_buf(),
            message,
        })?;
        write_atomic(path, &bytes)
    }

    /// Reads a checkpoint file.
    pub fn load(path: &Path) -> Result<Checkpoint, Error> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Checkpoint::from_bytes(&bytes).map_err(|message| Error::Checkpoint {
            path: path.to_path_buf(),
            message,
        })
    }
}
