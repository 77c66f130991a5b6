//! The integer dense layer's accumulation with inputs taken in pairs, for the Armv7E-M `SMLAD`
//! (two 16 × 16 multiplies added to a 32-bit accumulator in one instruction). It computes the
//! same integers as [`IntegerDense::run`](super::IntegerDense::run)'s column order (the sum is
//! exact, the module docs of `integer` say why), so the chip and the host still agree bit for bit.
//!
//! The weights are column-major (one input's weights for every output together), so one 32-bit
//! load reads one input's weights for four consecutive outputs. Two such words, inputs `j` and
//! `j + 1`, become the four pairs `(q[r][j], q[r][j + 1])` with two `PKH`s (their low halves
//! together, their high halves together) and four `SXTB16`s (bytes 0 and 2, then rotated by 8:
//! bytes 1 and 3); each pair meets the activation pair `(x[j] − zero, x[j + 1] − zero)` in one
//! `SMLAD`. That is 12 instructions for 8 multiply-accumulates, plus the activation load and
//! the weight pointer's step: 14, and the loop's compare and branch once for two such pairs:
//! 15 for 8 MACs. A row-major
//! layout (CMSIS-NN's) would need no `PKH` and could share the activation loads between two
//! rows, but the blob format fixes the layout and the weights stay in flash where they are.
//!
//! The activation pairs are made once per layer, in place: the layer's input codes (the other
//! half of the model's scratch, which the layer after this one overwrites anyway) become
//! `inputs / 2` words of two int16s. So the pairs need no room beyond the scratch
//! [`Model::scratch_width`](crate::model::Model::scratch_width) already sizes. `x − zero` fits
//! in 16 bits: codes and zero points are int8 (the loader checks every zero point).

use core::cell::Cell;

/// `acc[r] += Σ_k q[2k][r] · lo(pairs[k]) + q[2k + 1][r] · hi(pairs[k])` for each lane `r`,
/// with `q[j][r] = w[j · stride + r]` as i8 and `lo`/`hi` the pair's low and high int16: what
/// the `SMLAD` kernel computes, in portable code. It takes the outputs that do not fill a block
/// of four, and stands in for the kernel on the host's tests. Terms past the end of `w` are left
/// out rather than panic (the driver never asks for them).
pub(super) fn accumulate_lanes(acc: &mut [i32], w: &[u8], stride: usize, pairs: &[i32]) {
    let q = |j: usize, r: usize| {
        let at = j.checked_mul(stride).and_then(|a| a.checked_add(r));
        at.and_then(|a| w.get(a)).map_or(0, |&b| i32::from(b as i8))
    };
    for (r, a) in acc.iter_mut().enumerate() {
        for (k, &pair) in pairs.iter().enumerate() {
            let (lo, hi) = (i32::from(pair as i16), pair >> 16);
            // Exact (the module docs of `integer`); wrapping only so that no input can panic.
            let term = q(2 * k, r)
                .wrapping_mul(lo)
                .wrapping_add(q(2 * k + 1, r).wrapping_mul(hi));
            *a = a.wrapping_add(term);
        }
    }
}

/// Replaces `x[k]` by the pair `(x[2k] − zero, x[2k + 1] − zero)` as two int16 (the first in
/// the low half, as `SMLAD` pairs it with a weight pair's low half) for `k < x.len() / 2`, and
/// returns that count. In place and in order: word `k` reads `x[2k]` and `x[2k + 1]`, which no
/// earlier word has overwritten (`k' < k ≤ 2k`); an odd last input stays where it was.
pub(super) fn pack_pairs(x: &mut [i32], zero: i32) -> usize {
    // Cells, so that word `k` and the pair it reads are one slice's, read and written in one
    // pass without an index to check.
    let cells = Cell::from_mut(x).as_slice_of_cells();
    for (word, pair) in cells.iter().zip(cells.chunks_exact(2)) {
        if let [lo, hi] = pair {
            let (lo, hi) = (lo.get().wrapping_sub(zero), hi.get().wrapping_sub(zero));
            word.set((lo & 0xffff) | (hi << 16));
        }
    }
    cells.len() / 2
}

