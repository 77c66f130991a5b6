//! The integer forward pass of [`Encoding::Integer`](crate::Encoding::Integer): int8 codes in,
//! int32 accumulators, requantisation by a fixed-point multiplier and a right shift, int8 codes
//! out. Every step is integer arithmetic, so a chip without an FPU runs it as it is and the
//! host computes the chip's bits by construction.
//!
//! The requantisation is TensorFlow Lite Micro's `MultiplyByQuantizedMultiplier`
//! (tensorflow/lite/kernels/internal/common.h) for a multiplier below 1, built from gemmlowp's
//! `SaturatingRoundingDoublingHighMul` and `RoundingDivideByPOT`
//! (gemmlowp/fixedpoint/fixedpoint.h), transcribed operation for operation below.
//!
//! The accumulation is exact: the loader bounds every bias by 2³⁰ and a layer has at most 1024
//! inputs, so `|acc| ≤ 2³⁰ + 1024 · 128 · 255 < 2³¹` and no sum ever wraps. An exact integer sum
//! does not depend on its order, so a kernel that pairs inputs (the Armv7E-M `SMLAD`, two
//! 16 × 16 multiplies added to a 32-bit accumulator: `q` sign-extended and `x − zero` both fit
//! in 16 bits) computes the same integers as the column order used here: the Armv7E-M build's
//! [`IntegerDense::run_in_place`] does so (`paired.rs`).

// The `SMLAD` kernel of the Armv7E-M, and its portable stand-in for the host's tests.
#[cfg(any(test, all(target_arch = "arm", target_feature = "dsp")))]
mod paired;

/// gemmlowp's `SaturatingRoundingDoublingHighMul`: the high 32 bits of `2 · a · b`, rounded to
/// nearest with ties toward +∞, saturating the one overflowing case `a = b = i32::MIN`.
///
/// gemmlowp adds a nudge of `2^30` (or `1 − 2^30` when `ab < 0`) and divides by `2^31`
/// truncating toward zero. Both cases are `⌊(ab + 2^30) / 2^31⌋`, one shift: for `ab ≥ 0` the
/// sum is not negative and truncation is the floor; for `ab < 0` the sum `x = ab + 1 − 2^30` is
/// negative, truncation is the ceiling, and `⌈x / 2^31⌉ = ⌊(x + 2^31 − 1) / 2^31⌋ =
/// ⌊(ab + 2^30) / 2^31⌋`. The shift saves the sign's branch and the division's correction, a
/// sixth of a requantisation on a 32-bit core; the tests compare it with the transcription on
/// the edges and on random operands.
///
/// ```
/// use policy_core::mlp::integer::saturating_rounding_doubling_high_mul as srdhm;
/// assert_eq!(srdhm(1 << 30, 1 << 30), 1 << 29); // 0.5 × 0.5 = 0.25 in Q31
/// assert_eq!(srdhm(i32::MIN, i32::MIN), i32::MAX);
/// assert_eq!(srdhm(-3, 1 << 30), -1); // -1.5: ties go toward +∞
/// assert_eq!(srdhm(3, 1 << 30), 2);
/// ```
#[inline]
pub fn saturating_rounding_doubling_high_mul(a: i32, b: i32) -> i32 {
    if a == b && a == i32::MIN {
        return i32::MAX;
    }
    doubling_high_mul_of_verified(a, b)
}

/// gemmlowp's `RoundingDivideByPOT`: `x / 2^exponent` rounded to nearest, ties away from zero,
/// for `exponent` in `0..=31` (a larger one is taken as 31; the loader allows no larger).
///
/// ```
/// use policy_core::mlp::integer::rounding_divide_by_pot as rdbpot;
/// assert_eq!((rdbpot(5, 1), rdbpot(-5, 1), rdbpot(7, 2), rdbpot(-6, 2)), (3, -3, 2, -2));
/// assert_eq!(rdbpot(i32::MIN, 31), -1);
/// ```
#[inline]
pub fn rounding_divide_by_pot(x: i32, exponent: u32) -> i32 {
    let exponent = exponent.min(31);
    // `2^exponent − 1` in 32 bits (`2^31 − 1` for 31), without a 64-bit shift.
    let mask = (1u32 << exponent).wrapping_sub(1) as i32;
    let remainder = x & mask;
    let threshold = (mask >> 1) + i32::from(x < 0);
    (x >> exponent) + i32::from(remainder > threshold)
}

