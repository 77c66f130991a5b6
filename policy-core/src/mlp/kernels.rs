//! The layer kernels, `y = b + W x`, for weights in any form: f32 words or bytes (a blob's
//! payload, or a compiled [`Dense`](super::Dense)'s matrix), f16 and int8. Every kernel fixes
//! the same summation order, so every form of the same numbers gives the same bits.

use nalgebra::{SMatrix, SVector};

/// Adds `W x` to `y`, one input column at a time in increasing order:
/// `y[o] += W[o, j] * x[j]` for `j = 0, 1, ...`.
///
/// This order is part of the contract with the trainer (it is what makes exported and trained
/// outputs bit-identical): each output sees exactly that sequence of roundings, with separate
/// multiplies and adds (never a fused multiply-add). Only the interleaving *between* outputs is
/// free, and that is what the implementation uses for speed.
///
/// ```
/// use nalgebra::{SMatrix, SVector};
/// use policy_core::mlp::accumulate;
/// let w = SMatrix::<f32, 2, 3>::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
/// let mut y = SVector::<f32, 2>::new(0.5, -0.5);
/// accumulate(&w, &[1.0, 0.0, -1.0], &mut y);
/// assert_eq!(y.as_slice(), &[0.5 + 1.0 - 3.0, -0.5 + 4.0 - 6.0]);
/// ```
// Not inlined: a layer is hundreds of multiply-adds, so the call is free, while inlining every
// layer into `act` made the register allocator spill the block accumulators (measured: the
// 2×32 and 6×64 ReLU actors ran about 1.5-2× slower inlined; see benches/act.rs).
#[inline(never)]
pub fn accumulate<const I: usize, const O: usize>(
    w: &SMatrix<f32, O, I>,
    x: &[f32],
    y: &mut SVector<f32, O>,
) {
    // nalgebra stores the matrix column-major, as a blob does: the same kernel as a payload's.
    accumulate_columns(w.as_slice(), x, y.as_mut_slice(), |v: &f32| *v);
}

/// Outputs whose partial sums stay in registers for a whole pass: 32 on hosts (eight SSE
/// registers). A Cortex-M4F has 32 single-precision registers in all, so a 32-block spills;
/// 16 fits (measured under QEMU for the 4×48 actor: 5.97 → 4.33 instructions per
/// multiply-accumulate, same bits, see scripts/cortex-m.sh).
#[cfg(not(target_arch = "arm"))]
const WIDE_BLOCK: usize = 32;
#[cfg(target_arch = "arm")]
const WIDE_BLOCK: usize = 16;

/// `y = b + W x` with the weights and biases read from little-endian `f32` bytes (a blob's
/// payload): `weights` holds `x.len()` columns of `y.len()` values, `bias` `y.len()` values. The
/// same operations in the same order as [`accumulate`] on the same numbers, so the same bits;
/// the runtime [`Model`](crate::model::Model) runs every layer through it. Lengths that do not
/// fit leave the missing terms out rather than panic (a verified blob always fits).
///
/// Bytes at a 4-byte boundary (a version-2 payload in an aligned buffer) are read as `f32` words
/// on a little-endian target; any other slice is decoded 4 bytes at a time. Both give the same
/// values, but on a Cortex-M4F the word path loads each weight straight into an FPU register,
/// where decoding takes an integer load and a move (measured with scripts/cortex-m.sh for the
/// trained 4×48 ReLU actor run from flash: 4.92 → 3.03 instructions per multiply-accumulate,
/// same bits).
///
/// ```
/// use policy_core::mlp::accumulate_bytes;
/// let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
/// let (w, b) = (f(&[1.0, 4.0, 2.0, 5.0, 3.0, 6.0]), f(&[0.5, -0.5])); // 2 outputs, 3 inputs
/// let mut y = [0.0; 2];
/// accumulate_bytes(&w, &b, &[1.0, 0.0, -1.0], &mut y);
/// assert_eq!(y, [0.5 + 1.0 - 3.0, -0.5 + 4.0 - 6.0]);
/// ```
// Not inlined, for the reason given at `accumulate`.
#[inline(never)]
pub fn accumulate_bytes(weights: &[u8], bias: &[u8], x: &[f32], y: &mut [f32]) {
    #[cfg(target_endian = "little")]
    if let (Ok(w), Ok(b)) = (words(weights), words(bias)) {
        return accumulate_values(w, b, x, y, |v: &f32| *v);
    }
    accumulate_values(quads(weights), quads(bias), x, y, |q: &[u8; 4]| {
        f32::from_le_bytes(*q)
    });
}

/// The bytes as `f32` words, if they start at a 4-byte boundary (the length is cut to whole
/// words).
#[cfg(target_endian = "little")]
fn words(bytes: &[u8]) -> Result<&[f32], bytemuck::PodCastError> {
    bytemuck::try_cast_slice(bytes.get(..bytes.len() / 4 * 4).unwrap_or_default())
}

