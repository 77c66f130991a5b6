//! Two flash slots for policy blobs (A and B), and the one rule that decides which of them runs.
//!
//! A product flashes its firmware once and new policies after it, into a region of flash of
//! their own. A power cut or a bad transfer while a policy is written must never leave the device
//! without a working one, so the region has two slots: a new policy goes into the slot that is
//! *not* running, with a sequence number one higher, and the old one stays as the fallback.
//!
//! Each slot holds a **slot record**: a 16-byte header, then the blob (`docs/blob-format.md`,
//! "Flash slots"):
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 4 | magic `DCPS` |
//! | 4 | 4 | sequence number, `u32` little-endian |
//! | 8 | 4 | blob length in bytes, `u32` little-endian |
//! | 12 | 4 | CRC-32 of bytes 0..12 (the header's own check) |
//! | 16 | length | the blob, which carries its own CRC-32 |
//!
//! The header has its own checksum so that a damaged sequence number cannot make a stale slot
//! look newer; the blob's checksum catches a transfer cut short. A slot starting at a 4-byte
//! boundary keeps the blob's payload 4-aligned (16 is a multiple of 4), so the weights are read
//! as `f32` words straight from flash.
//!
//! **The rule** ([`choose`]): read both headers; try the newer slot first (sequence numbers
//! compare in serial-number order, RFC 1982, so `0` is newer than `0xFFFF_FFFF` after a wrap; a
//! tie, or two numbers exactly 2³¹ apart, tries A first); run it if the caller's verification
//! accepts its blob, else try the other; if neither passes, run nothing (the caller's safe state)
//! and report both reasons. The older slot is not verified when the newer one runs, so boot
//! costs one verification in the usual case.
//!
//! ```
//! use policy_core::model::Model;
//! use policy_core::slot::{self, SlotId, Status};
//! static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
//! let record = |seq| [&slot::header(seq, BLOB.len()).unwrap()[..], BLOB].concat();
//! let (a, mut b) = (record(1), record(2));
//! b[100] ^= 1; // a bad transfer into the newer slot
//! let boot = slot::choose(&a, &b, |blob| Model::for_policy(blob, 2, 2, 64));
//! assert_eq!(boot.running.as_ref().map(|(id, _)| *id), Some(SlotId::A));
//! assert_eq!(boot.a, Status::Running { sequence: 1 });
//! assert!(matches!(boot.b, Status::Failed(policy_core::Error::ChecksumMismatch { .. })));
//! ```

use core::fmt;

use crate::crc32::crc32;
use crate::error::Error;

/// The first four bytes of a slot record.
pub const MAGIC: [u8; 4] = *b"DCPS";

/// Bytes of a slot record's header; the blob starts here.
pub const HEADER_LEN: usize = 16;

/// The example firmware's slot A address (`firmware/mps2/memory.x`, QEMU's mps2-an386 layout).
pub const EXAMPLE_SLOT_A: u32 = 0x0004_0000;
/// The example firmware's slot B address (`firmware/mps2/memory.x`).
pub const EXAMPLE_SLOT_B: u32 = 0x0006_0000;
/// The example firmware's slot size in bytes (`firmware/mps2/memory.x`): 128 KiB each, one erase
/// sector on parts like the STM32F4's upper flash.
pub const EXAMPLE_SLOT_SIZE: usize = 128 * 1024;

/// One of the two slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotId {
    /// Slot A (the lower address; the tie-breaker).
    A,
    /// Slot B.
    B,
}

impl fmt::Display for SlotId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SlotId::A => "A",
            SlotId::B => "B",
        })
    }
}

/// A slot record whose header checked out; its blob is not verified yet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record<'a> {
    /// The sequence number the flasher gave it.
    pub sequence: u32,
    /// The blob bytes, exactly as long as the header says.
    pub blob: &'a [u8],
}

