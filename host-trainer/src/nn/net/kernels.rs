//! The loops of the forward and backward passes, on row-major batches.
//!
//! Everything is one kernel, [`matmul`]: `y[r, :] = init[r, :] + Σ_k x[r, k] w[k, :]` with `w`
//! row-major, summed in increasing `k`, one multiply-add at a time ([`matmul_then`] applies a
//! hidden layer's activation to each sum as it is stored). A layer's weights are
//! column-major (`w[j * outputs + o]`), which is exactly the row-major `inputs × outputs` matrix
//! the forward pass needs, so the forward pass adds bias first, then input `j = 0, 1, ...`:
//! policy-core's order of operations. The weight gradient `aᵀ delta` reads `a` transposed in
//! place ([`Lhs::Transposed`]), so the backward pass copies nothing but the small `Wᵀ`.
//!
//! The kernel works on tiles of `R` rows × `C` outputs held in registers, so each weight loaded
//! is used `R` times and each accumulator stays out of memory for the whole sum; plain safe
//! Rust that LLVM vectorises. Where the build has FMA (the workspace builds for x86-64-v3: AVX2
//! and FMA), each multiply-add is fused, one rounding instead of two; a build without it
//! (`-C target-cpu=x86-64`, or a target without the `fma` feature) multiplies and adds, and
//! trains to other bits. Within one build, the result does not depend on the tile shape.
//!
//! The one exception to "same order as policy-core" is a layer with one output (the critic's
//! last layer), where a row-by-row sequential sum cannot use vectors: [`dot_rows`] sums 16
//! interleaved partial sums and adds them in a fixed tree, the same on every instruction set.
//! The batched pass is only the training pass; what is exported and evaluated is
//! [`super::Net::forward_one`], which repeats policy-core's arithmetic exactly.

use policy_core::Activation;

use super::{Layer, Matrix};

/// `acc + w * x`: fused where the build has FMA (one rounding), else a multiply and an add.
/// Never `mul_add` without the `fma` feature: that would be a slow software fallback.
#[inline(always)]
fn madd(acc: f32, w: f32, x: f32) -> f32 {
    #[cfg(target_feature = "fma")]
    {
        w.mul_add(x, acc)
    }
    #[cfg(not(target_feature = "fma"))]
    {
        acc + w * x
    }
}

/// `y[o] += W[o, j] * x[j]` for `j` ascending: policy-core's `mlp::accumulate` on slices, a
/// multiply and an add (never fused), because [`super::Net::forward_one`] must equal the chip.
pub(super) fn accumulate_one(w: &[f32], x: &[f32], y: &mut [f32]) {
    let outputs = y.len();
    for (col, &xj) in w.chunks_exact(outputs).zip(x) {
        for (yo, &wo) in y.iter_mut().zip(col) {
            *yo += wo * xj;
        }
    }
}

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

