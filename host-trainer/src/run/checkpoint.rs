//! The resumable training state, as one postcard file.
//!
//! A checkpoint holds everything the next episode depends on: the configuration, the networks,
//! the optimiser moments, the normaliser, the whole replay buffer, the metrics so far and the
//! exact position of every random stream. The algorithm's part ([`Learner`]) holds its own
//! networks, buffers and random streams (for PPO, the unfinished rollout too). Resuming from it therefore continues the very run
//! that was interrupted: a run of N episodes and a run stopped at k and resumed to N produce
//! the same blob bytes (tested in `tests/training.rs`).
//!
//! Layout: the 8 bytes `DCPCKPT6` (magic and version), the postcard encoding of
//! [`Checkpoint`], then the CRC-32 (policy-core's, little-endian) of everything before it, so a
//! flipped bit anywhere is a clear error rather than a silently different run. The config and
//! the plant are stored as TOML text: the file stays readable by `export` even if a config field
//! is added later with a default, and resume needs no file outside the run folder.

use std::io::Write;
use std::path::Path;

use firmware_sim::files::AtomicFile;
use serde::{Deserialize, Serialize};

use crate::algorithms::Learner;
use crate::rng_state::RngState;
use crate::run::crash_test;
use crate::run::metrics::EpisodeRow;
use crate::run::validation::{Kept, Round};
use crate::Error;

/// Magic and format version at the start of every checkpoint file.
pub const MAGIC: &[u8; 8] = b"DCPCKPT6";
/// Bytes of the trailing checksum.
const CRC_LEN: usize = 4;

/// Everything needed to continue a run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Checkpoint {
    /// The run's configuration, as TOML text.
    pub config_toml: String,
    /// The plant the run trains on (the resolved scenario, before the run's reward and γ
    /// overrides), as TOML text.
    pub scenario_toml: String,
    /// The algorithm's state: networks, optimisers, normaliser, replay buffer or rollout, and
    /// its random streams.
    pub learner: Learner,
    /// Completed episodes.
    pub episode: usize,
    /// Environment steps so far.
    pub total_steps: u64,
    /// One row per completed episode.
    pub metrics: Vec<EpisodeRow>,
    /// The stream of episode starts.
    pub env_rng: RngState,
    /// The validation rounds so far.
    pub validation: Vec<Round>,
    /// The best policy by validation, as its blobs.
    pub kept: Option<Kept>,
}

/// A checkpoint of the format before validation (`DCPCKPT5`): the same fields without the
/// validation state. Read so that a run started by an older build continues (without
/// validation: its config has no `[validation]` section).
#[derive(Deserialize)]
struct Version5 {
    config_toml: String,
    scenario_toml: String,
    learner: Learner,
    episode: usize,
    total_steps: u64,
    metrics: Vec<EpisodeRow>,
    env_rng: RngState,
}

/// The magic of [`Version5`].
const MAGIC_5: &[u8; 8] = b"DCPCKPT5";

impl Checkpoint {
    /// The file's bytes: magic, postcard, CRC-32.
    pub fn to_bytes(&self) -> Result<Vec<u8>, String> {
        seal(MAGIC, self)
    }

    /// Parses a checkpoint file's bytes: magic, checksum, then the contents.
    ///
    /// ```
    /// use host_trainer::run::checkpoint::Checkpoint;
    /// let err = Checkpoint::from_bytes(b"DCPCKPT2....").unwrap_err();
    /// assert!(err.contains("older build"), "{err}");
    /// ```
    pub fn from_bytes(bytes: &[u8]) -> Result<Checkpoint, String> {
        if let Some(rest) = bytes.strip_prefix(MAGIC_5.as_slice()) {
            let v: Version5 = unseal(rest, bytes)?;
            return Ok(Checkpoint {
                config_toml: v.config_toml,
                scenario_toml: v.scenario_toml,
                learner: v.learner,
                episode: v.episode,
                total_steps: v.total_steps,
                metrics: v.metrics,
                env_rng: v.env_rng,
                validation: Vec::new(),
                kept: None,
            });
        }
        let Some(rest) = bytes.strip_prefix(MAGIC.as_slice()) else {
            return Err(wrong_magic(bytes));
        };
        unseal(rest, bytes)
    }

    /// Writes the checkpoint atomically. (A crash-safety test can stop the process halfway
    /// through the write: the kill points of `run/crash_test.rs`.)
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        let bytes = self.to_bytes().map_err(|message| Error::Checkpoint {
            path: path.to_path_buf(),
            message,
        })?;
        write_in_halves(path, &bytes)
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

/// A resumable state's file bytes: `magic`, the postcard encoding of `value`, then the CRC-32
/// (policy-core's, little-endian) of everything before it. Team checkpoints share it.
pub fn seal(magic: &[u8; 8], value: &impl Serialize) -> Result<Vec<u8>, String> {
    let bytes = postcard::to_extend(value, magic.to_vec()).map_err(|e| e.to_string())?;
    let crc = policy_core::crc32(&bytes);
    Ok([bytes, crc.to_le_bytes().to_vec()].concat())
}

/// The value [`seal`] wrote: `rest` is `bytes` after a magic the caller has checked; the
/// checksum covers the whole of `bytes`.
pub fn unseal<T: serde::de::DeserializeOwned>(rest: &[u8], bytes: &[u8]) -> Result<T, String> {
    let Some((body, crc)) = rest.split_last_chunk::<CRC_LEN>() else {
        return Err(format!("truncated: {} bytes", bytes.len()));
    };
    let stored = u32::from_le_bytes(*crc);
    let computed = policy_core::crc32(&bytes[..bytes.len() - CRC_LEN]);
    if stored != computed {
        return Err(format!(
            "checksum mismatch (stored CRC-32 {stored:08x}, computed {computed:08x}): the file is corrupt or truncated"
        ));
    }
    postcard::from_bytes(body).map_err(|e| format!("corrupt contents ({e})"))
}

/// Writes `bytes` to `path` atomically, in two halves so the crash-safety test can stop the
/// process between them.
pub fn write_in_halves(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = AtomicFile::create(path).map_err(io)?;
    let (first, second) = bytes.split_at(bytes.len() / 2);
    file.write_all(first).map_err(io)?;
    crash_test::checkpoint_half_written(&mut file);
    file.write_all(second).map_err(io)?;
    file.commit().map_err(io)
}

fn wrong_magic(bytes: &[u8]) -> String {
    let found = &bytes[..bytes.len().min(MAGIC.len())];
    if found.starts_with(b"DCPCKPT") {
        format!(
            "written by an older build (format {:?}); this build reads DCPCKPT5 and DCPCKPT6 (one state per algorithm, with a checksum, the plant, the replay's episode ends and twin critics, and from 6 the validation rounds and the kept policy): export it with the build that wrote it",
            String::from_utf8_lossy(found)
        )
    } else {
        format!(
            "not a checkpoint: expected the magic \"DCPCKPT6\", found {:?}",
            String::from_utf8_lossy(found)
        )
    }
}
