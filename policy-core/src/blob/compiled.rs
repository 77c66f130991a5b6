//! The compiled (const-generic) types' side of the format: the [`Compiled`] trait that
//! [`Policy`](crate::Policy) and [`Critic`](crate::Critic) implement, and the one load and write
//! path both use (their `load_into`, `from_blob`, `write_blob` and `to_blob` methods are
//! written once, by [`blob_methods!`]).

use super::params::{check_parameters, values};
use super::read::{verify, Verified};
use super::write::{encoded_len, write};
use crate::error::Error;
use crate::format::{Encoding, ModelKind, Shape, Spec};
use crate::mlp::activation::Activation;

/// A model whose shape is fixed at compile time ([`Policy`](crate::Policy),
/// [`Critic`](crate::Critic)): its kind, its shape, and its parameters in blob order. The runtime
/// [`Model`](crate::model::Model) needs none of this; compiled types remain for code that wants
/// the sizes in its types.
pub trait Compiled {
    /// Actor or critic.
    const KIND: ModelKind;
    /// The shape fixed by the const generics.
    const SHAPE: Shape;
    /// The hidden activation.
    fn activation(&self) -> Activation;
    /// Sets the hidden activation (from a blob header).
    fn set_activation(&mut self, activation: Activation);
    /// Visits every parameter slice in blob order.
    fn params<'a>(&'a self, f: &mut dyn FnMut(&'a [f32]));
    /// Visits every parameter slice mutably, in blob order.
    fn params_mut(&mut self, f: &mut dyn FnMut(&mut [f32]));
}

/// Loads a verified blob into `slot`; `slot` is untouched unless the whole load succeeds.
///
/// The generic form of [`Policy::load_into`](crate::Policy::load_into) and
/// [`Critic::load_into`](crate::Critic::load_into). The checks are the runtime model's
/// ([`verify`], then [`check_parameters`]), so both accept exactly the same blobs.
///
/// ```
/// use policy_core::{blob, Policy};
/// static BLOB: &[u8] = include_bytes!("../../tests/golden/actor_2x32.postcard");
/// let mut slot = Policy::<2, 32, 1, 2>::ZERO;
/// blob::load_into(&mut slot, BLOB).unwrap();
/// assert_eq!(slot.normalizer.clip, 5.0);
/// ```
pub fn load_into<M: Compiled>(slot: &mut M, bytes: &[u8]) -> Result<(), Error> {
    let Verified { header, payload } = verify(bytes)?;
    check_parameters(&header, payload)?;
    if header.encoding != Encoding::F32 {
        return Err(Error::WrongEncoding {
            expected: Encoding::F32,
            found: header.encoding,
        });
    }
    if header.kind != M::KIND {
        return Err(Error::WrongKind {
            expected: M::KIND,
            found: header.kind,
        });
    }
    if header.shape != M::SHAPE {
        return Err(Error::ShapeMismatch {
            expected: M::SHAPE,
            found: header.shape,
        });
    }
    check_param_count(slot)?;
    let mut values = values(&header, payload);
    slot.params_mut(&mut |dst| {
        for (d, v) in dst.iter_mut().zip(&mut values) {
            *d = v;
        }
    });
    slot.set_activation(header.activation);
    Ok(())
}

/// Guards against a [`Compiled`] implementation whose `params` disagree with its `SHAPE` (a bug
/// in that implementation, never in a blob): loading or writing it would misplace values.
fn check_param_count<M: Compiled>(model: &M) -> Result<(), Error> {
    let mut count = 0usize;
    model.params(&mut |p| count = count.saturating_add(p.len()));
    if Some(count) != M::SHAPE.param_count(M::KIND) {
        return Err(Error::Malformed {
            what: "model parameters do not match its declared shape",
        });
    }
    Ok(())
}

fn spec_of<'a, M: Compiled>(model: &M, label: &'a str) -> Spec<'a> {
    Spec {
        kind: M::KIND,
        encoding: Encoding::F32,
        shape: M::SHAPE,
        activation: model.activation(),
        label,
    }
}

/// Bytes a blob of this compiled model with this label occupies.
///
/// ```
/// use policy_core::{blob, Policy};
/// let policy = Policy::<2, 48, 3, 2>::ZERO;
/// let n = blob::blob_len(&policy, "nav").unwrap();
/// assert_eq!(n, 20 + 4 * 7307 + 4); // 20-byte header (3-byte label), 7307 parameters, CRC
/// ```
pub fn blob_len<M: Compiled>(model: &M, label: &str) -> Result<usize, Error> {
    encoded_len(&spec_of(model, label))
}