/// TFLite Micro's `MultiplyByQuantizedMultiplier(x, multiplier, shift)` for `shift ≤ 0` (a
/// real multiplier below 1, the only kind the format stores): `x · multiplier · 2^(shift − 31)`,
/// rounded as the two gemmlowp functions round.
///
/// ```
/// use policy_core::mlp::integer::multiply_by_quantized_multiplier as requantise;
/// // 0.75 = (3 << 29) · 2^-31 · 2^0; 0.1875 = the same multiplier, shift -2
/// assert_eq!(requantise(1000, 3 << 29, 0), 750);
/// assert_eq!(requantise(1000, 3 << 29, -2), 188);
/// assert_eq!(requantise(-1000, 3 << 29, -2), -188);
/// ```
#[inline]
pub fn multiply_by_quantized_multiplier(x: i32, multiplier: i32, shift: i32) -> i32 {
    // `rounding_divide_by_pot` takes a shift above 31 as 31 itself.
    let right = shift.unsigned_abs();
    rounding_divide_by_pot(saturating_rounding_doubling_high_mul(x, multiplier), right)
}

/// One integer layer, as the payload stores it (docs/blob-format.md, "The integer forward
/// pass"): the parts of an [`IntegerLayer`](crate::blob::IntegerLayer), as bytes.
#[derive(Clone, Copy, Debug)]
pub struct IntegerDense<'a> {
    /// `outputs` little-endian i32 multipliers.
    pub multipliers: &'a [u8],
    /// `outputs` i8 shifts.
    pub shifts: &'a [u8],
    /// `inputs × outputs` i8 weights, column-major.
    pub weights: &'a [u8],
    /// `outputs` little-endian i32 biases.
    pub bias: &'a [u8],
    /// The zero point of the layer's output codes.
    pub output_zero: i32,
    /// The smallest output code: the output zero point for a fused ReLU, else -128.
    pub lower: i32,
    /// The tanh table (`table[code + 128]`), if the layer has one.
    pub table: Option<&'a [u8]>,
}

