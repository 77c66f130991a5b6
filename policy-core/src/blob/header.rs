//! Decoding a blob's header field by field, in postcard's wire format (docs/blob-format.md,
//! "Encodings used"), with each varint's length checked as it is read.
//!
//! A header is canonical when every varint has its shortest length: postcard decodes a value
//! padded with extra `0x80` groups (`2` written `82 00`), so without the check one model would
//! have many headers and the header's size no bound. An unsigned LEB128 varint of more than one
//! byte is longer than its shortest form exactly when its last byte is zero (that group adds
//! nothing), so the reader notes that as it goes, at no cost beyond a compare per varint; it
//! reports it only once the whole header has decoded, so a header that is both padded and
//! undecodable gets the decoding error, as a decode-then-compare reader would give.

use heapless::String;

use crate::error::Error;
use crate::format::{
    Encoding, Header, ModelKind, Shape, LABEL_CAPACITY, MAGIC, VERSION, VERSION_INTEGER,
    VERSION_QUANTISED,
};
use crate::mlp::activation::Activation;

const ENDS_EARLY: Error = Error::Malformed {
    what: "header ends early (truncated blob)",
};
const UNDECODABLE: Error = Error::Malformed {
    what: "header fields cannot be decoded",
};

/// A header's bytes being read, front to back.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    /// A varint read so far was longer than its shortest form.
    padded: bool,
}

impl Reader<'_> {
    fn byte(&mut self) -> Result<u8, Error> {
        let b = *self.bytes.get(self.at).ok_or(ENDS_EARLY)?;
        self.at += 1;
        Ok(b)
    }

    /// An unsigned LEB128 varint of a `bits`-wide integer, as postcard decodes it: at most
    /// `ceil(bits / 7)` bytes, the last of which may only hold the type's remaining bits.
    fn varint(&mut self, bits: u32) -> Result<u64, Error> {
        let max_len = bits.div_ceil(7);
        let last_max = (1u8 << (bits % 7)).wrapping_sub(1);
        let mut value = 0u64;
        for i in 0..max_len {
            let b = self.byte()?;
            value |= u64::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                if i == max_len - 1 && b > last_max {
                    return Err(UNDECODABLE);
                }
                // A last group of zero adds nothing: the same value fits in fewer bytes.
                self.padded |= i > 0 && b == 0;
                return Ok(value);
            }
        }
        Err(UNDECODABLE)
    }

    fn u16(&mut self) -> Result<u16, Error> {
        // At most 3 bytes with the last at most 3: the value fits.
        self.varint(16).map(|v| v as u16)
    }

    fn u32(&mut self) -> Result<u32, Error> {
        self.varint(32).map(|v| v as u32)
    }

    /// An enum's variant index (a `u32` varint), at most `count - 1`; postcard reports an
    /// index past the last variant as undecodable (a serde error), and so does this reader.
    fn variant(&mut self, count: u32) -> Result<u32, Error> {
        let index = self.u32()?;
        if index < count {
            Ok(index)
        } else {
            Err(UNDECODABLE)
        }
    }

    fn kind(&mut self) -> Result<ModelKind, Error> {
        Ok(match self.variant(3)? {
            0 => ModelKind::Actor,
            1 => ModelKind::Critic,
            _ => ModelKind::Discrete,
        })
    }

    fn encoding(&mut self) -> Result<Encoding, Error> {
        Ok(match self.variant(4)? {
            0 => Encoding::F32,
            1 => Encoding::F16,
            2 => Encoding::Int8,
            _ => Encoding::Integer,
        })
    }

    fn activation(&mut self) -> Result<Activation, Error> {
        Ok(match self.variant(2)? {
            0 => Activation::Tanh,
            _ => Activation::Relu,
        })
    }

    /// A string: its length as a `usize` varint, then that many bytes of UTF-8, at most
    /// [`LABEL_CAPACITY`] of them; checked in postcard's order (bytes present, UTF-8, length).
    fn label(&mut self) -> Result<String<LABEL_CAPACITY>, Error> {
        let len = self.varint(usize::BITS)?;
        let bytes = usize::try_from(len)
            .ok()
            .and_then(|len| self.bytes.get(self.at..self.at.checked_add(len)?))
            .ok_or(ENDS_EARLY)?;
        self.at += bytes.len();
        let text = core::str::from_utf8(bytes).map_err(|_| Error::Malformed {
            what: "label is not UTF-8",
        })?;
        String::try_from(text).map_err(|_| UNDECODABLE)
    }
}

/// Decodes the header at the start of `bytes` (its magic already checked): the header and the
/// length of its encoding. Version 1's header has no encoding (f32) and no `choices` (0); a
/// version this build does not read is refused before the rest is decoded.
pub(super) fn decode(bytes: &[u8]) -> Result<(Header, usize), Error> {
    let mut r = Reader {
        bytes,
        at: MAGIC.len(),
        padded: false,
    };
    let version = r.u16()?;
    if !matches!(version, 1 | VERSION | VERSION_QUANTISED | VERSION_INTEGER) {
        return Err(Error::UnsupportedVersion {
            supported: VERSION_INTEGER,
            found: version,
        });
    }
    let v1 = version == 1;
    let kind = r.kind()?;
    let encoding = if v1 { Encoding::F32 } else { r.encoding()? };
    let observations = r.u16()?;
    let actions = r.u16()?;
    let width = r.u16()?;
    let depth = r.byte()?;
    let choices = if v1 { 0 } else { r.u16()? };
    let activation = r.activation()?;
    let label = r.label()?;
    let payload_len = r.u32()?;
    if r.padded {
        return Err(Error::Malformed {
            what: "header is not in canonical form (a varint longer than its shortest encoding)",
        });
    }
    if v1 && kind == ModelKind::Discrete {
        // Version 1 knew two kinds; the third enum value was invalid then.
        return Err(Error::Malformed {
            what: "unknown kind or activation",
        });
    }
    let header = Header {
        magic: MAGIC,
        version,
        kind,
        encoding,
        shape: Shape {
            observations,
            actions,
            width,
            depth,
            choices,
        },
        activation,
        label,
        payload_len,
    };
    Ok((header, r.at))
}
