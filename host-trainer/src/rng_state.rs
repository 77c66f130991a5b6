//! The exact position of a random stream, so a checkpoint continues every stream where it was.

use firmware_sim::seed::SimRng;
use serde::{Deserialize, Serialize};

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
    /// use firmware_sim::seed;
    /// use host_trainer::rng_state::RngState;
    /// use rand_core::Rng as _;
    /// let mut rng = seed::training_stream(7, "explore");
    /// rng.next_u32();
    /// let mut copy = RngState::of(&rng).restore();
    /// assert_eq!(rng.next_u64(), copy.next_u64());
    /// ```
    pub fn of(rng: &SimRng) -> RngState {
        RngState {
            seed: rng.get_seed(),
            stream: rng.get_stream(),
            word_pos: rng.get_word_pos(),
        }
    }

    /// A generator at the captured position.
    pub fn restore(&self) -> SimRng {
        use rand_core::SeedableRng;
        let mut rng = SimRng::from_seed(self.seed);
        rng.set_stream(self.stream);
        rng.set_word_pos(self.word_pos);
        rng
    }
}

/// Serde for a random stream inside a checkpoint: its [`RngState`]. Use on a field with
/// `#[serde(with = "crate::rng_state::serde_rng")]`.
pub mod serde_rng {
    use super::RngState;
    use firmware_sim::seed::SimRng;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes the stream's position.
    pub fn serialize<S: Serializer>(rng: &SimRng, s: S) -> Result<S::Ok, S::Error> {
        RngState::of(rng).serialize(s)
    }

    /// Reads a stream back at its position.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<SimRng, D::Error> {
        RngState::deserialize(d).map(|s| s.restore())
    }
}
