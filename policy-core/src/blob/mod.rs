//! The weight-blob format: one definition, used by the loader on the chip and the writer on the
//! host. `docs/blob-format.md` specifies it byte by byte.
//!
//! ```text
//! blob    = header padding payload crc
//! header  = postcard(Header)            magic "DCPB", version 2 (f32), 3 (f16, int8) or 4
//!                                       (integer), kind, encoding, shape, activation, label,
//!                                       payload length
//! padding = 0 to 3 zero bytes           so that the payload starts at a multiple of 4
//! payload = every parameter             f32: 4 bytes little-endian each; f16 and int8 store
//!                                       the layers' weights in 2 or 1 bytes, integer stores
//!                                       integer layers ([`IntegerLayer`]; see [`Encoding`])
//! crc     = u32 little-endian           CRC-32/ISO-HDLC of everything before it
//! ```
//!
//! Version 1 blobs (no encoding field, no `choices` in the shape, no padding) still load.
//!
//! Loading checks, in order: magic, version, header, an encoding this build reads (cargo features
//! `f32`, `f16`, `int8`, `integer`, all on by default), limits, length, padding, checksum
//! ([`verify`]); then the parameter rules ([`check_parameters`]: finite values, normaliser,
//! bounds, action table), which [`Model::from_blob`](crate::model::Model::from_blob) and
//! [`load_into`] both run; [`load_into`] also checks kind and shape against its type. Nothing
//! runs, and nothing is written to a slot, unless every check passed.
//!
//! The files split it by what each part does, from the bottom up: the crate's `format.rs` (the types: kind,
//! encoding, shape, header, layer layout, write spec), `limits.rs` (the sizes allowed and the
//! shape check), `header.rs` (decoding a header, each varint checked for its shortest
//! length), `read.rs` (verifying a blob, version 1 included), `params.rs` (the parameter
//! rules and the decoded values), `quantise.rs` (f16 and int8 weights), `write.rs` (writing a
//! blob), `encode.rs` (re-encoding an f32 blob, host side) and `compiled.rs` (loading and writing
//! the const-generic [`Policy`](crate::Policy) and [`Critic`](crate::Critic)); for the integer
//! encoding, `integer.rs` (its parameter rules and its writer) and `calibrate.rs` (the ranges it
//! is quantised with), its layout in the crate's `integer_layout.rs`. Every public item
//! is here, as `blob::verify`, `blob::Spec`, `blob::write` and so on.

mod calibrate;
mod compiled;
#[cfg(feature = "std")]
mod encode;
mod header;
mod integer;
mod limits;
mod params;
mod quantise;
mod read;
mod write;

pub use crate::format::{
    Encoding, Header, LayerLayout, ModelKind, Params, Shape, Spec, CRC_LEN, LABEL_CAPACITY, MAGIC,
    MAX_BLOB_LEN, MAX_HEADER_LEN, MAX_PAYLOAD_LEN, VERSION, VERSIONS_READ, VERSION_INTEGER,
    VERSION_QUANTISED,
};
pub use crate::integer_layout::{
    has_table, layers as integer_layers, IntegerInput, IntegerLayer, TABLE_LEN,
};
#[cfg(feature = "std")]
pub use calibrate::calibrate;
pub use calibrate::calibrate_into;
pub(crate) use compiled::blob_methods;
#[cfg(feature = "std")]
pub use compiled::to_vec;
pub use compiled::{blob_len, load_into, write_into, Compiled};
#[cfg(feature = "std")]
pub use encode::{encode, encode_integer};
pub use integer::{
    real_multiplier, tanh_entry, write_integer, Quantisation, MAX_BIAS, MIN_MULTIPLIER, MIN_SHIFT,
    TANH_RANGE,
};
pub use limits::{MAX_ACTIONS, MAX_CHOICES, MAX_DEPTH, MAX_OBSERVATIONS, MAX_WIDTH};
pub use params::{check_parameters, values};
pub use read::{payload_values, verify, Verified};
#[cfg(feature = "std")]
pub use write::to_vec_with;
pub use write::{encoded_len, write};
