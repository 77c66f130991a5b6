//! The loops of the forward and backward passes, on row-major batches.
//!
//! Everything is one kernel, [`matmul`]: `y[r, :] = init[r, :] + Σ_k x[r, k] w[k, :]` with `w`
//! row-major, summed in increasing `k`. A layer's weights are column-major (`w[j * outputs + o]`),
//! which is exactly the row-major `inputs × outputs` matrix the forward pass needs, so the forward
//! pass adds bias first, then input `j = 0, 1, ...` — policy-core's order of operations, and the
//! batched pass agrees with the chip bit for bit (up to the tanh, see [`tanh_fast`]). The two
//! backward products use the same kernel on transposed copies (a few KB, made once per call).
//!
//! The kernel works on tiles of `ROWS` rows × `COLS` outputs held in registers, so each weight
//! loaded is used `ROWS` times and each accumulator stays out of memory for the whole sum; plain
//! safe Rust that LLVM vectorises (the crate forbids `unsafe`, so no intrinsics).

use policy_core::Activation;

use super::{Layer, Matrix};

/// Rows per register tile.
const ROWS: usize = 4;
/// Outputs per register tile: two vectors (SSE: 8 lanes; with AVX enabled at build time, 16).
const COLS: usize = if cfg!(target_feature = "avx") { 16 } else { 8 };

/// What a [`matmul`] output row starts from.
#[derive(Clone, Copy)]
pub(super) enum Init<'a> {
    /// The same bias row for every output row.
    Bias(&'a [f32]),
    /// Zero.
    Zero,
    /// The output's current contents (accumulate).
    Keep,
}

/// `y[o] += W[o, j] * x[j]` for `j` ascending: policy-core's `mlp::accumulate` on slices.
pub(super) fn accumulate_one(w: &[f32], x: &[f32], y: &mut [f32]) {
    let outputs = y.len();
    for (col, &xj) in w.chunks_exact(outputs).zip(x) {
        for (yo, &wo) in y.iter_mut().zip(col) {
            *yo += wo * xj;
        }
    }
}

/// `y[r, :] = init + Σ_k x[r, k] w[k, :]` for `x`: rows × `k`, `w`: `k` × `n`, `y`: rows × `n`
/// (all row-major), accumulating in increasing `k`.
pub(super) fn matmul(x: &[f32], k: usize, w: &[f32], n: usize, y: &mut [f32], init: Init<'_>) {
    debug_assert!(k > 0 && n > 0, "matmul: empty inner or output dimension");
    debug_assert_eq!(w.len(), k * n);
    debug_assert_eq!(x.len() / k, y.len() / n);
    let full = y.len() / n / ROWS * ROWS;
    let (x_full, x_rest) = x.split_at(full * k);
    let (y_full, y_rest) = y.split_at_mut(full * n);
    for (xb, yb) in x_full
        .chunks_exact(ROWS * k)
        .zip(y_full.chunks_exact_mut(ROWS * n))
    {
        row_block::<ROWS>(xb, k, w, n, yb, init);
    }
    for (xr, yr) in x_rest.chunks_exact(k).zip(y_rest.chunks_exact_mut(n)) {
        row_block::<1>(xr, k, w, n, yr, init);
    }
}

/// `R` rows of [`matmul`]: full `COLS`-wide tiles, then the leftover outputs one by one.
fn row_block<const R: usize>(
    x: &[f32],
    k: usize,
    w: &[f32],
    n: usize,
    y: &mut [f32],
    init: Init<'_>,
) {
    let mut c = 0;
    while c + COLS <= n {
        tile::<R, COLS>(x, k, w, n, c, y, init);
        c += COLS;
    }
    while c < n {
        tile::<R, 1>(x, k, w, n, c, y, init);
        c += 1;
    }
}

/// One `R × C` tile of [`matmul`], outputs `c..c + C`, accumulated in registers.
#[inline(always)]
fn tile<const R: usize, const C: usize>(
    x: &[f32],
    k: usize,
    w: &[f32],
    n: usize,
    c: usize,
    y: &mut [f32],
    init: Init<'_>,
) {
    let mut acc = [[0.0f32; C]; R];
    for (r, a) in acc.iter_mut().enumerate() {
        match init {
            Init::Bias(b) => a.copy_from_slice(&b[c..c + C]),
            Init::Keep => a.copy_from_slice(&y[r * n + c..r * n + c + C]),
            Init::Zero => {}
        }
    }
    let xs: [&[f32]; R] = std::array::from_fn(|r| &x[r * k..(r + 1) * k]);
    for (kk, wrow) in w.chunks_exact(n).enumerate().take(k) {
        let wv: &[f32; C] = match wrow[c..c + C].try_into() {
            Ok(v) => v,
            Err(_) => unreachable!("tile slice has length C"),
        };
        for (a, xr) in acc.iter_mut().zip(&xs) {
            let xv = xr[kk];
            for (s, &wc) in a.iter_mut().zip(wv) {
                *s += wc * xv;
            }
        }
    }
    for (r, a) in acc.iter().enumerate() {
        y[r * n + c..r * n + c + C].copy_from_slice(a);
    }
}