/// The left operand of [`matmul`], `rows × k`.
#[derive(Clone, Copy)]
pub(super) enum Lhs<'a> {
    /// Row-major: element `(r, kk)` at `data[r * k + kk]`.
    Rows(&'a [f32]),
    /// Stored transposed (`k × rows`, row-major): element `(r, kk)` at `data[kk * rows + r]`.
    Transposed(&'a [f32]),
}

/// `y[r, :] = init + Σ_k x[r, k] w[k, :]` for `x`: rows × `k`, `w`: `k` × `n`, `y`: rows × `n`
/// (row-major), accumulating in increasing `k`.
pub(super) fn matmul(x: Lhs<'_>, k: usize, w: &[f32], n: usize, y: &mut [f32], init: Init<'_>) {
    matmul_then(x, k, w, n, y, init, None);
}

/// [`matmul`], with `activation` applied to each sum as it leaves the registers: a hidden
/// layer's forward pass in one sweep over its output instead of a product then a second pass
/// (the second pass was a tenth of a DCP run, all of it loads and stores). The activated values
/// are the bits a second pass over the product would give (tested).
pub(super) fn matmul_then(
    x: Lhs<'_>,
    k: usize,
    w: &[f32],
    n: usize,
    y: &mut [f32],
    init: Init<'_>,
    activation: Option<Activation>,
) {
    debug_assert!(k > 0 && n > 0, "matmul: empty inner or output dimension");
    debug_assert_eq!(w.len(), k * n);
    debug_assert_eq!(y.len() % n, 0);
    match activation {
        None => matmul_tiled::<ROWS, COLS, NONE>(x, k, w, n, y, init),
        Some(Activation::Relu) => matmul_tiled::<ROWS, COLS, RELU>(x, k, w, n, y, init),
        Some(Activation::Tanh) => matmul_tiled::<ROWS, COLS, TANH>(x, k, w, n, y, init),
    }
}

/// What a tile applies as it stores its sums (a const parameter, so each kernel is compiled
/// with its own store loop and the plain product pays nothing).
const NONE: u8 = 0;
/// ReLU on store.
const RELU: u8 = 1;
/// Tanh ([`tanh_fast`]) on store.
const TANH: u8 = 2;

/// The activation `ACT` of one value.
#[inline(always)]
fn apply<const ACT: u8>(v: f32) -> f32 {
    match ACT {
        RELU => relu(v),
        TANH => tanh_fast(v),
        _ => v,
    }
}

/// ReLU as the batched pass computes it (NaN becomes 0).
#[inline(always)]
fn relu(v: f32) -> f32 {
    if v > 0.0 {
        v
    } else {
        0.0
    }
}

/// Rows per register tile: 6 rows × 2 vectors of 8 outputs keeps 12 multiply-add chains in
/// flight in AVX2's 16 registers (4 rows, 8 chains, was measurably slower: an FMA's latency
/// needs about 10 chains to keep both FMA units busy).
const ROWS: usize = 6;
/// Outputs per register tile: two vectors (SSE: 4 lanes each; AVX: 8).
const COLS: usize = if cfg!(target_feature = "avx") { 16 } else { 8 };

/// [`matmul`] with `R × C` tiles; leftover rows in tiles of 4 and 1, leftover outputs in tiles
/// of 16, 8 and 1. A one-output row-major product goes to [`dot_rows`].
#[inline(always)]
fn matmul_tiled<const R: usize, const C: usize, const ACT: u8>(
    x: Lhs<'_>,
    k: usize,
    w: &[f32],
    n: usize,
    y: &mut [f32],
    init: Init<'_>,
) {
    let rows = y.len() / n;
    if let (1, Lhs::Rows(x), Init::Bias(_) | Init::Zero) = (n, x, init) {
        if k >= 16 {
            dot_rows(x, k, w, y, init);
            y.iter_mut().for_each(|v| *v = apply::<ACT>(*v));
            return;
        }
    }
    let mut r = 0;
    while r + R <= rows {
        row_block::<R, C, ACT>(x, rows, k, r, w, n, y, init);
        r += R;
    }
    while r + 4 <= rows {
        row_block::<4, C, ACT>(x, rows, k, r, w, n, y, init);
        r += 4;
    }
    while r < rows {
        row_block::<1, C, ACT>(x, rows, k, r, w, n, y, init);
        r += 1;
    }
}

/// Rows `r0..r0 + R` of [`matmul`]: `C`-wide tiles, then 16, 8 and 1 wide.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn row_block<const R: usize, const C: usize, const ACT: u8>(
    x: Lhs<'_>,
    rows: usize,
    k: usize,
    r0: usize,
    w: &[f32],
    n: usize,
    y: &mut [f32],
    init: Init<'_>,
) {
    let mut c = 0;
    while c + C <= n {
        tile::<R, C, ACT>(x, rows, k, r0, w, n, c, y, init);
        c += C;
    }
    while c + 16 <= n {
        tile::<R, 16, ACT>(x, rows, k, r0, w, n, c, y, init);
        c += 16;
    }
    while c + 8 <= n {
        tile::<R, 8, ACT>(x, rows, k, r0, w, n, c, y, init);
        c += 8;
    }
    while c < n {
        tile::<R, 1, ACT>(x, rows, k, r0, w, n, c, y, init);
        c += 1;
    }
}

