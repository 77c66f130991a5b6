//! The vectorisable `tanhf` gives `libm::tanhf`'s bits. The full proof is the exhaustive example
//! (`cargo run --release -p policy-core --example tanh_exhaustive`, all 2³² inputs); this test
//! covers what can break it, fast enough for every `cargo test`.

use policy_core::tanh::{tanh_in_place, tanhf};

use crate::support::SplitMix64;

/// Bit patterns of |x| where libm's `tanhf` or `expm1f` changes case (for `expm1f`, of its
/// argument 2|x|, so halved), plus the ends of the range.
const BOUNDARIES: [u32; 12] = [
    0x4120_0000, // tanhf: |x| > 10
    0x3f0c_9f54, // tanhf: |x| > log(3)/2
    0x3e82_c578, // tanhf: |x| > log(5/3)/2
    0x0080_0000, // tanhf: normal
    0x3e31_7218, // expm1f(2|x|): |2x| > 0.5 ln 2
    0x3f05_1592, // expm1f(2|x|): |2x| < 1.5 ln 2
    0x3fb8_aa3b, // about where k reaches 2
    0x40f1_d0b6, // about where k reaches 23 (2|x| ≈ 23 ln 2 / 2 · 2)
    0x4195_b844, // expm1f: 27 ln 2
    0x3280_0000, // expm1f: 2^-25 (halved)
    0x0000_0001, // smallest subnormal
    0x7f80_0000, // infinity
];

fn check(x: f32) {
    assert_eq!(
        tanhf(x).to_bits(),
        libm::tanhf(x).to_bits(),
        "tanhf({x:e}) = {x:?} bits {:08x}",
        x.to_bits()
    );
}

#[test]
fn boundaries_and_neighbourhoods_match_libm() {
    for &b in &BOUNDARIES {
        for d in 0..=4096u32 {
            for bits in [b.wrapping_add(d), b.wrapping_sub(d)] {
                check(f32::from_bits(bits));
                check(-f32::from_bits(bits));
            }
        }
    }
    for x in [
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7fc0_1234),
        f32::MAX,
        0.0,
        -0.0,
    ] {
        check(x);
    }
}

/// A million values spread over every exponent, and a dense sweep of the range hidden units use.
#[test]
fn random_and_dense_values_match_libm() {
    let mut rng = SplitMix64(0x7A);
    for _ in 0..500_000 {
        check(f32::from_bits(rng.next() as u32));
    }
    for i in -250_000..250_000 {
        check(i as f32 * (12.0 / 250_000.0));
    }
}

#[test]
fn in_place_matches_elementwise() {
    let mut rng = SplitMix64(0x7B);
    let values: Vec<f32> = (0..1000).map(|_| 8.0 * rng.symmetric()).collect();
    let mut out = values.clone();
    tanh_in_place(&mut out);
    for (x, y) in values.iter().zip(&out) {
        assert_eq!(y.to_bits(), libm::tanhf(*x).to_bits());
    }
}
