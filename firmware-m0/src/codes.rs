//! The fixed observation codes the firmware acts on. firmware/host-check includes this same file
//! (`#[path]`), so the chip and the host always compute on the same inputs.
//!
//! They are int8 codes in the blob's input quantisation, what the integer entry
//! (`Model::act_codes_in`) takes: a sensor pipeline that produces codes, or the host's
//! `Model::observation_codes`, makes them. A code is valid for any integer blob, so the table
//! does not depend on the blob in the slot. It covers both ends of the range, zero and ordinary
//! values; a blob of `n` observations gets each row widened by [`fill`], as
//! firmware/src/observations.rs does for float observations.

/// Observation codes, two per row.
pub const CODES: [[i8; 2]; 10] = [
    [0, 0],
    [127, -128],
    [-128, 127],
    [127, 127],
    [-128, -128],
    [37, -91],
    [-5, 64],
    [100, -3],
    [-77, 12],
    [1, -1],
];

/// How many observations the firmware acts on.
pub const CASES: usize = CODES.len();

/// Observation `k` (below [`CASES`]) for a blob of `codes.len()` observations: component `j` is
/// the table's row `k + j / 2` (wrapping), column `j % 2`. Rows wrap by a compare: the
/// Cortex-M0 has no divide instruction, and `%` would call a software division.
pub fn fill(k: usize, codes: &mut [i8]) {
    let mut row = k;
    for pair in codes.chunks_mut(2) {
        if row >= CASES {
            row -= CASES;
        }
        for (c, &code) in pair.iter_mut().zip(CODES.get(row).unwrap_or(&[0, 0])) {
            *c = code;
        }
        row += 1;
    }
}