/// The bytes in groups of 4, at any alignment (the length is cut to whole groups).
fn quads(bytes: &[u8]) -> &[[u8; 4]] {
    bytemuck::try_cast_slice(bytes.get(..bytes.len() / 4 * 4).unwrap_or_default())
        .unwrap_or_default()
}

/// [`accumulate_bytes`] over parameters stored as `T` and read with `value`.
#[inline(always)]
fn accumulate_values<T>(
    weights: &[T],
    bias: &[T],
    x: &[f32],
    y: &mut [f32],
    value: impl Fn(&T) -> f32 + Copy,
) {
    for (yo, b) in y.iter_mut().zip(bias) {
        *yo = value(b);
    }
    accumulate_columns(weights, x, y, value);
}

/// `y += W x` for weights stored as `T` (read with `value`), `x.len()` columns of `y.len()`:
/// per output, input columns in increasing order, one multiply and one add each.
#[inline(always)]
fn accumulate_columns<T>(
    weights: &[T],
    x: &[f32],
    y: &mut [f32],
    value: impl Fn(&T) -> f32 + Copy,
) {
    let column = y.len();
    if column == 0 {
        return;
    }
    let mut start = 0;
    while start + WIDE_BLOCK <= y.len() {
        accumulate_block::<T, WIDE_BLOCK>(weights, column, x, y, start, value);
        start += WIDE_BLOCK;
    }
    if WIDE_BLOCK > 16 && start + 16 <= y.len() {
        accumulate_block::<T, 16>(weights, column, x, y, start, value);
        start += 16;
    }
    let rest = y.get_mut(start..).unwrap_or_default();
    for (col, &xj) in weights.chunks_exact(column).zip(x) {
        let col = col.get(start..).unwrap_or_default();
        for (yo, w) in rest.iter_mut().zip(col) {
            *yo += value(w) * xj;
        }
    }
}

/// `y = b + W x` for a layer with f16 weights (2 bytes each, little-endian binary16, column-major
/// like [`accumulate_bytes`]) and f32 biases: each weight is decoded exactly
/// ([`crate::half::f16_to_f32`]) and the arithmetic is [`accumulate_bytes`]'s, in the same order,
/// so an f16 blob computes what an f32 blob with the decoded weights computes. The weights must
/// be finite (the loader checks); an infinity or NaN reads as some finite value
/// ([`crate::half::f16_to_f32_finite`]).
///
/// ```
/// use policy_core::mlp::accumulate_f16;
/// let w: Vec<u8> = [0x3c00u16, 0x4000, 0xbc00, 0x3800].iter().flat_map(|h| h.to_le_bytes()).collect();
/// let b: Vec<u8> = [0.5f32, -0.5].iter().flat_map(|v| v.to_le_bytes()).collect();
/// let mut y = [0.0; 2]; // 2 outputs, 2 inputs: W = [[1, -1], [2, 0.5]]
/// accumulate_f16(&w, &b, &[1.0, 2.0], &mut y);
/// assert_eq!(y, [0.5 + 1.0 - 2.0, -0.5 + 2.0 + 1.0]);
/// ```
// Not inlined, for the reason given at `accumulate`.
#[inline(never)]
pub fn accumulate_f16(weights: &[u8], bias: &[u8], x: &[f32], y: &mut [f32]) {
    for (yo, b) in y.iter_mut().zip(quads(bias)) {
        *yo = f32::from_le_bytes(*b);
    }
    let pairs: &[[u8; 2]] =
        bytemuck::try_cast_slice(weights.get(..weights.len() / 2 * 2).unwrap_or_default())
            .unwrap_or_default();
    // The loader has checked every weight is finite, so the branch-free decoder is exact here.
    // Without a hardware FPU (the Cortex-M3) its multiply is a soft-float call, and the exact
    // decoder's integer branches are cheaper; both give the same bits on finite weights.
    #[cfg(not(all(target_arch = "arm", not(target_abi = "eabihf"))))]
    let decode = crate::half::f16_to_f32_finite;
    #[cfg(all(target_arch = "arm", not(target_abi = "eabihf")))]
    let decode = crate::half::f16_to_f32;
    accumulate_columns(pairs, x, y, |h: &[u8; 2]| decode(u16::from_le_bytes(*h)));
}