/// `y[r] += Σ_j q[j][r] · (x[j] − zero)` with `q[j][r] = weights[j · y.len() + r]` as i8: the
/// inputs in pairs through `block` (four outputs at a time: `block(acc, w, stride, pairs)` must
/// compute what [`accumulate_lanes`] computes on four lanes), the outputs past the last full
/// block through [`accumulate_lanes`], an odd last input on its own. `x` is used as working
/// space (its contents afterwards are unspecified). Expects `weights.len() ≥ x.len() · y.len()`
/// (the caller checks it); with fewer, the blocks see terms as [`accumulate_lanes`] would.
pub(super) fn accumulate<K>(weights: &[u8], x: &mut [i32], zero: i32, y: &mut [i32], block: K)
where
    K: Fn(&mut [i32; 4], &[u8], usize, &[i32]),
{
    let (inputs, outputs) = (x.len(), y.len());
    let odd = if inputs % 2 == 1 {
        x.last().map(|&v| v.wrapping_sub(zero))
    } else {
        None
    };
    let count = pack_pairs(x, zero);
    let pairs = x.get(..count).unwrap_or_default();
    let mut blocks = y.chunks_exact_mut(4);
    for (b, acc) in (&mut blocks).enumerate() {
        if let Ok(acc) = <&mut [i32; 4]>::try_from(acc) {
            block(
                acc,
                weights.get(4 * b..).unwrap_or_default(),
                outputs,
                pairs,
            );
        }
    }
    let rest = blocks.into_remainder();
    let done = outputs - rest.len();
    if outputs >= 4 && !rest.is_empty() {
        // The last four outputs as one more block from zero, of which only the lanes past the
        // full blocks are kept: one block's cost rather than the portable loop's per output.
        let mut acc = [0i32; 4];
        let from = outputs - 4;
        block(
            &mut acc,
            weights.get(from..).unwrap_or_default(),
            outputs,
            pairs,
        );
        for (y, a) in rest.iter_mut().zip(acc.iter().skip(done - from)) {
            *y = y.wrapping_add(*a);
        }
    } else {
        let w = weights.get(done..).unwrap_or_default();
        accumulate_lanes(rest, w, outputs, pairs);
    }
    if let Some(centred) = odd {
        let column = weights.get((inputs - 1).saturating_mul(outputs)..);
        for (acc, &q) in y.iter_mut().zip(column.unwrap_or_default()) {
            *acc = acc.wrapping_add(i32::from(q as i8).wrapping_mul(centred));
        }
    }
}

/// [`accumulate_lanes`] on four lanes with `SMLAD`: the loop the module docs count, two input
/// pairs a turn. Stable `asm!`, as the `SMLAD` and `SXTB16` intrinsics are not. Its loads stay
/// inside `w` and `pairs`: checked here, so a call that would read past them takes the portable
/// code instead (the driver never makes one).
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[allow(unsafe_code)] // the one `asm!` of policy-core: SMLAD has no stable intrinsic
#[inline(always)]
pub(super) fn block4(acc: &mut [i32; 4], w: &[u8], stride: usize, pairs: &[i32]) {
    let Some(last) = pairs.len().checked_sub(1) else {
        return;
    };
    // The last byte the loop reads: output 3 of input 2·last + 1.
    let end = (2 * last + 1)
        .checked_mul(stride)
        .and_then(|at| at.checked_add(4));
    if end.is_none_or(|end| end > w.len()) {
        outside(acc, w, stride, pairs);
        return;
    }
    let [mut a0, mut a1, mut a2, mut a3] = *acc;
    // SAFETY: the loop takes exactly `pairs.len()` ≥ 1 pairs: `x` steps one word a pair from
    // `pairs`' start, and the compare with the end comes after an odd count's first pair (the
    // entry at the second half) and after every second pair from there, so `x` meets the end
    // exactly. It reads words `pairs[..]` and, for pair k, the 4 bytes at
    // `w[2k · stride..]` and `w[(2k + 1) · stride..]`, all within `w` by the check above (the
    // highest ends at `(2 · last + 1) · stride + 4 ≤ w.len()`). Unaligned word loads are
    // allowed on Armv7-M (`LDR` only: no `LDRD` or `LDM` here). It writes only its registers
    // and the flags, and touches no stack.
    unsafe {
        core::arch::asm!(
            // Two pairs a turn (one compare and branch for both); an odd count enters at the
            // second, so the first turn takes one pair.
            "sub {t}, {xend}, {x}",
            "tst {t}, #4",
            "bne 3f",
            "2:",
            "ldr {xp}, [{x}], #4",
            "ldr {lo}, [{p}]",
            "ldr {hi}, [{p}, {s}]",
            "add {p}, {p}, {s}, lsl #1",
            // bytes (q0j, q1j, q0j', q1j') and (q2j, q3j, q2j', q3j'), j' = j + 1
            "pkhbt {t}, {lo}, {hi}, lsl #16",
            "pkhtb {lo}, {hi}, {lo}, asr #16",
            "sxtb16 {hi}, {t}",
            "smlad {a0}, {hi}, {xp}, {a0}",
            "sxtb16 {hi}, {t}, ror #8",
            "smlad {a1}, {hi}, {xp}, {a1}",
            "sxtb16 {hi}, {lo}",
            "smlad {a2}, {hi}, {xp}, {a2}",
            "sxtb16 {hi}, {lo}, ror #8",
            "smlad {a3}, {hi}, {xp}, {a3}",
            "3:",
            "ldr {xp}, [{x}], #4",
            "ldr {lo}, [{p}]",
            "ldr {hi}, [{p}, {s}]",
            "add {p}, {p}, {s}, lsl #1",
            "pkhbt {t}, {lo}, {hi}, lsl #16",
            "pkhtb {lo}, {hi}, {lo}, asr #16",
            "sxtb16 {hi}, {t}",
            "smlad {a0}, {hi}, {xp}, {a0}",
            "sxtb16 {hi}, {t}, ror #8",
            "smlad {a1}, {hi}, {xp}, {a1}",
            "sxtb16 {hi}, {lo}",
            "smlad {a2}, {hi}, {xp}, {a2}",
            "sxtb16 {hi}, {lo}, ror #8",
            "smlad {a3}, {hi}, {xp}, {a3}",
            "cmp {x}, {xend}",
            "bne 2b",
            x = inout(reg) pairs.as_ptr() => _,
            xend = in(reg) pairs.as_ptr().wrapping_add(pairs.len()),
            p = inout(reg) w.as_ptr() => _,
            s = in(reg) stride,
            a0 = inout(reg) a0,
            a1 = inout(reg) a1,
            a2 = inout(reg) a2,
            a3 = inout(reg) a3,
            xp = out(reg) _,
            lo = out(reg) _,
            hi = out(reg) _,
            t = out(reg) _,
            options(nostack, readonly),
        );
    }
    *acc = [a0, a1, a2, a3];
}

