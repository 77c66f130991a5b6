//! The batch Box–Muller gives the single draws' bits: its `logf` and `cosf` match `libm` on
//! every input Box–Muller can give them, and the batch matches repeated `standard_normal`.

use core::convert::Infallible;
use core::f32::consts::TAU;

use policy_core::normal::{cosf, logf, standard_normal, standard_normals};
use rand_core::{Rng, TryRng};

use crate::support::SplitMix64;

/// Every uniform `standard_normal` can draw, from the 2²⁴ possible top 24 bits of a word (the
/// same expression as the sampler's, so the same `f32` roundings).
fn every_uniform() -> impl Iterator<Item = f32> {
    (0..1u32 << 24).map(|top| (top as f32 + 0.5) * (1.0 / 16_777_216.0))
}

#[test]
fn logf_matches_libm_on_every_uniform() {
    for u in every_uniform() {
        assert_eq!(logf(u).to_bits(), libm::logf(u).to_bits(), "logf({u:e})");
    }
}

#[test]
fn cosf_matches_libm_on_every_angle() {
    for u in every_uniform() {
        let x = TAU * u;
        assert_eq!(cosf(x).to_bits(), libm::cosf(x).to_bits(), "cosf({x:e})");
    }
}

/// Around each bit pattern where libm's `cosf` changes case, and over its whole domain.
#[test]
fn cosf_matches_libm_around_its_cases() {
    let boundaries = [
        0x3980_0000u32,
        0x3f49_0fda,
        0x4016_cbe3,
        0x407b_53d1,
        0x40af_eddf,
    ];
    for b in boundaries {
        for d in 0..=4096 {
            for bits in [b + d, b - d] {
                let x = f32::from_bits(bits);
                assert_eq!(cosf(x).to_bits(), libm::cosf(x).to_bits(), "cosf({x:e})");
            }
        }
    }
    for bits in (0..=0x40e2_31d5u32).step_by(97) {
        let x = f32::from_bits(bits);
        assert_eq!(cosf(x).to_bits(), libm::cosf(x).to_bits(), "cosf({x:e})");
    }
}

/// Any positive normal float, not only uniforms: the port has no hidden range assumption.
#[test]
fn logf_matches_libm_on_positive_normals() {
    let mut rng = SplitMix64(0x10);
    for _ in 0..1_000_000 {
        let bits = (rng.next() as u32 % (0x7f80_0000 - 0x0080_0000)) + 0x0080_0000;
        let x = f32::from_bits(bits);
        assert_eq!(logf(x).to_bits(), libm::logf(x).to_bits(), "logf({x:e})");
    }
}

/// Lengths below, at and above the lane count, odd ones included, with the stream carried from
/// one call to the next.
#[test]
fn batch_is_the_single_draws_in_order() {
    let mut batch_rng = SplitMix64(0x11);
    let mut single_rng = SplitMix64(0x11);
    let mut out = [0.0f32; 80];
    for len in (0..=33).chain([63, 64, 65, 79, 80]) {
        out[..len].fill(f32::NAN);
        standard_normals(&mut batch_rng, &mut out[..len]);
        for (i, z) in out[..len].iter().enumerate() {
            let want = standard_normal(&mut single_rng);
            assert_eq!(z.to_bits(), want.to_bits(), "length {len}, draw {i}");
        }
        assert_eq!(batch_rng.0, single_rng.0, "stream after a batch of {len}");
    }
    assert_eq!(batch_rng.next_u32(), single_rng.next_u32());
}

/// Feeds every top 24 bits as the first uniform of a draw (the radius, so every square root
/// Box–Muller takes) with a sweep of angles as the second.
#[derive(Clone)]
struct EveryRadius {
    draw: u32,
    second: bool,
}

impl TryRng for EveryRadius {
    type Error = Infallible;
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        let word = if self.second {
            self.draw = self.draw.wrapping_add(1);
            self.draw.wrapping_sub(1).wrapping_mul(0x9E37_79B9)
        } else {
            self.draw << 8
        };
        self.second = !self.second;
        Ok(word)
    }
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        Ok(u64::from(self.try_next_u32()?))
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        dst.fill(0);
        Ok(())
    }
}

#[test]
fn batch_matches_single_draws_on_every_radius() {
    let mut batch_rng = EveryRadius {
        draw: 0,
        second: false,
    };
    let mut single_rng = batch_rng.clone();
    let mut out = vec![0.0f32; 4096];
    for _ in 0..(1 << 24) / out.len() {
        standard_normals(&mut batch_rng, &mut out);
        for z in &out {
            let want = standard_normal(&mut single_rng);
            assert_eq!(z.to_bits(), want.to_bits(), "draw {}", single_rng.draw - 1);
        }
    }
    assert_eq!(batch_rng.draw, 1 << 24);
}