/// Reads a slot's header: magic, header checksum and length. `slot` is the whole slot (it may
/// be longer than the record; the rest is ignored).
///
/// ```
/// use policy_core::{slot, Error};
/// let record = [&slot::header(7, 9).unwrap()[..], b"any bytes"].concat();
/// let read = slot::read(&record).unwrap();
/// assert_eq!((read.sequence, read.blob), (7, &b"any bytes"[..]));
/// assert_eq!(slot::read(&[0xFF; 64]), Err(Error::SlotEmpty));
/// ```
pub fn read(slot: &[u8]) -> Result<Record<'_>, Error> {
    if slot.is_empty() {
        return Err(Error::SlotEmpty); // no region at all (a host tool's absent slot)
    }
    let header: &[u8; HEADER_LEN] = slot
        .get(..HEADER_LEN)
        .and_then(|h| h.try_into().ok())
        .ok_or(Error::SlotOverflow {
            needed: HEADER_LEN,
            capacity: slot.len(),
        })?;
    // Erased NOR flash reads 0xFF; an emulator's (or a zero-filled) region reads 0x00.
    if header.iter().all(|&b| b == 0xFF) || header.iter().all(|&b| b == 0) {
        return Err(Error::SlotEmpty);
    }
    let word =
        |i: usize| u32::from_le_bytes([header[i], header[i + 1], header[i + 2], header[i + 3]]);
    let magic = [header[0], header[1], header[2], header[3]];
    if magic != MAGIC {
        return Err(Error::SlotMagic { found: magic });
    }
    let (stored, computed) = (word(12), crc32(&header[..12]));
    if stored != computed {
        return Err(Error::SlotHeaderChecksum { stored, computed });
    }
    let length = word(8) as usize;
    let blob = slot
        .get(HEADER_LEN..)
        .and_then(|rest| rest.get(..length))
        .ok_or(Error::SlotOverflow {
            needed: HEADER_LEN.saturating_add(length),
            capacity: slot.len(),
        })?;
    Ok(Record {
        sequence: word(4),
        blob,
    })
}

/// Whether sequence number `a` is newer than `b` in serial-number order (RFC 1982): `a` is
/// ahead of `b` by 1 to 2³¹ − 1 steps, counting around the wrap.
///
/// ```
/// use policy_core::slot::is_newer;
/// assert!(is_newer(2, 1));
/// assert!(is_newer(0, u32::MAX)); // wrapped around
/// assert!(!is_newer(1, 1));
/// assert!(!is_newer(1 << 31, 0)); // exactly half the circle apart: neither is newer
/// assert!(!is_newer(0, 1 << 31));
/// ```
pub fn is_newer(a: u32, b: u32) -> bool {
    let ahead = a.wrapping_sub(b);
    ahead != 0 && ahead < 1 << 31
}

/// What became of one slot at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Its blob passed verification and runs.
    Running {
        /// Its sequence number.
        sequence: u32,
    },
    /// Its header is intact but the other slot is newer and runs; its blob was not verified.
    Standby {
        /// Its sequence number.
        sequence: u32,
    },
    /// It cannot run: the reason.
    Failed(Error),
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Status::Running { sequence } => write!(f, "running (sequence {sequence})"),
            Status::Standby { sequence } => {
                write!(f, "standby (sequence {sequence}, older; not verified)")
            }
            Status::Failed(e) => write!(f, "failed: {e}"),
        }
    }
}

/// The outcome of [`choose`]: the slot that runs with what the verification returned (`None`:
/// run the safe state), and what became of each slot.
#[derive(Debug)]
pub struct Boot<T> {
    /// The running slot and the caller's verified value (a [`Model`](crate::model::Model)).
    pub running: Option<(SlotId, T)>,
    /// Slot A's status.
    pub a: Status,
    /// Slot B's status.
    pub b: Status,
}

