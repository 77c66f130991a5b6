//! Standard normal draws by Box–Muller, one at a time or a batch at a time, with the same bits.
//!
//! [`standard_normal`] is the sampler DCP was measured with: two 24-bit uniforms from the
//! stream, then `libm`'s `f32` `logf`, `sqrtf` and `cosf`. The trainer's draws are pinned by
//! its training test, and a faster method (a ziggurat) once changed them and DCP learned worse,
//! so a faster sampler has to return these very values.
//!
//! [`standard_normals`] does: it takes the uniforms from the stream in the same order, then runs
//! Box–Muller eight lanes at a time through [`logf`] and [`cosf`], ports of `libm`'s (musl's,
//! from FreeBSD's `e_logf.c`, `s_cosf.c`, `k_cosf.c` and `k_sinf.c`) with the same constants and
//! the same IEEE operations in the same order, every branch replaced by computing both sides and
//! selecting. IEEE arithmetic is deterministic and Rust never fuses a multiply and an add
//! unless told to, so each lane gets exactly `libm`'s bits, and the lane loops become packed
//! SIMD. The square root is correctly rounded everywhere (`sqrtss`, `vsqrtps` or `libm`'s
//! software one), so it agrees too. The tests compare both functions with `libm` on every input
//! Box–Muller can give them (all 2²⁴ uniforms) and the batch with repeated single draws.
//!
//! Computing every case costs more than `libm`'s branches on a core without SIMD, so targets
//! without it (Cortex-M) draw one at a time; both give the same bits.

use rand_core::Rng;

/// How many draws [`standard_normals`] takes from the stream before computing them: enough for
/// the lane loops to run at full vector width (a variable trip count, so the compiler
/// vectorises them rather than unrolling them into scalar code), few enough for the stack.
#[cfg(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
))]
const CHUNK: usize = 64;

// libm's constants, by their bits (its decimal literals parse to exactly these).
// logf:
const LN2_HI: f32 = f32::from_bits(0x3f31_7180); // 6.9313812256e-01
const LN2_LO: f32 = f32::from_bits(0x3717_f7d1); // 9.0580006145e-06
const LG1: f32 = f32::from_bits(0x3f2a_aaaa); // 0.66666662693
const LG2: f32 = f32::from_bits(0x3ecc_ce13); // 0.40000972152
const LG3: f32 = f32::from_bits(0x3e91_e9ee); // 0.28498786688
const LG4: f32 = f32::from_bits(0x3e78_9e26); // 0.24279078841
                                              // cosf: small multiples of pi/2 rounded to double precision.
const C1_PIO2: f64 = core::f64::consts::FRAC_PI_2;
const C2_PIO2: f64 = 2. * core::f64::consts::FRAC_PI_2;
const C3_PIO2: f64 = 3. * core::f64::consts::FRAC_PI_2;
const C4_PIO2: f64 = 4. * core::f64::consts::FRAC_PI_2;
// k_cosf, |cos(x) - c(x)| < 2**-34.1:
const C0: f64 = f64::from_bits(0xbfdf_ffff_fd0c_5e81); // -0.499999997251031003120
const C1: f64 = f64::from_bits(0x3fa5_5553_e105_3a42); // 0.0416666233237390631894
const C2: f64 = f64::from_bits(0xbf56_c087_e80f_1e27); // -0.00138867637746099294692
const C3: f64 = f64::from_bits(0x3ef9_9342_e0ee_5069); // 0.0000243904487962774090654
                                                       // k_sinf, |sin(x)/x - s(x)| < 2**-37.5:
const S1: f64 = f64::from_bits(0xbfc5_5555_54cb_ac77); // -0.166666666416265235595
const S2: f64 = f64::from_bits(0x3f81_1110_896e_fbb2); // 0.0083333293858894631756
const S3: f64 = f64::from_bits(0xbf2a_00f9_e2ca_e774); // -0.000198393348360966317347
const S4: f64 = f64::from_bits(0x3ec6_cd87_8c3b_46a7); // 0.0000027183114939898219064