/// `y = b + scale ⊙ (Q x)` for a layer with int8 weights: `weights` holds the signed bytes `q`
/// column-major like [`accumulate_bytes`], `scales` and `bias` one little-endian f32 per output.
/// Per output: `acc = 0`, then `acc += q[j] · x[j]` for the inputs in increasing order, then
/// `y = b + scale · acc`; one multiply per weight, and the scale applied once per output.
///
/// ```
/// use policy_core::mlp::accumulate_int8;
/// let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
/// let q = [127i8, -64, 1, 127].map(|v| v as u8); // columns: input 0 then input 1
/// let mut y = [0.0; 2];
/// accumulate_int8(&f(&[0.5, 0.25]), &q, &f(&[1.0, 0.0]), &[2.0, 1.0], &mut y);
/// assert_eq!(y, [1.0 + 0.5 * (254.0 + 1.0), 0.25 * (-128.0 + 127.0)]);
/// ```
// Not inlined, for the reason given at `accumulate`.
#[inline(never)]
pub fn accumulate_int8(scales: &[u8], weights: &[u8], bias: &[u8], x: &[f32], y: &mut [f32]) {
    y.iter_mut().for_each(|v| *v = 0.0);
    accumulate_columns(weights, x, y, |q: &u8| f32::from(*q as i8));
    for ((yo, s), b) in y.iter_mut().zip(quads(scales)).zip(quads(bias)) {
        *yo = f32::from_le_bytes(*b) + f32::from_le_bytes(*s) * *yo;
    }
}

/// [`accumulate_columns`] for outputs `start..start + B`: the block's partial sums live in
/// registers for the whole pass over the inputs instead of going through memory once per input,
/// which is what bounds the naive loop. `B = 32` is eight SSE registers of independent sums,
/// enough to hide the add latency and keep both add units busy, with registers left for the
/// weights and the broadcast input; a 16 block picks up widths like 48.
#[inline(always)]
fn accumulate_block<T, const B: usize>(
    weights: &[T],
    column: usize,
    x: &[f32],
    y: &mut [f32],
    start: usize,
    value: impl Fn(&T) -> f32,
) {
    let Some(Ok(out)) = y.get_mut(start..start + B).map(<&mut [f32; B]>::try_from) else {
        return;
    };
    let mut acc = *out;
    for (col, &xj) in weights.chunks_exact(column).zip(x) {
        let Some(Ok(wb)) = col.get(start..start + B).map(<&[T; B]>::try_from) else {
            return;
        };
        for (a, w) in acc.iter_mut().zip(wb) {
            *a += value(w) * xj;
        }
    }
    *out = acc;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mlp::Dense;

    /// Deterministic values with every sign and a wide range of magnitudes.
    fn values(n: usize, seed: u32) -> Vec<f32> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                ((s >> 8) as f32 / 8_388_608.0 - 1.0) * (1 + (s & 7)) as f32
            })
            .collect()
    }

    /// `values` as little-endian bytes at a 4-byte boundary, and the same bytes one byte off.
    fn aligned_and_not(v: &[f32]) -> (Vec<u32>, Vec<u8>) {
        let words: Vec<u32> = v.iter().map(|x| u32::from_le(x.to_bits())).collect();
        let mut shifted = vec![0u8];
        shifted.extend(v.iter().flat_map(|x| x.to_le_bytes()));
        (words, shifted)
    }

    // Guards the aligned fast path of `accumulate_bytes`: reading weights as words must give
    // the bits of the byte-by-byte decoding and of the compiled `accumulate`.
    #[test]
    fn word_and_byte_paths_give_the_same_bits_as_the_compiled_layer() {
        const I: usize = 5;
        const O: usize = 41; // two 16-blocks on ARM, a 32-block on hosts, and a remainder
        let (w, b, x) = (values(I * O, 1), values(O, 2), values(I, 3));
        let (w_words, w_shifted) = aligned_and_not(&w);
        let (b_words, b_shifted) = aligned_and_not(&b);
        let (w_aligned, b_aligned): (&[u8], &[u8]) = (
            bytemuck::cast_slice(&w_words),
            bytemuck::cast_slice(&b_words),
        );
        let (w_odd, b_odd) = (&w_shifted[1..], &b_shifted[1..]);
        assert!(words(w_aligned).is_ok() && words(w_odd).is_err());

        let mut fast = [0.0f32; O];
        let mut slow = [0.0f32; O];
        accumulate_bytes(w_aligned, b_aligned, &x, &mut fast);
        accumulate_bytes(w_odd, b_odd, &x, &mut slow);
        let mut dense = Dense::<I, O>::ZERO;
        dense.w.as_mut_slice().copy_from_slice(&w);
        dense.b.as_mut_slice().copy_from_slice(&b);
        let compiled = dense.affine(&[x[0], x[1], x[2], x[3], x[4]]);
        for k in 0..O {
            assert_eq!(fast[k].to_bits(), slow[k].to_bits(), "output {k}");
            assert_eq!(fast[k].to_bits(), compiled[k].to_bits(), "output {k}");
        }
    }
}