/// Picks the slot to run: the newer slot whose blob `verify` accepts, else the older one, else
/// none. `verify` is the firmware's own check (for the example firmware,
/// [`Model::for_policy`](crate::model::Model::for_policy) with its sizes and scratch width); it
/// runs at most twice. Never panics, whatever the slots hold.
///
/// ```
/// use policy_core::slot::{self, SlotId, Status};
/// let newer = [&slot::header(5, 3).unwrap()[..], b"new"].concat();
/// let older = [&slot::header(4, 3).unwrap()[..], b"old"].concat();
/// // A verification that accepts only the old bytes: B is tried first, fails, A runs.
/// let boot = slot::choose(&older, &newer, |blob| {
///     if blob == b"old" { Ok(blob.len()) } else { Err(policy_core::Error::SlotEmpty) }
/// });
/// assert_eq!(boot.running, Some((SlotId::A, 3)));
/// assert_eq!(boot.a, Status::Running { sequence: 4 });
/// assert_eq!(boot.b, Status::Failed(policy_core::Error::SlotEmpty));
/// ```
pub fn choose<'a, T>(
    a: &'a [u8],
    b: &'a [u8],
    mut verify: impl FnMut(&'a [u8]) -> Result<T, Error>,
) -> Boot<T> {
    let (ra, rb) = (read(a), read(b));
    let b_first = match (&ra, &rb) {
        (Ok(ra), Ok(rb)) => is_newer(rb.sequence, ra.sequence),
        (Err(_), Ok(_)) => true,
        _ => false,
    };
    let order = if b_first {
        [(SlotId::B, rb), (SlotId::A, ra)]
    } else {
        [(SlotId::A, ra), (SlotId::B, rb)]
    };
    let mut running = None;
    let mut statuses = [Status::Failed(Error::SlotEmpty); 2];
    for (status, (id, record)) in statuses.iter_mut().zip(order) {
        *status = match record {
            Err(e) => Status::Failed(e),
            Ok(r) if running.is_some() => Status::Standby {
                sequence: r.sequence,
            },
            Ok(r) => match verify(r.blob) {
                Ok(value) => {
                    running = Some((id, value));
                    Status::Running {
                        sequence: r.sequence,
                    }
                }
                Err(e) => Status::Failed(e),
            },
        };
    }
    let [first, second] = statuses;
    let (a, b) = if b_first {
        (second, first)
    } else {
        (first, second)
    };
    Boot { running, a, b }
}

/// The 16-byte header of a slot record for a blob of `blob_len` bytes with sequence number
/// `sequence` (magic, sequence, length, header CRC-32). A flasher writes it and then the blob.
///
/// ```
/// use policy_core::slot;
/// let h = slot::header(3, 4).unwrap();
/// assert_eq!(&h[..4], b"DCPS");
/// assert_eq!(&h[4..12], &[3, 0, 0, 0, 4, 0, 0, 0]);
/// assert_eq!(h[12..], policy_core::crc32(&h[..12]).to_le_bytes());
/// ```
pub fn header(sequence: u32, blob_len: usize) -> Result<[u8; HEADER_LEN], Error> {
    let length = u32::try_from(blob_len).map_err(|_| Error::SlotOverflow {
        needed: HEADER_LEN.saturating_add(blob_len),
        capacity: (u32::MAX as usize).saturating_add(HEADER_LEN),
    })?;
    let mut h = [0u8; HEADER_LEN];
    h[..4].copy_from_slice(&MAGIC);
    h[4..8].copy_from_slice(&sequence.to_le_bytes());
    h[8..12].copy_from_slice(&length.to_le_bytes());
    let crc = crc32(&h[..12]);
    h[12..].copy_from_slice(&crc.to_le_bytes());
    Ok(h)
}

/// The whole slot record for `blob` with sequence number `sequence`: what a flasher writes at a
/// slot's address. Refused if the record would not fit a slot of `capacity` bytes.
///
/// ```
/// use policy_core::slot;
/// let record = slot::record(b"blob", 3, 1024).unwrap();
/// assert_eq!(record[..16], slot::header(3, 4).unwrap());
/// assert_eq!(&record[16..], b"blob");
/// assert!(slot::record(&[0; 1009], 3, 1024).is_err()); // 16 + 1009 > 1024
/// ```
#[cfg(feature = "std")]
pub fn record(blob: &[u8], sequence: u32, capacity: usize) -> Result<Vec<u8>, Error> {
    let needed = HEADER_LEN.saturating_add(blob.len());
    if needed > capacity {
        return Err(Error::SlotOverflow { needed, capacity });
    }
    let mut out = Vec::with_capacity(needed);
    out.extend_from_slice(&header(sequence, blob.len())?);
    out.extend_from_slice(blob);
    Ok(out)
}