/// A standard normal sample by the Box–Muller transform (one of the pair; `libm` only).
///
/// ```
/// use policy_core::normal::standard_normal;
/// use rand_core::{Infallible, TryRng};
/// struct Counter(u32);
/// impl TryRng for Counter {
///     type Error = Infallible;
///     fn try_next_u32(&mut self) -> Result<u32, Infallible> { self.0 = self.0.wrapping_mul(747796405).wrapping_add(2891336453); Ok(self.0) }
///     fn try_next_u64(&mut self) -> Result<u64, Infallible> { Ok(self.try_next_u32()? as u64) }
///     fn try_fill_bytes(&mut self, d: &mut [u8]) -> Result<(), Infallible> { d.fill(0); Ok(()) }
/// }
/// let mut rng = Counter(1);
/// let n = 10_000;
/// let mean = (0..n).map(|_| standard_normal(&mut rng)).sum::<f32>() / n as f32;
/// assert!(mean.abs() < 0.05);
/// ```
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> f32 {
    let u1 = unit(rng.next_u32());
    let u2 = unit(rng.next_u32());
    libm::sqrtf(-2.0 * libm::logf(u1)) * libm::cosf(core::f32::consts::TAU * u2)
}

/// Fills `out` with standard normals: exactly the values, in order, of `out.len()` calls of
/// [`standard_normal`] on the same stream, which it leaves in the same state.
///
/// ```
/// use policy_core::normal::{standard_normal, standard_normals};
/// use rand_core::{Infallible, TryRng};
/// #[derive(Clone)]
/// struct Counter(u32);
/// impl TryRng for Counter {
///     type Error = Infallible;
///     fn try_next_u32(&mut self) -> Result<u32, Infallible> { self.0 = self.0.wrapping_mul(747796405).wrapping_add(2891336453); Ok(self.0) }
///     fn try_next_u64(&mut self) -> Result<u64, Infallible> { Ok(self.try_next_u32()? as u64) }
///     fn try_fill_bytes(&mut self, d: &mut [u8]) -> Result<(), Infallible> { d.fill(0); Ok(()) }
/// }
/// let (mut a, mut b) = (Counter(1), Counter(1));
/// let mut batch = [0.0f32; 11];
/// standard_normals(&mut a, &mut batch);
/// let one_by_one: Vec<f32> = (0..11).map(|_| standard_normal(&mut b)).collect();
/// assert_eq!(batch.map(f32::to_bits).to_vec(), one_by_one.iter().map(|z| z.to_bits()).collect::<Vec<_>>());
/// assert_eq!(a.0, b.0);
/// ```
pub fn standard_normals<R: Rng + ?Sized>(rng: &mut R, out: &mut [f32]) {
    #[cfg(any(
        target_feature = "sse2",
        target_feature = "neon",
        target_feature = "simd128"
    ))]
    for chunk in out.chunks_mut(CHUNK) {
        // The first uniform of each pair goes straight into `out`, the second beside it.
        let mut u2 = [0.0; CHUNK];
        for (u1, u2) in chunk.iter_mut().zip(&mut u2) {
            *u1 = unit(rng.next_u32());
            *u2 = unit(rng.next_u32());
        }
        box_muller(chunk, &u2[..chunk.len()]);
    }
    #[cfg(not(any(
        target_feature = "sse2",
        target_feature = "neon",
        target_feature = "simd128"
    )))]
    out.iter_mut().for_each(|z| *z = standard_normal(rng));
}

/// A uniform strictly inside (0, 1) from the top 24 bits of `x`: the log never sees 0. (Above
/// 2²³ the half step rounds to even, so the largest value is exactly 1.)
#[inline(always)]
fn unit(x: u32) -> f32 {
    ((x >> 8) as f32 + 0.5) * (1.0 / 16_777_216.0)
}

/// Box–Muller of the pairs `(u1[i], u2[i])`, in place of `u1`. Each pass is a loop over the
/// lanes with no branch in its body, so each vectorises.
#[cfg(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
))]
fn box_muller(u1: &mut [f32], u2: &[f32]) {
    for r in u1.iter_mut() {
        *r = -2.0 * logf(*r);
    }
    sqrt_in_place(u1);
    // `sqrtf(..) * cosf(..)` as in `standard_normal` (a product is the same either way round).
    for (z, &u) in u1.iter_mut().zip(u2) {
        *z *= cosf(core::f32::consts::TAU * u);
    }
}