impl IntegerDense<'_> {
    /// `y = requantise(bias + Σ_j q[:, j] · (x[j] − x_zero))`, clamped to `lower..=127`, then
    /// through the table if there is one: codes in `y[..outputs]` (as i32 in `-128..=127`).
    /// `x` holds the input codes. Lengths that do not fit leave the missing terms out rather
    /// than panic (a verified blob always fits).
    ///
    /// ```
    /// use policy_core::mlp::integer::IntegerDense;
    /// let words = |v: &[i32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    /// // 2 outputs, 2 inputs: W = [[2, -1], [1, 1]], biases (10, -4), multiplier 0.5
    /// let (m, b) = (words(&[1 << 30, 1 << 30]), words(&[10, -4]));
    /// let layer = IntegerDense {
    ///     multipliers: &m, shifts: &[0, 0], weights: &[2, 1, 0xff, 1], bias: &b,
    ///     output_zero: -5, lower: -5, table: None,
    /// };
    /// let mut y = [0i32; 2];
    /// layer.run(&[7, 3], 1, &mut y); // x - zero = (6, 2)
    /// // acc = (10 + 12 - 2, -4 + 6 + 2) = (20, 4); halved (10, 2); plus the zero point -5
    /// assert_eq!(y, [5, -3]);
    /// ```
    // Not inlined, for the reason the f32 kernels give (kernels.rs, `accumulate`).
    #[inline(never)]
    pub fn run(&self, x: &[i32], x_zero: i32, y: &mut [i32]) {
        let outputs = y.len();
        self.load_bias(y);
        if outputs == 0 {
            return;
        }
        accumulate(self.weights, x, x_zero, y);
        self.requantise(y);
    }

    /// [`IntegerDense::run`], the same integers, with `x` as working space: its contents
    /// afterwards are unspecified (the model's forward pass gives the layer's input vector,
    /// which the next layer overwrites). On an Armv7E-M (`target_feature = "dsp"`: the
    /// Cortex-M4 and M7) the inputs are taken in pairs by an `SMLAD` kernel that packs them
    /// into `x` (`paired.rs`); everywhere else, and for weights shorter than the layer's
    /// sizes, this is [`IntegerDense::run`].
    ///
    /// ```
    /// use policy_core::mlp::integer::IntegerDense;
    /// let words = |v: &[i32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    /// let (m, b) = (words(&[1 << 30, 1 << 30]), words(&[10, -4]));
    /// let layer = IntegerDense {
    ///     multipliers: &m, shifts: &[0, 0], weights: &[2, 1, 0xff, 1], bias: &b,
    ///     output_zero: -5, lower: -5, table: None,
    /// };
    /// let (mut y, mut z) = ([0i32; 2], [0i32; 2]);
    /// layer.run(&[7, 3], 1, &mut y);
    /// layer.run_in_place(&mut [7, 3], 1, &mut z);
    /// assert_eq!(y, z);
    /// ```
    // Not inlined where it holds the `SMLAD` kernel (as `run`); elsewhere it is `run` itself,
    // inlined so that the call costs no second frame.
    #[cfg_attr(all(target_arch = "arm", target_feature = "dsp"), inline(never))]
    #[cfg_attr(not(all(target_arch = "arm", target_feature = "dsp")), inline(always))]
    pub fn run_in_place(&self, x: &mut [i32], x_zero: i32, y: &mut [i32]) {
        #[cfg(all(target_arch = "arm", target_feature = "dsp"))]
        if self.weights.len() >= x.len().saturating_mul(y.len()) {
            self.load_bias(y);
            paired::accumulate(self.weights, x, x_zero, y, paired::block4);
            self.requantise(y);
            return;
        }
        self.run(x, x_zero, y);
    }

    /// The accumulators' start: `y[i] = bias[i]`.
    #[inline(always)]
    fn load_bias(&self, y: &mut [i32]) {
        match words(self.bias) {
            Ok(bias) => {
                for (acc, &b) in y.iter_mut().zip(bias) {
                    *acc = i32::from_le(b);
                }
            }
            Err(_) => {
                for (acc, b) in y.iter_mut().zip(self.bias.chunks_exact(4)) {
                    *acc = i32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                }
            }
        }
    }

    /// The accumulators into output codes: requantised, offset by the output zero point,
    /// clamped, then through the table if there is one.
    #[inline(always)]
    fn requantise(&self, y: &mut [i32]) {
        match words(self.multipliers) {
            Ok(m) => self.requantise_by(y, m.iter().map(|&m| i32::from_le(m))),
            Err(_) => {
                let bytes = self.multipliers.chunks_exact(4);
                self.requantise_by(
                    y,
                    bytes.map(|m| i32::from_le_bytes([m[0], m[1], m[2], m[3]])),
                )
            }
        }
    }

    /// [`IntegerDense::requantise`] with the multipliers read by `multipliers`: the table's
    /// presence is tested once for the layer, not once per output.
    #[inline(always)]
    fn requantise_by(&self, y: &mut [i32], multipliers: impl Iterator<Item = i32>) {
        match self.table {
            Some(table) => self.requantise_with(y, multipliers, |code| lookup(table, code)),
            None => self.requantise_with(y, multipliers, |code| code),
        }
    }

    /// Each accumulator requantised (a verified multiplier is at least 2^30, so the doubling
    /// high multiply's one saturating case cannot occur: [`doubling_high_mul_of_verified`]),
    /// offset by the output zero point, clamped, then mapped by `finish`.
    #[inline(always)]
    fn requantise_with(
        &self,
        y: &mut [i32],
        multipliers: impl Iterator<Item = i32>,
        finish: impl Fn(i32) -> i32,
    ) {
        for (acc, (multiplier, &shift)) in y.iter_mut().zip(multipliers.zip(self.shifts)) {
            let high = doubling_high_mul_of_verified(*acc, multiplier);
            let scaled = rounding_divide_by_pot(high, i32::from(shift as i8).unsigned_abs());
            let code = scaled
                .saturating_add(self.output_zero)
                .clamp(self.lower, 127);
            *acc = finish(code);
        }
    }
}