/// [`block4`]'s way out for a call that would read past its slices: out of line, so that the
/// kernel stays small enough to inline into the driver's loop.
#[cfg(all(target_arch = "arm", target_feature = "dsp"))]
#[cold]
#[inline(never)]
fn outside(acc: &mut [i32; 4], w: &[u8], stride: usize, pairs: &[i32]) {
    accumulate_lanes(acc, w, stride, pairs);
}

#[cfg(test)]
mod tests {
    use super::{accumulate, accumulate_lanes, pack_pairs};

    /// The column order of `IntegerDense::run`, the reference.
    fn columns(weights: &[u8], x: &[i32], zero: i32, y: &mut [i32]) {
        let outputs = y.len();
        for (column, &xj) in weights.chunks_exact(outputs).zip(x) {
            for (acc, &q) in y.iter_mut().zip(column) {
                *acc += i32::from(q as i8) * (xj - zero);
            }
        }
    }

    #[test]
    fn pairs_are_packed_in_place_low_half_first() {
        let mut x = [5, -128, 127, 0, 9];
        assert_eq!(pack_pairs(&mut x, -128), 2);
        assert_eq!(x[0], 133);
        assert_eq!((x[1] as i16, x[1] >> 16, x[4]), (255, 128, 9));
        let mut x = [-128, 127];
        pack_pairs(&mut x, 127);
        assert_eq!((x[0] as i16, x[0] >> 16), (-255, 0));
    }

    #[test]
    fn paired_sums_equal_the_column_order_for_every_shape() {
        // Every input count from 0 to 9 (odd ones leave a last input on its own) and output
        // counts below, at and past a block of four (the remainder as an overlapping block or
        // the portable lanes), with extreme codes and weights among pseudo-random ones.
        let mut seed = 0x1234_5678u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            seed >> 8
        };
        for inputs in 0..10usize {
            for outputs in 1..14usize {
                for zero in [-128, 0, 127, 3] {
                    let weights: Vec<u8> = (0..inputs * outputs)
                        .map(|i| match i % 7 {
                            0 => 0x80,
                            1 => 0x7f,
                            _ => next() as u8,
                        })
                        .collect();
                    let x: Vec<i32> = (0..inputs)
                        .map(|i| match i % 5 {
                            0 => -128,
                            1 => 127,
                            _ => (next() % 256) as i32 - 128,
                        })
                        .collect();
                    let bias: Vec<i32> = (0..outputs).map(|i| i as i32 * 1000 - 5000).collect();
                    let mut expected = bias.clone();
                    columns(&weights, &x, zero, &mut expected);
                    let mut paired = bias.clone();
                    let mut work = x.clone();
                    accumulate(&weights, &mut work, zero, &mut paired, |acc, w, s, p| {
                        accumulate_lanes(acc, w, s, p)
                    });
                    assert_eq!(
                        paired, expected,
                        "{inputs} inputs, {outputs} outputs, zero {zero}"
                    );
                }
            }
        }
    }

    #[test]
    fn short_weights_leave_terms_out_without_panicking() {
        let mut y = [0i32; 5];
        accumulate(&[1, 2, 3], &mut [1, 2, 3], 0, &mut y, |acc, w, s, p| {
            accumulate_lanes(acc, w, s, p)
        });
        let mut acc = [0i32; 4];
        accumulate_lanes(&mut acc, &[], usize::MAX, &[7]);
        assert_eq!(acc, [0; 4]);
    }
}
