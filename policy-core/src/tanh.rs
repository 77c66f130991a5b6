//! `tanhf` for whole layers: bit-identical to `libm::tanhf`, written without branches so a loop
//! over a layer vectorises.
//!
//! `libm::tanhf` (musl's, from FreeBSD's `s_tanhf.c` and `s_expm1f.c`) is part of the
//! arithmetic contract with the trainer, and at 12-20 ns per call it is most of the cost of a
//! tanh `act` on a host. This is the same algorithm, the same constants and the same IEEE
//! operations in the same order, with every branch replaced by computing both sides and
//! selecting: IEEE arithmetic is deterministic, so each lane gets exactly libm's bits, and the
//! loop becomes packed SIMD (about 55 instructions per value at SSE2 width, roughly 1.4× faster
//! than calling libm per value on this project's x86-64 benchmark machine; see benches/act.rs).
//! `examples/tanh_exhaustive.rs` checks all 2³² inputs against `libm::tanhf`; the tests check
//! the neighbourhoods of every boundary between the algorithm's cases.
//!
//! Computing every case costs more than libm's branches on a core without SIMD, so targets
//! without it (Cortex-M) call `libm::tanhf` directly; both give the same bits.

// libm's constants, by their bits (its decimal literals parse to exactly these).
const LN2_HI: f32 = f32::from_bits(0x3f31_7180); // 6.9313812256e-01
const LN2_LO: f32 = f32::from_bits(0x3717_f7d1); // 9.0580006145e-06
const INV_LN2: f32 = f32::from_bits(0x3fb8_aa3b); // 1.4426950216e+00
const Q1: f32 = f32::from_bits(0xbd08_8868); // -3.3333212137e-2
const Q2: f32 = f32::from_bits(0x3acf_3010); // 1.5807170421e-3

/// The hyperbolic tangent, bit for bit `libm::tanhf(x)` for every `x` (NaN payloads included).
///
/// ```
/// for x in [0.0f32, -0.3, 0.5493, 1.0, -7.5, 12.0, f32::INFINITY, 1e-40] {
///     assert_eq!(policy_core::tanh::tanhf(x).to_bits(), libm::tanhf(x).to_bits());
/// }
/// ```
#[inline(always)]
pub fn tanhf(x: f32) -> f32 {
    let bits = x.to_bits();
    let w = bits & 0x7fff_ffff;
    let ax = f32::from_bits(w);
    // libm's cases, in its order of precedence.
    let huge = w > 0x4120_0000; // |x| > 10, or NaN
    let big = w > 0x3f0c_9f54; // |x| > log(3)/2
    let mid = w > 0x3e82_c578; // |x| > log(5/3)/2
    let normal = w >= 0x0080_0000; // |x| >= 2^-126
                                   // One expm1f per lane: of 2|x| in the two upper cases, of -2|x| below them.
    let t = expm1f_reduced(if mid { 2.0 * ax } else { -2.0 * ax });
    let q = t + 2.0;
    let d = (if big { 2.0 } else { t }) / q;
    // `-t / q` in libm is `(-t) / q`, which equals `-(t / q)` exactly (rounding is symmetric).
    // libm's `1 + 0 / |x|` is 1 for every non-NaN |x| > 10 and the quieted NaN otherwise,
    // which is also what `|x| + 1` gives a NaN: same bits, no division.
    let r = select(
        huge,
        select(ax.is_nan(), ax + 1.0, 1.0),
        select(big, 1.0 - d, select(mid, d, select(normal, -d, ax))),
    );
    select(bits >> 31 != 0, -r, r)
}