/// [`saturating_rounding_doubling_high_mul`] without its test for the one saturating case, `a =
/// b = i32::MIN`: equal to it whenever `b > i32::MIN`, as every multiplier the loader accepts is
/// (at least [`MIN_MULTIPLIER`](crate::blob::MIN_MULTIPLIER), 2^30). CMSIS-NN's requantisation
/// (`arm_nn_doubling_high_mult_no_sat`) leaves the test out likewise; it is five instructions of
/// each output's requantisation on the Cortex-M4. For `a = b = i32::MIN` (no verified layer) the
/// result wraps to `i32::MIN` rather than saturating; it never panics.
#[inline(always)]
fn doubling_high_mul_of_verified(a: i32, b: i32) -> i32 {
    // |ab| ≤ 2^62, so the sum does not overflow; the quotient fits in i32 except for the case
    // above, which `as` wraps.
    ((i64::from(a) * i64::from(b) + (1 << 30)) >> 31) as i32
}

/// `bytes` as i32 words in place where they start at a 4-byte boundary (every block of the
/// integer encoding starts at a multiple of 4 from the blob's start, so a blob in a 4-aligned
/// slot has aligned multipliers and biases): one load a word on the chips that cannot load an
/// unaligned word (the Cortex-M0 and the RV32 build a word from four byte loads, shifts and
/// ors otherwise, a fifth of each output's requantisation). The same values as
/// `from_le_bytes` (tested).
#[inline(always)]
fn words(bytes: &[u8]) -> Result<&[i32], bytemuck::PodCastError> {
    bytemuck::try_cast_slice(bytes.get(..bytes.len() / 4 * 4).unwrap_or_default())
}

/// Whether the core is Thumb-1 only (the Cortex-M0/M0+: eight low registers, no immediate
/// offset on a sign-extending byte load), where [`accumulate`] goes column by column instead.
/// Told by the missing 32-bit compare-and-swap: every Thumb-2 core has `LDREX`/`STREX`,
/// ARMv6-M has not, and that `cfg` is stable where the Arm target features (`thumb2`) are
/// visible to `cfg` on nightly only.
const THUMB1: bool = cfg!(target_arch = "arm") && !cfg!(target_has_atomic = "32");

/// `y[o] += Σ_j q[j][o] · (x[j] − x_zero)` over the column-major int8 weights (`q[j]` is the
/// run of `y.len()` bytes for input `j`), four outputs at a time: their accumulators stay in
/// registers for the whole pass over the inputs, and each input's four weights are adjacent
/// bytes. Measured on the integer 4×48 actor under QEMU (docs/cortex-m.md): 6.1 instructions
/// per MAC on the Cortex-M4F and M3 and 7.2 on RV32IMAC, against 7.5, 8.0 and 10.8 one output
/// at a time (which loads and stores an accumulator for every product); the M4F's build runs
/// the `SMLAD` kernel instead ([`IntegerDense::run_in_place`], 4.5). On a Thumb-1 core
/// ([`THUMB1`]) four accumulators spill to the stack (12.5 against 12.2) and two or one at a
/// time cost more still (15.3, 15.1), so there the outputs go one at a time, column by column.
/// The outputs left over (fewer than four) go one at a time. The sums are exact (see the
/// module docs), so the order changes no bit; wrapping only so that no input can panic.
#[inline(always)]
fn accumulate(weights: &[u8], x: &[i32], x_zero: i32, y: &mut [i32]) {
    let outputs = y.len();
    if outputs == 0 {
        return;
    }
    let columns = weights.chunks_exact(outputs).zip(x);
    let product = |q: u8, centred: i32| i32::from(q as i8).wrapping_mul(centred);
    if THUMB1 {
        for (column, &xj) in columns {
            let centred = xj.wrapping_sub(x_zero);
            for (acc, &q) in y.iter_mut().zip(column) {
                *acc = acc.wrapping_add(product(q, centred));
            }
        }
        return;
    }
    accumulate_in_blocks::<WIDE>(weights, x, x_zero, y);
}