/// `dst` (cols × rows) = transpose of `src` (rows × cols), both row-major.
fn transpose(src: &[f32], rows: usize, cols: usize, dst: &mut Vec<f32>) {
    dst.resize(rows * cols, 0.0);
    for (r, row) in src.chunks_exact(cols.max(1)).enumerate() {
        for (c, &v) in row.iter().enumerate() {
            dst[c * rows + r] = v;
        }
    }
}

/// `y = b + x Wᵀ` for every row of `x`, in policy-core's order of summation.
pub(super) fn affine(x: &Matrix, layer: &Layer, y: &mut Matrix) {
    y.reshape(x.rows, layer.outputs);
    matmul(
        &x.data,
        layer.inputs,
        &layer.w,
        layer.outputs,
        &mut y.data,
        Init::Bias(&layer.b),
    );
}

/// tanh by Eigen's 13/6 rational approximation (also used by TensorFlow/XLA and ONNX Runtime):
/// at most 4.2e-7 from the exact tanh (checked on every f32 in [0, 10]), clamped into [-1, 1]
/// (the raw ratio exceeds 1 by an ulp near ±6), branch-free, so a whole layer's activations
/// vectorise: `libm::tanhf` made a width-48 forward pass 4x slower than the products. NaN stays
/// NaN, so a diverging pass still shows as non-finite.
///
/// Only the batched training pass uses it; [`super::Net::forward_one`] (what is exported and
/// evaluated) uses `libm::tanhf` exactly as policy-core does.
#[inline(always)]
pub(super) fn tanh_fast(x: f32) -> f32 {
    // Beyond ±9, tanh is ±1 in f32. `clamp` keeps NaN.
    let x = x.clamp(-9.0, 9.0);
    let x2 = x * x;
    let mut p = x2 * -2.760_768_4e-16 + 2.000_188e-13;
    p = x2 * p + -8.604_672e-11;
    p = x2 * p + 5.122_297_3e-8;
    p = x2 * p + 1.485_722_35e-5;
    p = x2 * p + 6.372_619_5e-4;
    p = x2 * p + 4.893_524_6e-3;
    let p = x * p;
    let mut q = x2 * 1.198_258_4e-6 + 1.185_347_1e-4;
    q = x2 * q + 2.268_434_7e-3;
    q = x2 * q + 4.893_525e-3;
    (p / q).clamp(-1.0, 1.0)
}

/// Applies the hidden activation in place (batched pass).
pub(super) fn activate(activation: Activation, data: &mut [f32]) {
    match activation {
        Activation::Tanh => data.iter_mut().for_each(|v| *v = tanh_fast(*v)),
        Activation::Relu => data
            .iter_mut()
            .for_each(|v| *v = if *v > 0.0 { *v } else { 0.0 }),
    }
}

/// The actor's output squashing in the batched pass: tanh, non-finite -> 0 (as policy-core).
pub(super) fn squash_tanh(data: &mut [f32]) {
    data.iter_mut().for_each(|v| {
        let t = tanh_fast(*v);
        *v = if t.is_finite() { t } else { 0.0 };
    });
}

/// Inverted dropout: each value survives with probability `1 - p` and is then scaled by
/// `1 / (1 - p)`. `mask` gets the factors (for backward), `dropped` the result.
///
/// Each decision uses 16 random bits (four per `next_u64`): drawing is a visible cost at 10⁴
/// activations per update, and a resolution of 2⁻¹⁶ in `p` is plenty.
pub(super) fn dropout(
    h: &Matrix,
    p: f32,
    rng: &mut impl rand_core::Rng,
    mask: &mut Matrix,
    dropped: &mut Matrix,
) {
    let threshold = p * 65_536.0;
    let scale = if p < 1.0 { 1.0 / (1.0 - p) } else { 0.0 };
    mask.reshape(h.rows, h.cols);
    dropped.reshape(h.rows, h.cols);
    for chunk in mask.data.chunks_mut(4) {
        let mut bits = rng.next_u64();
        for m in chunk {
            *m = if (bits & 0xffff) as f32 >= threshold {
                scale
            } else {
                0.0
            };
            bits >>= 16;
        }
    }
    for ((d, &v), &m) in dropped.data.iter_mut().zip(&h.data).zip(&mask.data) {
        *d = v * m;
    }
}

