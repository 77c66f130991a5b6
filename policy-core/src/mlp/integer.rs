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
/// nearest with ties toward +∞ (its nudge of `2^30` or `1 − 2^30`, then a division that
/// truncates), saturating the one overflowing case `a = b = i32::MIN`.
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
    let ab = i64::from(a) * i64::from(b);
    let nudge: i64 = if ab >= 0 { 1 << 30 } else { 1 - (1 << 30) };
    // Division truncates toward zero, as C's does; the quotient fits in i32 (|ab| < 2^62).
    ((ab + nudge) / (1i64 << 31)) as i32
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
    let mask = ((1i64 << exponent) - 1) as i32;
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
    let right = shift.unsigned_abs().min(31);
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
        for (acc, b) in y.iter_mut().zip(self.bias.chunks_exact(4)) {
            *acc = i32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
    }

    /// The accumulators into output codes: requantised, offset by the output zero point,
    /// clamped, then through the table if there is one.
    #[inline(always)]
    fn requantise(&self, y: &mut [i32]) {
        let parts = self.multipliers.chunks_exact(4).zip(self.shifts);
        for (acc, (m, &shift)) in y.iter_mut().zip(parts) {
            let multiplier = i32::from_le_bytes([m[0], m[1], m[2], m[3]]);
            let scaled = multiply_by_quantized_multiplier(*acc, multiplier, i32::from(shift as i8));
            let code = scaled
                .saturating_add(self.output_zero)
                .clamp(self.lower, 127);
            *acc = match self.table {
                Some(table) => lookup(table, code),
                None => code,
            };
        }
    }
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
    let mut blocks = y.chunks_exact_mut(4);
    let mut first = 0;
    for block in &mut blocks {
        if let [y0, y1, y2, y3] = block {
            let mut acc = [*y0, *y1, *y2, *y3];
            for (column, &xj) in columns.clone() {
                let centred = xj.wrapping_sub(x_zero);
                if let Some(&[q0, q1, q2, q3]) = column.get(first..first + 4) {
                    acc[0] = acc[0].wrapping_add(product(q0, centred));
                    acc[1] = acc[1].wrapping_add(product(q1, centred));
                    acc[2] = acc[2].wrapping_add(product(q2, centred));
                    acc[3] = acc[3].wrapping_add(product(q3, centred));
                }
            }
            [*y0, *y1, *y2, *y3] = acc;
        }
        first += 4;
    }
    for (k, acc) in blocks.into_remainder().iter_mut().enumerate() {
        for (column, &xj) in columns.clone() {
            if let Some(&q) = column.get(first + k) {
                *acc = acc.wrapping_add(product(q, xj.wrapping_sub(x_zero)));
            }
        }
    }
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
    use super::accumulate;

    /// The blocked kernel against the sum written out, output by output, on every output count
    /// from 0 to 11 (whole blocks of four, remainders of one to three) and input counts 0 to 6,
    /// with weights and inputs across their whole ranges (a small LCG: no dependency).
    #[test]
    fn the_blocked_sums_are_the_plain_sums() {
        let mut state = 0x2545_f491_u32;
        let mut next = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        };
        for outputs in 0..12usize {
            for inputs in 0..7usize {
                let weights: Vec<u8> = (0..outputs * inputs).map(|_| next() as u8).collect();
                let x: Vec<i32> = (0..inputs).map(|_| (next() % 256) as i32 - 128).collect();
                let x_zero = (next() % 256) as i32 - 128;
                let bias: Vec<i32> = (0..outputs)
                    .map(|_| (next() % 2001) as i32 - 1000)
                    .collect();
                let mut y = bias.clone();
                accumulate(&weights, &x, x_zero, &mut y);
                for (o, (&got, &b)) in y.iter().zip(&bias).enumerate() {
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
