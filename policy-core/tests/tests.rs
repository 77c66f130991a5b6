//! policy-core's integration tests: one binary, one module per concern (ripgrep's layout).

// Fixtures: a seeded generator and realistic or arbitrary models built from it.
mod support;

// Committed blobs, inputs and bit-exact expected outputs (`UPDATE_GOLDEN=1` regenerates them).
mod golden;
// The format is postcard: byte equality with serde, the spec's worked example, the CRC.
mod format;
// Every load check returns its typed error and leaves the slot untouched.
mod errors;
// The runtime Model: any shape from the bytes, same bits as the compiled types, discrete kind.
mod model;
// Any valid model written then loaded is identical (proptest).
mod roundtrip;
// Random bytes, bit flips and truncations are rejected with an error, never a panic.
mod robustness;
// Actions are finite and in bounds for every observation, finite or not.
mod act_bounds;
// f16 and int8 blobs: stored, computed and refused as documented.
mod quantised;
// The integer encoding: the page's forward pass, both entries, bounds, refusals, corruption.
mod integer;
// The vectorisable tanhf is bit-identical to libm::tanhf.
mod tanh;
// Batch normal draws are the single draws, bit for bit (libm's logf and cosf, ported).
mod normal;
// The device-side compare step never returns a worse action under Q.
mod compare;
// The A/B flash slots: fallback and safe state on every bad slot, never a panic.
mod slots;
// The conformance vectors (policy-core/conformance/): generated, committed, and run.
mod conformance;