/// Adds the gradients of a layer that consumed `a` and produced pre-activations with gradient
/// `delta`: `gW[o, j] += Σ_r delta[r, o] a[r, j]` (as `G += aᵀ delta`, `G` being the row-major
/// `inputs × outputs` view of the column-major weights), `gb[o] += Σ_r delta[r, o]`.
pub(super) fn accumulate_grads(a: &Matrix, delta: &Matrix, g: &mut Layer, scratch: &mut Vec<f32>) {
    transpose(&a.data, a.rows, a.cols, scratch);
    matmul(
        scratch,
        a.rows,
        &delta.data,
        g.outputs,
        &mut g.w,
        Init::Keep,
    );
    for dr in delta.data.chunks_exact(g.outputs.max(1)) {
        for (gb, &d) in g.b.iter_mut().zip(dr) {
            *gb += d;
        }
    }
}

/// `below = delta W`: the gradient with respect to the layer's input.
pub(super) fn input_grads(
    delta: &Matrix,
    layer: &Layer,
    below: &mut Matrix,
    scratch: &mut Vec<f32>,
) {
    below.reshape(delta.rows, layer.inputs);
    // Wᵀ as a row-major outputs × inputs matrix: row o holds W[o, :].
    transpose(&layer.w, layer.inputs, layer.outputs, scratch);
    matmul(
        &delta.data,
        layer.outputs,
        scratch,
        layer.inputs,
        &mut below.data,
        Init::Zero,
    );
}

/// Turns dL/d(activation) into dL/d(pre-activation) in place, through dropout (`mask`) and the
/// activation's derivative written in terms of its output `h`.
pub(super) fn activation_grads(
    activation: Activation,
    h: &Matrix,
    mask: Option<&Matrix>,
    d: &mut Matrix,
) {
    if let Some(mask) = mask {
        d.data
            .iter_mut()
            .zip(&mask.data)
            .for_each(|(d, &m)| *d *= m);
    }
    match activation {
        Activation::Tanh => d
            .data
            .iter_mut()
            .zip(&h.data)
            .for_each(|(d, &h)| *d *= 1.0 - h * h),
        Activation::Relu => d.data.iter_mut().zip(&h.data).for_each(|(d, &h)| {
            if h <= 0.0 {
                *d = 0.0;
            }
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tanh_fast_is_within_a_few_ulp_of_libm() {
        let mut worst = 0.0f32;
        for i in -200_000..=200_000 {
            let x = i as f32 * 1e-4;
            worst = worst.max((tanh_fast(x) - libm::tanhf(x)).abs());
        }
        assert!(worst < 5e-7, "max |tanh_fast - tanhf| = {worst}");
        assert_eq!(tanh_fast(1e30), 1.0);
        assert_eq!(tanh_fast(-1e30), -1.0);
        assert!(tanh_fast(f32::NAN).is_nan());
        assert_eq!(tanh_fast(0.0), 0.0);
    }

    #[test]
    fn matmul_matches_a_naive_product_on_ragged_shapes() {
        for (rows, k, n) in [
            (1, 1, 1),
            (3, 5, 7),
            (4, 8, 8),
            (9, 3, 17),
            (13, 48, 48),
            (64, 4, 48),
        ] {
            let x: Vec<f32> = (0..rows * k).map(|i| (i as f32 * 0.37).sin()).collect();
            let w: Vec<f32> = (0..k * n).map(|i| (i as f32 * 0.11).cos()).collect();
            let b: Vec<f32> = (0..n).map(|i| i as f32 * 0.5).collect();
            let mut y = vec![f32::NAN; rows * n];
            matmul(&x, k, &w, n, &mut y, Init::Bias(&b));
            let mut keep = y.clone();
            matmul(&x, k, &w, n, &mut keep, Init::Keep);
            for r in 0..rows {
                for c in 0..n {
                    // The documented order: init, then k ascending; so this is bit-exact.
                    let mut expect = b[c];
                    for kk in 0..k {
                        expect += w[kk * n + c] * x[r * k + kk];
                    }
                    assert_eq!(
                        y[r * n + c].to_bits(),
                        expect.to_bits(),
                        "{rows}x{k}x{n} at ({r}, {c})"
                    );
                    let mut twice = expect;
                    for kk in 0..k {
                        twice += w[kk * n + c] * x[r * k + kk];
                    }
                    assert_eq!(keep[r * n + c].to_bits(), twice.to_bits());
                }
            }
        }
    }
}
