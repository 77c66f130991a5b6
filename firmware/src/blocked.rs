//! Experiment behind the `proposal-blocked-mac` feature (not part of the example a user copies):
//! the same forward pass as `Policy::act`, with the multiply-accumulates register-blocked.
//!
//! policy-core's `accumulate` walks the weights column by column, so every multiply-accumulate
//! loads `y[o]` from memory and stores it back (4 instructions per MAC on the M4F). Here a block
//! of `B` outputs stays in FPU registers while all inputs stream past; each output still gets
//! `b_o`, then `+= w[o, j] * x_j` for `j` ascending, so the bits are the same (the firmware checks
//! that) and only the instruction count changes.

use policy_core::{mlp::Dense, Policy};

/// Outputs kept in registers at once: the M4F has 32 single-precision registers, so 16 sums
/// leave room for the weights and the input (a 32-block spills, see the report).
const B: usize = 16;

/// `y = b + W x` with the per-output summation order of `policy_core::mlp::accumulate`.
#[inline]
fn dense<const I: usize, const O: usize>(layer: &Dense<I, O>, x: &[f32], y: &mut [f32; O]) {
    let w = layer.w.as_slice();
    y.copy_from_slice(layer.b.as_slice());
    let mut o0 = 0;
    while o0 + B <= O {
        let mut acc = [0.0f32; B];
        acc.copy_from_slice(&y[o0..o0 + B]);
        for (col, &xj) in w.chunks_exact(O).zip(x) {
            for (a, &wo) in acc.iter_mut().zip(&col[o0..o0 + B]) {
                *a += wo * xj;
            }
        }
        y[o0..o0 + B].copy_from_slice(&acc);
        o0 += B;
    }
    for (o, yo) in y.iter_mut().enumerate().skip(o0) {
        for (col, &xj) in w.chunks_exact(O).zip(x) {
            *yo += col[o] * xj;
        }
    }
}

/// `Policy::act`, step for step (normalise, layers, tanh, scale), with [`dense`] for the layers.
pub fn act<const S: usize, const H: usize, const L: usize, const A: usize>(
    p: &Policy<S, H, L, A>,
    obs: &[f32; S],
) -> [f32; A] {
    let z = p.normalizer.normalize(obs);
    let mut pre = [0.0f32; H];
    dense(&p.input, z.as_slice(), &mut pre);
    let mut hidden = [0.0f32; H];
    for layer in &p.trunk.hidden {
        for (h, &v) in hidden.iter_mut().zip(&pre) {
            *h = p.trunk.activation.apply(v);
        }
        dense(layer, &hidden, &mut pre);
    }
    for (h, &v) in hidden.iter_mut().zip(&pre) {
        *h = p.trunk.activation.apply(v);
    }
    let mut out = [0.0f32; A];
    dense(&p.trunk.output, &hidden, &mut out);
    let mut unit = [0.0f32; A];
    for (u, &y) in unit.iter_mut().zip(&out) {
        let t = libm::tanhf(y);
        *u = if t.is_finite() { t } else { 0.0 };
    }
    p.bounds.scale(&unit)
}