/// One `R × C` tile of [`matmul`]: rows `r0..r0 + R`, outputs `c..c + C`, accumulated in
/// registers.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn tile<const R: usize, const C: usize, const ACT: u8>(
    x: Lhs<'_>,
    rows: usize,
    k: usize,
    r0: usize,
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
            Init::Keep => a.copy_from_slice(&y[(r0 + r) * n + c..][..C]),
            Init::Zero => {}
        }
    }
    match x {
        Lhs::Rows(x) => {
            let xs: [&[f32]; R] = std::array::from_fn(|r| &x[(r0 + r) * k..(r0 + r + 1) * k]);
            for (kk, wrow) in (0..k).zip(w.chunks_exact(n)) {
                let xv: [f32; R] = std::array::from_fn(|r| xs[r][kk]);
                tile_step(&mut acc, &wrow[c..c + C], &xv);
            }
        }
        Lhs::Transposed(x) => {
            for (wrow, xcol) in w.chunks_exact(n).zip(x.chunks_exact(rows)).take(k) {
                let xv: &[f32; R] = match xcol[r0..r0 + R].try_into() {
                    Ok(v) => v,
                    Err(_) => unreachable!("tile slice has length R"),
                };
                tile_step(&mut acc, &wrow[c..c + C], xv);
            }
        }
    }
    for (r, a) in acc.iter().enumerate() {
        for (out, &v) in y[(r0 + r) * n + c..][..C].iter_mut().zip(a) {
            *out = apply::<ACT>(v);
        }
    }
}

/// One `k` of a tile: `acc[r][c] += w[c] * x[r]` for the tile's `C` weights and `R` inputs.
#[inline(always)]
fn tile_step<const R: usize, const C: usize>(acc: &mut [[f32; C]; R], w: &[f32], x: &[f32; R]) {
    let wv: &[f32; C] = match w.try_into() {
        Ok(v) => v,
        Err(_) => unreachable!("tile slice has length C"),
    };
    for (a, &xr) in acc.iter_mut().zip(x) {
        for (s, &wc) in a.iter_mut().zip(wv) {
            *s = madd(*s, wc, xr);
        }
    }
}

/// Lanes of [`dot_rows`]' partial sums.
const LANES: usize = 16;

/// `y[r] = init + x[r, :] · w` for a one-output layer: lane `l` sums the products with
/// `k ≡ l (mod 16)` in increasing `k`, the lanes are added in a fixed tree, then to `init`.
/// Written on plain arrays, so every instruction set gives the same bits.
#[inline(always)]
fn dot_rows(x: &[f32], k: usize, w: &[f32], y: &mut [f32], init: Init<'_>) {
    let start = match init {
        Init::Bias(b) => b[0],
        _ => 0.0,
    };
    let full = k / LANES * LANES;
    for (xr, yr) in x.chunks_exact(k).zip(y.iter_mut()) {
        let mut lanes = [0.0f32; LANES];
        for (xc, wc) in xr[..full]
            .chunks_exact(LANES)
            .zip(w[..full].chunks_exact(LANES))
        {
            for ((l, &xv), &wv) in lanes.iter_mut().zip(xc).zip(wc) {
                *l = madd(*l, wv, xv);
            }
        }
        for ((l, &xv), &wv) in lanes.iter_mut().zip(&xr[full..]).zip(&w[full..k]) {
            *l = madd(*l, wv, xv);
        }
        let mut width = LANES / 2;
        while width > 0 {
            let (lo, hi) = lanes.split_at_mut(width);
            for (a, &b) in lo.iter_mut().zip(&hi[..width]) {
                *a += b;
            }
            width /= 2;
        }
        *yr = start + lanes[0];
    }
}

/// `dst` (cols × rows) = transpose of `src` (rows × cols), both row-major.
fn transpose(src: &[f32], rows: usize, cols: usize, dst: &mut Vec<f32>) {
    dst.resize(rows * cols, 0.0);
    for (c, out) in dst.chunks_exact_mut(rows.max(1)).enumerate() {
        for (o, row) in out.iter_mut().zip(src.chunks_exact(cols.max(1))) {
            *o = row[c];
        }
    }
}

/// `y = b + x Wᵀ` for every row of `x`, in policy-core's order of summation.
pub(super) fn affine(x: &Matrix, layer: &Layer, y: &mut Matrix) {
    affine_then(x, layer, None, y);
}