/// `tanhf` of every element: the hidden activation of a whole layer.
///
/// ```
/// let mut layer = [-3.0f32, -0.2, 0.0, 0.4, 1.0, 15.0];
/// let expected = layer.map(libm::tanhf);
/// policy_core::tanh::tanh_in_place(&mut layer);
/// assert_eq!(layer.map(f32::to_bits), expected.map(f32::to_bits));
/// ```
#[inline]
pub fn tanh_in_place(values: &mut [f32]) {
    #[cfg(any(
        target_feature = "sse2",
        target_feature = "neon",
        target_feature = "simd128"
    ))]
    values.iter_mut().for_each(|v| *v = tanhf(*v));
    #[cfg(not(any(
        target_feature = "sse2",
        target_feature = "neon",
        target_feature = "simd128"
    )))]
    values.iter_mut().for_each(|v| *v = libm::tanhf(*v));
}

#[inline(always)]
fn select(c: bool, a: f32, b: f32) -> f32 {
    if c {
        a
    } else {
        b
    }
}

/// libm's `expm1f` for the arguments `tanhf` gives it (`-0.511 <= x <= 20`, or a lane whose
/// result is discarded): its early returns for NaN, `x <= -27 ln 2` and overflow cannot occur
/// there, and everything else is computed on both sides of each branch and selected.
#[inline(always)]
fn expm1f_reduced(x: f32) -> f32 {
    let hx = x.to_bits() & 0x7fff_ffff;
    let negative = x.to_bits() >> 31 != 0;
    let reduce = hx > 0x3eb1_7218; // |x| > 0.5 ln 2
    let near = hx < 0x3f85_1592; // |x| < 1.5 ln 2
    let tiny = hx < 0x3300_0000; // |x| < 2^-25

    // Argument reduction x = k ln2 + r, |r| <= 0.5 ln 2.
    // libm: `k = (INV_LN2 * x ± 0.5) as i32`. Where this branch is taken for tanhf's arguments
    // (1.5 ln 2 <= x <= 20) the sum v lies in [2, 29.4], so truncation is floor, done here with
    // the 2^23 rounding trick and integer bits (a saturating `as i32` would not vectorise).
    let v = INV_LN2 * x + select(negative, -0.5, 0.5);
    let rounded = (v + 8_388_608.0) - 8_388_608.0; // v to the nearest integer, for 0 <= v < 2^23
    let t_far = select(rounded > v, rounded - 1.0, rounded);
    let k_far = ((t_far + 8_388_608.0).to_bits() as i32).wrapping_sub(0x4b00_0000);
    let k_near = if negative { -1 } else { 1 };
    let hi = if near {
        select(negative, x + LN2_HI, x - LN2_HI)
    } else {
        x - t_far * LN2_HI
    };
    let lo = if near {
        select(negative, -LN2_LO, LN2_LO)
    } else {
        t_far * LN2_LO
    };
    let k = if reduce {
        if near {
            k_near
        } else {
            k_far
        }
    } else {
        0
    };
    let xr = select(reduce, hi - lo, x);
    let c = select(reduce, (hi - xr) - lo, 0.0);

    // x is now in the primary range.
    let hfx = 0.5 * xr;
    let hxs = xr * hfx;
    let r1 = 1.0 + hxs * (Q1 + hxs * Q2);
    let t = 3.0 - r1 * hfx;
    let e0 = hxs * ((r1 - t) / (6.0 - xr * t));
    let k_zero = xr - (xr * e0 - hxs);
    let e = (xr * (e0 - c) - c) - hxs;
    let k_minus_one = 0.5 * (xr - e) - 0.5;
    let k_one = if xr < -0.25 {
        -2.0 * (e - (xr + 0.5))
    } else {
        1.0 + 2.0 * (xr - e)
    };
    // 2 <= k <= 29 here; wrapping keeps discarded lanes from overflowing in debug builds.
    let two_pk = f32::from_bits((0x7f_i32.wrapping_add(k) as u32) << 23);
    let two_mk = f32::from_bits((0x7f_i32.wrapping_sub(k) as u32) << 23);
    let k_large = if k < 23 {
        (xr - e + (1.0 - two_mk)) * two_pk
    } else {
        (xr - (e + two_mk) + 1.0) * two_pk
    };
    let reduced = match k {
        0 => k_zero,
        -1 => k_minus_one,
        1 => k_one,
        _ => k_large,
    };
    select(!reduce && tiny, x, reduced)
}