/// The blocked order of [`accumulate`]: `W` outputs at a time as far as whole blocks go, then
/// four, two and one (a last layer's two actions take one block of two).
#[inline(always)]
fn accumulate_in_blocks<const W: usize>(weights: &[u8], x: &[i32], x_zero: i32, y: &mut [i32]) {
    let first = blocks::<W>(weights, x, x_zero, y, 0);
    let first = blocks::<4>(weights, x, x_zero, y, first);
    let first = blocks::<2>(weights, x, x_zero, y, first);
    blocks::<1>(weights, x, x_zero, y, first);
}

/// How many outputs [`accumulate`] takes at a time before it goes four at a time: as many
/// accumulators as the core's registers hold beside the pointers and the eight weights in
/// flight. On the RV32 (31 registers) eight: 6.4 instructions per MAC against 7.2 four at a
/// time, and 7.6 sixteen at a time, which spills (docs/cortex-m.md); Thumb-2's 13 hold four.
const WIDE: usize = if cfg!(target_arch = "riscv32") { 8 } else { 4 };

/// `y[o] += Σ_j q[j][o] · (x[j] − x_zero)` for the outputs from `first` on, `B` at a time (their
/// accumulators in registers for the whole pass over the inputs), as far as whole blocks of `B`
/// go; returns the first output it left.
#[inline(always)]
fn blocks<const B: usize>(
    weights: &[u8],
    x: &[i32],
    x_zero: i32,
    y: &mut [i32],
    first: usize,
) -> usize {
    let outputs = y.len();
    if outputs == 0 {
        return first;
    }
    let columns = weights.chunks_exact(outputs).zip(x);
    let product = |q: u8, centred: i32| i32::from(q as i8).wrapping_mul(centred);
    let mut at = first;
    for block in y.get_mut(first..).unwrap_or_default().chunks_exact_mut(B) {
        let mut acc = [0i32; B];
        acc.copy_from_slice(block);
        for (column, &xj) in columns.clone() {
            let centred = xj.wrapping_sub(x_zero);
            if let Some(q) = column.get(at..at + B) {
                for (a, &q) in acc.iter_mut().zip(q) {
                    *a = a.wrapping_add(product(q, centred));
                }
            }
        }
        block.copy_from_slice(&acc);
        at += B;
    }
    at
}

/// `table[code + 128]` as an i8 code (0 past the end, which verified tables never reach).
#[inline]
pub fn lookup(table: &[u8], code: i32) -> i32 {
    let at = usize::try_from(code.saturating_add(128)).unwrap_or(0);
    table.get(at).map_or(0, |&t| i32::from(t as i8))
}