/// Square roots in place; correctly rounded either way, so the same bits as `libm::sqrtf`.
/// `libm`'s is an inline `sqrtss` on x86-64, which the compiler cannot widen; `std`'s is the
/// compiler's own square root, which it can. (Like `CHUNK` and `box_muller`, only the SIMD
/// batch uses it.)
#[cfg(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
))]
#[inline(always)]
fn sqrt_in_place(x: &mut [f32]) {
    #[cfg(any(test, feature = "std"))]
    x.iter_mut().for_each(|v| *v = v.sqrt());
    #[cfg(not(any(test, feature = "std")))]
    x.iter_mut().for_each(|v| *v = libm::sqrtf(*v));
}

/// The natural logarithm, bit for bit `libm::logf(x)` for every positive normal finite `x`
/// (every uniform Box–Muller takes). Other inputs give some value, never a panic.
///
/// libm's early returns are for zero, negatives, subnormals, infinity and NaN, none of which
/// are in this domain, and for 1, where the general path below also gives +0.
///
/// ```
/// for x in [1e-30f32, 2.98e-8, 0.25, 0.5, 0.7071, 1.0, 1.5, 3.0e38] {
///     assert_eq!(policy_core::normal::logf(x).to_bits(), libm::logf(x).to_bits());
/// }
/// ```
#[inline(always)]
pub fn logf(x: f32) -> f32 {
    // Reduce x into [sqrt(2)/2, sqrt(2)].
    let ix = x.to_bits().wrapping_add(0x3f80_0000 - 0x3f35_04f3);
    let k = ((ix >> 23) as i32).wrapping_sub(0x7f);
    let x = f32::from_bits((ix & 0x007f_ffff) + 0x3f35_04f3);

    let f = x - 1.;
    let s = f / (2. + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG2 + w * LG4);
    let t2 = z * (LG1 + w * LG3);
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    let dk = k as f32;
    s * (hfsq + r) + dk * LN2_LO - hfsq + f + dk * LN2_HI
}

/// The cosine, bit for bit `libm::cosf(x)` for `0 <= x <= 9π/4` (every angle Box–Muller takes,
/// `TAU * u` for `u` in (0, 1]). Other inputs give some value, never a panic.
///
/// libm's argument reduction for larger |x| (`rem_pio2f`) is not needed there; its four cases
/// below 9π/4 are all computed and the right one selected.
///
/// ```
/// for x in [0.0f32, 1e-5, 0.5, 0.7853, 2.0, 3.1416, 4.0, 5.5, 6.2831855, 7.0] {
///     assert_eq!(policy_core::normal::cosf(x).to_bits(), libm::cosf(x).to_bits());
/// }
/// ```
#[inline(always)]
pub fn cosf(x: f32) -> f32 {
    let x64 = x as f64;
    let ix = x.to_bits() & 0x7fff_ffff;
    // libm's cases for a non-negative x, in its order of precedence.
    let tiny = ix < 0x3980_0000; // |x| < 2^-12: 1
    let quarter = ix <= 0x3f49_0fda; // |x| ~<= pi/4: cos(x)
    let three_quarters = ix <= 0x4016_cbe3; // |x| ~<= 3pi/4: sin(pi/2 - x)
    let five_quarters = ix <= 0x407b_53d1; // |x| ~<= 5pi/4: -cos(x - pi)
    let seven_quarters = ix <= 0x40af_eddf; // |x| ~<= 7pi/4: sin(x - 3pi/2); else cos(x - 2pi)
    let y = if quarter {
        x64
    } else if three_quarters {
        C1_PIO2 - x64
    } else if five_quarters {
        x64 - C2_PIO2
    } else if seven_quarters {
        x64 - C3_PIO2
    } else {
        x64 - C4_PIO2
    };
    let sine = !quarter && (three_quarters || (!five_quarters && seven_quarters));
    let v = if sine { k_sinf(y) } else { k_cosf(y) };
    let v = if !three_quarters && five_quarters {
        -v
    } else {
        v
    };
    if tiny {
        1.
    } else {
        v
    }
}

/// libm's `k_cosf`: cos on [-pi/4, pi/4], in `f64`.
#[inline(always)]
fn k_cosf(x: f64) -> f32 {
    let z = x * x;
    let w = z * z;
    let r = C2 + z * C3;
    (((1.0 + z * C0) + w * C1) + (w * z) * r) as f32
}

/// libm's `k_sinf`: sin on [-pi/4, pi/4], in `f64`.
#[inline(always)]
fn k_sinf(x: f64) -> f32 {
    let z = x * x;
    let w = z * z;
    let r = S3 + z * S4;
    let s = z * x;
    ((x + s * (S1 + z * S2)) + s * w * r) as f32
}