/// `bytes` as Intel HEX placed at `address`: 16-byte data records, an extended linear address
/// record (type 04) wherever the upper 16 address bits change, and the end-of-file record. What
/// `probe-rs download --binary-format hex`, OpenOCD, STM32CubeProgrammer and QEMU's
/// `-device loader` take. Refused if the bytes would run past the 4 GiB address space.
///
/// ```
/// let hex = policy_core::slot::intel_hex(&[0xDE, 0xAD], 0x0804_0000).unwrap();
/// assert_eq!(hex, ":020000040804EE\n:02000000DEAD73\n:00000001FF\n");
/// ```
#[cfg(feature = "std")]
pub fn intel_hex(bytes: &[u8], address: u32) -> Result<String, Error> {
    use core::fmt::Write;
    let space = (1usize << 32) - address as usize;
    if bytes.len() > space {
        return Err(Error::SlotOverflow {
            needed: bytes.len(),
            capacity: space,
        });
    }
    let mut out = String::new();
    let mut line = |kind: u8, offset: u16, data: &[u8]| {
        let mut sum = (data.len() as u8)
            .wrapping_add((offset >> 8) as u8)
            .wrapping_add(offset as u8)
            .wrapping_add(kind);
        let _ = write!(out, ":{:02X}{offset:04X}{kind:02X}", data.len());
        for &b in data {
            sum = sum.wrapping_add(b);
            let _ = write!(out, "{b:02X}");
        }
        let _ = writeln!(out, "{:02X}", sum.wrapping_neg());
    };
    let mut upper = None;
    let mut at = 0usize;
    while at < bytes.len() {
        let addr = address as usize + at;
        if upper != Some(addr >> 16) {
            upper = Some(addr >> 16);
            line(0x04, 0, &((addr >> 16) as u16).to_be_bytes());
        }
        // A record never crosses a 64 KiB boundary (its offset is 16 bits).
        let room = 0x1_0000 - (addr & 0xFFFF);
        let n = 16.min(room).min(bytes.len() - at);
        line(0x00, addr as u16, &bytes[at..at + n]);
        at += n;
    }
    line(0x01, 0, &[]);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A verification that accepts any blob whose first byte is `b'G'` ("good").
    fn good(blob: &[u8]) -> Result<u8, Error> {
        match blob.first() {
            Some(b'G') => Ok(blob.len() as u8),
            _ => Err(Error::Malformed { what: "not good" }),
        }
    }

    /// A slot record (header + blob) without the std-only writer; `_capacity` as in [`record`].
    fn rec(blob: &[u8], sequence: u32, _capacity: usize) -> Result<Vec<u8>, Error> {
        Ok([&header(sequence, blob.len())?[..], blob].concat())
    }

    fn running_id<T>(boot: &Boot<T>) -> Option<SlotId> {
        boot.running.as_ref().map(|(id, _)| *id)
    }

    #[test]
    fn the_newer_good_slot_runs_and_the_older_stands_by() {
        let a = rec(b"Gold", 1, 64).expect("test value");
        let b = rec(b"Gnew!", 2, 64).expect("test value");
        let boot = choose(&a, &b, good);
        assert_eq!(boot.running, Some((SlotId::B, 5)));
        assert_eq!(boot.a, Status::Standby { sequence: 1 });
        assert_eq!(boot.b, Status::Running { sequence: 2 });
        // The same with the roles swapped.
        let boot = choose(&b, &a, good);
        assert_eq!(running_id(&boot), Some(SlotId::A));
    }

    #[test]
    fn a_bad_newer_slot_falls_back_to_the_older() {
        let a = rec(b"Gold", 1, 64).expect("test value");
        let b = rec(b"bad", 2, 64).expect("test value");
        let boot = choose(&a, &b, good);
        assert_eq!(running_id(&boot), Some(SlotId::A));
        assert_eq!(boot.a, Status::Running { sequence: 1 });
        assert!(matches!(boot.b, Status::Failed(Error::Malformed { .. })));
    }

    #[test]
    fn both_bad_or_empty_runs_nothing_and_says_why() {
        let bad = rec(b"bad", 2, 64).expect("test value");
        let boot = choose(&[0xFF; 64], &bad, good);
        assert!(boot.running.is_none());
        assert_eq!(boot.a, Status::Failed(Error::SlotEmpty));
        assert!(matches!(boot.b, Status::Failed(Error::Malformed { .. })));
        let boot = choose(&[0; 64], &[], good);
        assert_eq!(boot.a, Status::Failed(Error::SlotEmpty));
        assert_eq!(boot.b, Status::Failed(Error::SlotEmpty));
        let boot = choose(&[0x44; 15], &[0; 64], good);
        assert_eq!(
            boot.a,
            Status::Failed(Error::SlotOverflow {
                needed: 16,
                capacity: 15
            })
        );
    }

    #[test]
    fn verification_runs_only_on_the_slot_that_runs_when_it_passes() {
        let a = rec(b"Gold", 1, 64).expect("test value");
        let b = rec(b"Gnew", 2, 64).expect("test value");
        let mut calls = 0;
        let boot = choose(&a, &b, |blob| {
            calls += 1;
            good(blob)
        });
        assert_eq!(running_id(&boot), Some(SlotId::B));
        assert_eq!(calls, 1);
    }

    #[test]
    fn sequence_numbers_wrap_around() {
        let a = rec(b"Gold", u32::MAX, 64).expect("test value");
        let b = rec(b"Gnew", 0, 64).expect("test value");
        assert_eq!(running_id(&choose(&a, &b, good)), Some(SlotId::B));
        // Ties and the undefined half-circle distance try A first.
        for (sa, sb) in [(5, 5), (0, 1 << 31), (1 << 31, 0)] {
            let a = rec(b"GA", sa, 64).expect("test value");
            let b = rec(b"GB", sb, 64).expect("test value");
            assert_eq!(
                running_id(&choose(&a, &b, good)),
                Some(SlotId::A),
                "{sa} {sb}"
            );
        }
    }

    #[test]
    fn a_damaged_header_is_refused_before_the_blob_is_looked_at() {
        let good_record = rec(b"Gold", 1, 64).expect("test value");
        for i in 0..HEADER_LEN {
            for bit in 0..8 {
                let mut r = good_record.clone();
                r[i] ^= 1 << bit;
                let e = read(&r).expect_err("must fail");
                assert!(
                    matches!(
                        e,
                        Error::SlotMagic { .. } | Error::SlotHeaderChecksum { .. }
                    ),
                    "byte {i} bit {bit}: {e:?}"
                );
            }
        }
    }

    #[test]
    fn a_length_beyond_the_slot_is_refused() {
        let r = rec(b"Gold", 1, 64).expect("test value");
        // The slot ends before the blob does (a truncated region).
        assert_eq!(
            read(&r[..r.len() - 1]),
            Err(Error::SlotOverflow {
                needed: 20,
                capacity: 19
            })
        );
        // A header claiming 4 GiB (with a valid header CRC) is refused, not read past.
        let mut h = r[..12].to_vec();
        h[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        let crc = crc32(&h);
        h.extend_from_slice(&crc.to_le_bytes());
        assert!(matches!(read(&h), Err(Error::SlotOverflow { .. })));
    }

    #[cfg(feature = "std")]
    #[test]
    fn intel_hex_records_follow_the_address_across_a_64k_boundary() {
        let bytes: Vec<u8> = (0..40).collect();
        let hex = intel_hex(&bytes, 0x0001_FFF8).expect("test value");
        let lines: Vec<&str> = hex.lines().collect();
        assert_eq!(lines[0], ":020000040001F9");
        assert!(lines[1].starts_with(":08FFF800")); // 8 bytes up to the boundary
        assert_eq!(lines[2], ":020000040002F8");
        assert!(lines[3].starts_with(":10000000")); // then 16, 16
        assert!(lines[4].starts_with(":10001000"));
        assert_eq!(lines.last(), Some(&":00000001FF"));
        // Every record's bytes sum to zero (mod 256).
        for l in &lines {
            let sum = (1..l.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&l[i..i + 2], 16).expect("test value"))
                .fold(0u8, u8::wrapping_add);
            assert_eq!(sum, 0, "{l}");
        }
        assert!(intel_hex(&[0; 2], u32::MAX).is_err());
        assert!(intel_hex(&[0; 1], u32::MAX).is_ok());
    }

    #[cfg(feature = "std")]
    #[test]
    fn the_writer_refuses_a_record_larger_than_the_slot() {
        assert!(record(&[0; 49], 1, 64).is_err());
        assert_eq!(record(&[0; 48], 1, 64).expect("test value").len(), 64);
    }

    #[test]
    fn the_record_layout_is_the_documented_one() {
        let r = rec(b"xy", 0x0102_0304, 64).expect("test value");
        assert_eq!(&r[0..4], b"DCPS");
        assert_eq!(&r[4..8], &[4, 3, 2, 1]);
        assert_eq!(&r[8..12], &[2, 0, 0, 0]);
        assert_eq!(&r[12..16], &crc32(&r[..12]).to_le_bytes());
        assert_eq!(&r[16..], b"xy");
    }
}