/// The float entry's input quantisation of one observation component: the normaliser and the
/// first layer's input quantisation folded into one affine map, `t = x · scale + offset` (a
/// multiply, then an add: no fused multiply-add), clamped to `[-128, 127]` and rounded half away
/// from zero (`roundf`). A non-finite `x` carries no information: it becomes `zero`, the code of
/// a normalised 0, as the other encodings read it as the mean.
///
/// ```
/// use policy_core::mlp::integer::observation_code;
/// assert_eq!(observation_code(1.0, 25.5, -3.0, -3), 23); // 22.5 rounds away from zero
/// assert_eq!(observation_code(1e30, 25.5, -3.0, -3), 127);
/// assert_eq!(observation_code(f32::NAN, 25.5, -3.0, -3), -3);
/// ```
#[inline]
pub fn observation_code(x: f32, scale: f32, offset: f32, zero: i32) -> i32 {
    if !x.is_finite() {
        return zero;
    }
    let t = x * scale + offset;
    if t.is_nan() {
        return zero; // not reachable for a verified blob (finite scale and offset)
    }
    crate::clamp::clamp(
        libm::roundf(crate::clamp::clamp(t, -128.0, 127.0)),
        -128.0,
        127.0,
    ) as i32
}

/// The float entry's output: a unit code `u` (the output table's value, in `-127..=127`) as the
/// unit action `u / 127` (one f32 division, exact for `u = 0, ±127`).
///
/// ```
/// use policy_core::mlp::integer::unit_of_code;
/// assert_eq!((unit_of_code(127), unit_of_code(-127), unit_of_code(0)), (1.0, -1.0, 0.0));
/// ```
#[inline]
pub fn unit_of_code(code: i32) -> f32 {
    code as f32 / 127.0
}

#[cfg(test)]
mod tests {
    use super::{
        accumulate_in_blocks, doubling_high_mul_of_verified, rounding_divide_by_pot,
        saturating_rounding_doubling_high_mul, IntegerDense,
    };

    /// gemmlowp's `SaturatingRoundingDoublingHighMul` as it is written there: the nudge by
    /// sign, then a division that truncates.
    fn srdhm_transcribed(a: i32, b: i32) -> i32 {
        if a == b && a == i32::MIN {
            return i32::MAX;
        }
        let ab = i64::from(a) * i64::from(b);
        let nudge: i64 = if ab >= 0 { 1 << 30 } else { 1 - (1 << 30) };
        ((ab + nudge) / (1i64 << 31)) as i32
    }

    /// gemmlowp's `RoundingDivideByPOT` with its mask in 64 bits, as first transcribed.
    fn rdbpot_transcribed(x: i32, exponent: u32) -> i32 {
        let exponent = exponent.min(31);
        let mask = ((1i64 << exponent) - 1) as i32;
        let remainder = x & mask;
        let threshold = (mask >> 1) + i32::from(x < 0);
        (x >> exponent) + i32::from(remainder > threshold)
    }

