//! CRC-32 (ISO-HDLC, the zlib/PNG/Ethernet polynomial), table-driven.
//!
//! Written here rather than pulled in so policy-core keeps the dependency list the firmware
//! audits. The table is 1 KiB of flash, a byte a step; with the feature `small-crc` it is 64 B,
//! half a byte a step: the same CRC for 960 B less flash and about twice the instructions per
//! byte at boot, for a part whose firmware must fit a few KiB (firmware-m0).

const POLY: u32 = 0xEDB8_8320;

/// The CRC register after shifting `n` through `bits` steps of the reflected polynomial.
const fn steps(n: u32, bits: u32) -> u32 {
    let mut c = n;
    let mut k = 0;
    while k < bits {
        c = if c & 1 != 0 { POLY ^ (c >> 1) } else { c >> 1 };
        k += 1;
    }
    c
}

/// A step per byte: 256 entries.
const TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut n = 0;
    while n < 256 {
        table[n] = steps(n as u32, 8);
        n += 1;
    }
    table
};

/// A step per half byte: 16 entries.
const NIBBLES: [u32; 16] = {
    let mut table = [0u32; 16];
    let mut n = 0;
    while n < 16 {
        table[n] = steps(n as u32, 4);
        n += 1;
    }
    table
};

/// CRC-32/ISO-HDLC of `bytes` (init `0xFFFF_FFFF`, reflected, final XOR `0xFFFF_FFFF`).
///
/// ```
/// assert_eq!(policy_core::crc32(b"123456789"), 0xCBF4_3926);
/// assert_eq!(policy_core::crc32(b""), 0);
/// ```
pub fn crc32(bytes: &[u8]) -> u32 {
    // The table the build does not use is a `const` no code reads: it takes no flash.
    if cfg!(feature = "small-crc") {
        by_nibbles(bytes)
    } else {
        by_bytes(bytes)
    }
}

fn by_bytes(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc = TABLE[((crc ^ b as u32) & 0xFF) as usize] ^ (crc >> 8);
    }
    !crc
}

fn by_nibbles(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        crc = NIBBLES[(crc & 0xF) as usize] ^ (crc >> 4);
        crc = NIBBLES[(crc & 0xF) as usize] ^ (crc >> 4);
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn both_tables_give_the_check_value() {
        assert_eq!(by_bytes(b"123456789"), 0xCBF4_3926);
        assert_eq!(by_nibbles(b"123456789"), 0xCBF4_3926);
        assert_eq!(by_nibbles(b""), 0);
    }

    proptest! {
        #[test]
        fn the_half_byte_table_gives_the_same_crc(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
            prop_assert_eq!(by_nibbles(&bytes), by_bytes(&bytes));
        }
    }
}
