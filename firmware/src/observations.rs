//! The fixed observations the firmware acts on. firmware/host-check includes this same file
//! (`#[path]`), so the chip and the host always compute on the same inputs.
//!
//! They cover the ordinary case and every input the normaliser must tame: values beyond the clip,
//! NaN, both infinities, a subnormal, and `f32::MAX` (whose normalisation overflows). A blob of
//! two observations (the navigation task's `[x, y]`) gets the table as it stands; a blob of `n`
//! gets each row widened by [`fill`], so every dimension meets every special value.

/// Observations `[x, y]`; the normaliser of the generated blobs has mean `[1.5, -0.7]`.
pub const OBSERVATIONS: [[f32; 2]; 10] = [
    [0.0, 0.0],
    [1.5, -0.7],
    [4.0, -2.5],
    [-3.2, 2.9],
    [0.37, 1.91],
    [12.0, -40.0],
    [f32::NAN, 1.0],
    [f32::INFINITY, f32::NEG_INFINITY],
    [-0.0, 1.0e-39],
    [f32::MAX, -f32::MAX],
];

/// How many observations the firmware acts on.
pub const CASES: usize = OBSERVATIONS.len();

/// Observation `k` for a blob of `obs.len()` observations: component `j` is the table's row
/// `k + j / 2` (wrapping), column `j % 2`. Components 0 and 1 are row `k` itself, so a
/// two-observation blob sees the table unchanged.
pub fn fill(k: usize, obs: &mut [f32]) {
    for (j, o) in obs.iter_mut().enumerate() {
        let row = &OBSERVATIONS[(k + j / 2) % CASES];
        *o = row[j % 2];
    }
}