    #[test]
    fn aligned_and_unaligned_words_give_the_same_codes() {
        // Multipliers and biases read in place as words (4-aligned) and byte by byte (the same
        // bytes one past a boundary): the same outputs, for multipliers, shifts and biases
        // across their ranges.
        let outputs = 7;
        let multipliers: Vec<i32> = (0..outputs).map(|o| (1 << 30) + o * 150_000_017).collect();
        let biases: Vec<i32> = (0..outputs).map(|o| (o - 3) * 300_000_001).collect();
        let shifts: Vec<u8> = (0..outputs).map(|o| (-(o * 4) as i8) as u8).collect();
        let weights: Vec<u8> = (0..3 * outputs).map(|i| (i * 37) as u8).collect();
        let le = |v: &[i32]| v.iter().flat_map(|w| w.to_le_bytes()).collect::<Vec<u8>>();
        let (m, b) = (le(&multipliers), le(&biases));
        let mut store = [0u32; 32];
        let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut store);
        let mut run = |offset: usize| {
            bytes[offset..offset + m.len()].copy_from_slice(&m);
            bytes[64 + offset..64 + offset + b.len()].copy_from_slice(&b);
            let layer = IntegerDense {
                multipliers: &bytes[offset..offset + m.len()],
                shifts: &shifts,
                weights: &weights,
                bias: &bytes[64 + offset..64 + offset + b.len()],
                output_zero: -3,
                lower: -128,
                table: None,
            };
            assert_eq!(super::words(layer.bias).is_ok(), offset == 0);
            let mut y = [0i32; 7];
            layer.run(&[100, -128, 127], 5, &mut y);
            y
        };
        let (aligned, unaligned) = (run(0), run(1));
        assert_eq!(aligned, unaligned);
        assert!(aligned.iter().any(|&c| c != aligned[0]), "{aligned:?}");
    }

    #[test]
    fn the_rounding_functions_equal_their_transcriptions() {
        let edges = [
            i32::MIN,
            i32::MIN + 1,
            -(1 << 30) - 1,
            -(1 << 30),
            -(1 << 30) + 1,
            -3,
            -2,
            -1,
            0,
            1,
            2,
            3,
            (1 << 30) - 1,
            1 << 30,
            (1 << 30) + 1,
            i32::MAX - 1,
            i32::MAX,
        ];
        let mut state = 0x9e37_79b9_u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as i32
        };
        // Products on exact ties (a multiple of 2^30 plus or minus one around them) come from
        // the edges; random operands, and random ones against the edges, cover the rest.
        let mut pairs: Vec<(i32, i32)> = Vec::new();
        for &a in &edges {
            for &b in &edges {
                pairs.push((a, b));
            }
        }
        for _ in 0..200_000 {
            let (a, b) = (next(), next());
            pairs.push((a, b));
            pairs.push((a >> (b as u32 % 31), b));
            pairs.push((a, edges[(b as u32 % edges.len() as u32) as usize]));
        }
        for (a, b) in pairs {
            assert_eq!(
                saturating_rounding_doubling_high_mul(a, b),
                srdhm_transcribed(a, b),
                "srdhm({a}, {b})"
            );
            // The requantisation's version without the saturation test, for every multiplier
            // but the one the loader refuses and the test exists for.
            if b != i32::MIN {
                assert_eq!(
                    doubling_high_mul_of_verified(a, b),
                    srdhm_transcribed(a, b),
                    "without the test: ({a}, {b})"
                );
            }
            for exponent in [0, 1, 2, 7, 15, 30, 31, 32, 40] {
                assert_eq!(
                    rounding_divide_by_pot(a, exponent),
                    rdbpot_transcribed(a, exponent),
                    "rdbpot({a}, {exponent})"
                );
            }
        }
    }

    /// The blocked kernel against the sum written out, output by output, on every output count
    /// from 0 to 19 (whole blocks of sixteen, eight, four and two, and what is left) and input
    /// counts 0 to 6,
    /// with weights and inputs across their whole ranges (a small LCG: no dependency).
    #[test]
    fn the_blocked_sums_are_the_plain_sums() {
        let mut state = 0x2545_f491_u32;
        let mut next = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        };
        for outputs in 0..20usize {
            for inputs in 0..7usize {
                let weights: Vec<u8> = (0..outputs * inputs).map(|_| next() as u8).collect();
                let x: Vec<i32> = (0..inputs).map(|_| (next() % 256) as i32 - 128).collect();
                let x_zero = (next() % 256) as i32 - 128;
                let bias: Vec<i32> = (0..outputs)
                    .map(|_| (next() % 2001) as i32 - 1000)
                    .collect();
                // Every block width a core uses (four, eight) and one that spills (sixteen).
                let mut ys = [bias.clone(), bias.clone(), bias.clone()];
                accumulate_in_blocks::<4>(&weights, &x, x_zero, &mut ys[0]);
                accumulate_in_blocks::<8>(&weights, &x, x_zero, &mut ys[1]);
                accumulate_in_blocks::<16>(&weights, &x, x_zero, &mut ys[2]);
                assert!(ys[1] == ys[0] && ys[2] == ys[0], "{outputs} outputs");
                for (o, (&got, &b)) in ys[0].iter().zip(&bias).enumerate() {
                    let plain: i32 = (0..inputs)
                        .map(|j| i32::from(weights[j * outputs + o] as i8) * (x[j] - x_zero))
                        .sum::<i32>()
                        + b;
                    assert_eq!(got, plain, "{outputs} outputs, {inputs} inputs, output {o}");
                }
            }
        }
    }
}
