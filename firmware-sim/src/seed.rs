//! One seed, many independent random streams (starts, sensor noise, dropouts, ...).
//!
//! Every random draw in the crate comes from a ChaCha8 stream derived from the user's seed and
//! the stream's name, so adding a new stream never shifts the numbers of an existing one, and the
//! same seed gives the same bytes on every machine.
//!
//! ```
//! use firmware_sim::seed::{stream, uniform};
//! let mut a = stream(7, "sensor", 0);
//! let mut b = stream(7, "sensor", 0);
//! assert_eq!(uniform(&mut a), uniform(&mut b));
//! let mut c = stream(7, "starts", 0);
//! assert_ne!(uniform(&mut stream(7, "sensor", 0)), uniform(&mut c));
//! ```

use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// The generator used everywhere in the crate.
pub type SimRng = ChaCha8Rng;

/// The stream `name`, instance `index`, of `seed` (FNV-1a of the name, mixed by SplitMix64).
pub fn stream(seed: u64, name: &str, index: u64) -> SimRng {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for byte in name.bytes() {
        h = (h ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    let mixed = splitmix(splitmix(seed ^ h).wrapping_add(index));
    SimRng::seed_from_u64(mixed)
}

fn splitmix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform `f64` in `[0, 1)` (53 random bits).
pub fn uniform(rng: &mut impl Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A standard normal `f64` (Box–Muller).
pub fn normal(rng: &mut impl Rng) -> f64 {
    let u1 = 1.0 - uniform(rng); // in (0, 1], so the log is finite
    let u2 = uniform(rng);
    (-2.0 * u1.ln()).sqrt() * (2.0 * core::f64::consts::PI * u2).cos()
}

/// A seed for episode `index` of an evaluation or training run seeded by `seed`.
///
/// ```
/// use firmware_sim::seed::episode_seed;
/// assert_eq!(episode_seed(0, 3), episode_seed(0, 3));
/// assert_ne!(episode_seed(0, 3), episode_seed(0, 4));
/// ```
pub fn episode_seed(seed: u64, index: u64) -> u64 {
    stream(seed, "episode", index).next_u64()
}
