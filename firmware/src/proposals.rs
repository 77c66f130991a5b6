//! The random stream of the on-device compare step (feature `refine`): SplitMix64, seeded with a
//! fixed value, so firmware/host-check (which includes this same file with `#[path]`) draws the
//! same proposals and recomputes the refined actions bit for bit.

use core::convert::Infallible;

use rand_core::TryRng;

/// The seed both sides start from.
pub const SEED: u64 = 0x5EED_0013;

/// SplitMix64 (Steele, Lea and Flood 2014): one add and three xor-shift-multiplies per draw.
pub struct Proposals(pub u64);

impl TryRng for Proposals {
    type Error = Infallible;
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        Ok(z ^ (z >> 31))
    }
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok((self.try_next_u64()? >> 32) as u32)
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        for chunk in dst.chunks_mut(8) {
            let bytes = self.try_next_u64()?.to_le_bytes();
            chunk.copy_from_slice(&bytes[..chunk.len()]);
        }
        Ok(())
    }
}