/// [`affine`], then `activation` on every output, in one sweep ([`matmul_then`]).
pub(super) fn affine_then(
    x: &Matrix,
    layer: &Layer,
    activation: Option<Activation>,
    y: &mut Matrix,
) {
    y.reshape(x.rows, layer.outputs);
    matmul_then(
        Lhs::Rows(&x.data),
        layer.inputs,
        &layer.w,
        layer.outputs,
        &mut y.data,
        Init::Bias(&layer.b),
        activation,
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
/// `inputs × outputs` view of the column-major weights, `aᵀ` read in place), `gb[o] += Σ_r
/// delta[r, o]`. A one-output layer's `G` is a single row, `deltaᵀ a`, the same sums in the
/// same order with the batch as the inner dimension.
pub(super) fn accumulate_grads(a: &Matrix, delta: &Matrix, g: &mut Layer) {
    if a.rows == 0 {
        return;
    }
    if g.outputs == 1 {
        matmul(
            Lhs::Rows(&delta.data),
            a.rows,
            &a.data,
            g.inputs,
            &mut g.w,
            Init::Keep,
        );
    } else {
        matmul(
            Lhs::Transposed(&a.data),
            a.rows,
            &delta.data,
            g.outputs,
            &mut g.w,
            Init::Keep,
        );
    }
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
        Lhs::Rows(&delta.data),
        layer.outputs,
        scratch,
        layer.inputs,
        &mut below.data,
        Init::Zero,
    );
}

/// `d = dL/d(pre-activation)` from `g = dL/d(activation)`: through dropout (`mask`) and the
/// activation's derivative written in terms of its output `h`. Out of place, like
/// [`activate`], so that no loop becomes a masked store.
pub(super) fn activation_grads(
    activation: Activation,
    h: &Matrix,
    mask: Option<&Matrix>,
    g: &Matrix,
    d: &mut Matrix,
) {
    d.reshape(g.rows, g.cols);
    // NaN `h` keeps the gradient, as `if h <= 0.0 { 0.0 } else { g }` would.
    let relu = |h: f32, g: f32| if h > 0.0 || h.is_nan() { g } else { 0.0 };
    let out = d.data.iter_mut().zip(&g.data).zip(&h.data);
    match (activation, mask) {
        (Activation::Tanh, None) => out.for_each(|((d, &g), &h)| *d = g * (1.0 - h * h)),
        (Activation::Relu, None) => out.for_each(|((d, &g), &h)| *d = relu(h, g)),
        (Activation::Tanh, Some(m)) => out
            .zip(&m.data)
            .for_each(|(((d, &g), &h), &m)| *d = g * m * (1.0 - h * h)),
        (Activation::Relu, Some(m)) => out
            .zip(&m.data)
            .for_each(|(((d, &g), &h), &m)| *d = relu(h, g * m)),
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

    fn data(len: usize, f: f32) -> Vec<f32> {
        (0..len).map(|i| (i as f32 * f).sin()).collect()
    }

    /// `y[r, c]` as the kernel documents it: init, then one multiply-add per `k`, ascending.
    fn naive(x: &[f32], k: usize, w: &[f32], n: usize, init: f32, r: usize, c: usize) -> f32 {
        (0..k).fold(init, |acc, kk| madd(acc, w[kk * n + c], x[r * k + kk]))
    }

    const SHAPES: [(usize, usize, usize); 9] = [
        (1, 1, 1),
        (3, 5, 7),
        (4, 8, 8),
        (9, 3, 17),
        (13, 48, 48),
        (64, 4, 48),
        (100, 64, 64),
        (11, 20, 57),
        (17, 33, 1),
    ];

    #[test]
    fn matmul_is_bit_exact_with_the_documented_order_on_ragged_shapes() {
        for (rows, k, n) in SHAPES {
            let x = data(rows * k, 0.37);
            let w = data(k * n, 0.11);
            let b: Vec<f32> = (0..n).map(|i| i as f32 * 0.5).collect();
            let mut y = vec![f32::NAN; rows * n];
            matmul(Lhs::Rows(&x), k, &w, n, &mut y, Init::Bias(&b));
            let mut keep = vec![0.25; rows * n];
            matmul(Lhs::Rows(&x), k, &w, n, &mut keep, Init::Keep);
            // The same product with x stored transposed.
            let mut xt = Vec::new();
            transpose(&x, rows, k, &mut xt);
            let mut from_t = vec![0.25; rows * n];
            matmul(Lhs::Transposed(&xt), k, &w, n, &mut from_t, Init::Keep);
            for r in 0..rows {
                for (c, &bias) in b.iter().enumerate() {
                    let at = r * n + c;
                    assert_eq!(
                        keep[at].to_bits(),
                        naive(&x, k, &w, n, 0.25, r, c).to_bits()
                    );
                    assert_eq!(from_t[at].to_bits(), keep[at].to_bits());
                    let expect = naive(&x, k, &w, n, bias, r, c);
                    if n == 1 && k >= LANES {
                        // One output: 16 partial sums (dot_rows), so only close.
                        assert!((y[at] - expect).abs() < 1e-5, "{rows}x{k}x{n} at {r}");
                    } else {
                        assert_eq!(
                            y[at].to_bits(),
                            expect.to_bits(),
                            "{rows}x{k}x{n} ({r}, {c})"
                        );
                    }
                }
            }
        }
    }

    /// The activation as a second pass over a product's output: what [`matmul_then`] fuses.
    fn activate(activation: Activation, src: &[f32], dst: &mut [f32]) {
        let pairs = dst.iter_mut().zip(src);
        match activation {
            Activation::Tanh => pairs.for_each(|(d, &v)| *d = tanh_fast(v)),
            Activation::Relu => pairs.for_each(|(d, &v)| *d = relu(v)),
        }
    }

    #[test]
    fn an_activation_fused_into_the_product_gives_the_bits_of_a_second_pass() {
        let (mut cut, mut passed) = (0, 0);
        for (rows, k, n) in SHAPES {
            let x = data(rows * k, 0.41);
            let w = data(k * n, 0.09);
            let b = data(n, 0.3);
            for activation in [Activation::Relu, Activation::Tanh] {
                let mut product = vec![0.0; rows * n];
                matmul(Lhs::Rows(&x), k, &w, n, &mut product, Init::Bias(&b));
                let mut two_passes = vec![f32::NAN; rows * n];
                activate(activation, &product, &mut two_passes);
                let mut fused = vec![f32::NAN; rows * n];
                let init = Init::Bias(&b);
                matmul_then(Lhs::Rows(&x), k, &w, n, &mut fused, init, Some(activation));
                let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&fused),
                    bits(&two_passes),
                    "{rows}x{k}x{n} {activation:?}"
                );
                if activation == Activation::Relu {
                    cut += product.iter().filter(|&&v| v < 0.0).count();
                    passed += product.iter().filter(|&&v| v > 0.0).count();
                }
            }
        }
        // Both sides of the ReLU were exercised.
        assert!(cut > 100 && passed > 100, "{cut} cut, {passed} passed");
    }

    /// Builds for wider or narrower vectors (x86-64-v4, SSE) tile differently; with the same
    /// multiply-add they must give the same bits.
    #[test]
    fn the_tile_shape_does_not_change_the_bits() {
        for (rows, k, n) in SHAPES {
            let x = data(rows * k, 0.29);
            let w = data(k * n, 0.07);
            let b = data(n, 0.5);
            for init in [Init::Bias(&b), Init::Keep, Init::Zero] {
                let mut wide = vec![0.5; rows * n];
                matmul_tiled::<ROWS, COLS, NONE>(Lhs::Rows(&x), k, &w, n, &mut wide, init);
                let mut narrow = vec![0.5; rows * n];
                matmul_tiled::<3, 4, NONE>(Lhs::Rows(&x), k, &w, n, &mut narrow, init);
                let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&wide), bits(&narrow), "{rows}x{k}x{n}");
            }
        }
    }

    #[test]
    fn weight_gradients_of_a_one_output_layer_match_the_general_form() {
        let (rows, inputs) = (37, 48);
        let a = Matrix::from_vec(rows, inputs, data(rows * inputs, 0.13));
        let delta = Matrix::from_vec(rows, 1, data(rows, 0.71));
        let mut g = Layer::zeros(inputs, 1);
        g.w.iter_mut().for_each(|v| *v = 0.5);
        accumulate_grads(&a, &delta, &mut g);
        for j in 0..inputs {
            let expect = (0..rows).fold(0.5, |acc, r| {
                madd(acc, delta.data[r], a.data[r * inputs + j])
            });
            assert_eq!(g.w[j].to_bits(), expect.to_bits(), "input {j}");
        }
        assert!((g.b[0] - delta.data.iter().sum::<f32>()).abs() < 1e-5);
    }
}
