//! The fixed observations the firmware acts on. firmware/host-check includes this same file
//! (`#[path]`), so the chip and the host always compute on the same inputs.
//!
//! They cover the ordinary case and every input the normaliser must tame: values beyond the clip,
//! NaN, both infinities, a subnormal, and `f32::MAX` (whose normalisation overflows).

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