/// Writes a compiled `model` as a blob into `out`; returns the number of bytes written.
///
/// Only `out[..n]` is written. A label longer than [`LABEL_CAPACITY`](super::LABEL_CAPACITY) bytes is an error, as is
/// a buffer shorter than [`blob_len`].
///
/// ```
/// use policy_core::{blob, Error, Policy};
/// let policy = Policy::<1, 2, 0, 1>::ZERO;
/// let mut out = [0u8; 16];
/// assert!(matches!(blob::write_into(&policy, "x", &mut out), Err(Error::BufferTooSmall { .. })));
/// let mut out = [0u8; 128];
/// let n = blob::write_into(&policy, "x", &mut out).unwrap();
/// assert_eq!(n, 68); // 16-byte header (15 + 1 padding), 12 parameters, CRC
/// ```
pub fn write_into<M: Compiled>(model: &M, label: &str, out: &mut [u8]) -> Result<usize, Error> {
    check_param_count(model)?;
    write(
        &spec_of(model, label),
        &mut |sink| model.params(&mut |p| sink(p)),
        out,
    )
}

/// Writes a compiled `model` as a blob into a new vector (host side).
///
/// ```
/// use policy_core::{blob, Policy};
/// let bytes = blob::to_vec(&Policy::<1, 2, 0, 1>::ZERO, "x").unwrap();
/// assert_eq!(bytes.len(), 68);
/// ```
#[cfg(feature = "std")]
pub fn to_vec<M: Compiled>(model: &M, label: &str) -> Result<std::vec::Vec<u8>, Error> {
    let mut out = std::vec![0u8; blob_len(model, label)?];
    let n = write_into(model, label, &mut out)?;
    out.truncate(n);
    Ok(out)
}

/// The blob methods of a compiled type, `load_into`, `from_blob`, `write_blob` and `to_blob`:
/// one definition for [`Policy`](crate::Policy) and [`Critic`](crate::Critic), forwarding to
/// [`load_into`], [`write_into`] and [`to_vec`]. `$golden` names a committed blob of the type
/// with sizes `<2, 32, 1, 2>` and `$label` its label, for the examples.
macro_rules! blob_methods {
    ($name:ident, $golden:literal, $label:literal) => {
        impl<const S: usize, const H: usize, const L: usize, const A: usize> $name<S, H, L, A> {
            #[doc = concat!("Loads a blob into this slot. On error the slot is left exactly as it was.

```
use policy_core::{Error, ", stringify!($name), "};
static BLOB: &[u8] = include_bytes!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/tests/golden/", $golden, "\"));
let mut slot = ", stringify!($name), "::<2, 32, 1, 2>::ZERO;
slot.load_into(BLOB).unwrap();
let mut wrong = ", stringify!($name), "::<2, 48, 3, 2>::ZERO;
assert!(matches!(wrong.load_into(BLOB), Err(Error::ShapeMismatch { .. })));
assert_eq!(wrong, ", stringify!($name), "::ZERO);
```")]
            pub fn load_into(&mut self, bytes: &[u8]) -> Result<(), $crate::error::Error> {
                $crate::blob::load_into(self, bytes)
            }

            #[doc = concat!("Loads a blob into a new value (convenient on the host; on a chip prefer
[`", stringify!($name), "::load_into`] into a `static`).

```
use policy_core::{Error, ", stringify!($name), "};
static BLOB: &[u8] = include_bytes!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/tests/golden/", $golden, "\"));
assert!(", stringify!($name), "::<2, 32, 1, 2>::from_blob(BLOB).is_ok());
let truncated = ", stringify!($name), "::<2, 32, 1, 2>::from_blob(&BLOB[..100]);
assert!(matches!(truncated, Err(Error::Truncated { found: 100, .. })));
```")]
            pub fn from_blob(bytes: &[u8]) -> Result<Self, $crate::error::Error> {
                let mut slot = Self::ZERO;
                slot.load_into(bytes)?;
                Ok(slot)
            }

            #[doc = concat!("Writes this value as a blob into `out`; returns the bytes written. The label (at
most 32 bytes) is free text stored in the header, e.g. task, algorithm and seed.

```
use policy_core::", stringify!($name), ";
static BLOB: &[u8] = include_bytes!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/tests/golden/", $golden, "\"));
let value = ", stringify!($name), "::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
let mut out = [0u8; 8192];
let n = value.write_blob(\"", $label, "\", &mut out).unwrap();
assert_eq!(&out[..n], BLOB);
```")]
            pub fn write_blob(&self, label: &str, out: &mut [u8]) -> Result<usize, $crate::error::Error> {
                $crate::blob::write_into(self, label, out)
            }

            #[doc = concat!("Writes this value as a blob into a new vector (host side).

```
use policy_core::", stringify!($name), ";
static BLOB: &[u8] = include_bytes!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/tests/golden/", $golden, "\"));
let value = ", stringify!($name), "::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
assert_eq!(value.to_blob(\"", $label, "\").unwrap(), BLOB);
```")]
            #[cfg(feature = "std")]
            pub fn to_blob(&self, label: &str) -> Result<std::vec::Vec<u8>, $crate::error::Error> {
                $crate::blob::to_vec(self, label)
            }
        }
    };
}
pub(crate) use blob_methods;
