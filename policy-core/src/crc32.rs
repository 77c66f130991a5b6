//! CRC-32 (ISO-HDLC, the zlib/PNG/Ethernet polynomial), table-driven, usable in `const` context.
//!
//! Written here rather than pulled in so policy-core keeps the dependency list the firmware
//! audits; the 1 KiB table lives in flash.

const POLY: u32 = 0xEDB8_8320;

const TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut n = 0;
    while n < 256 {
        let mut c = n as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 { POLY ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        table[n] = c;
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
    let mut crc = !0u32;
    for &b in bytes {
        crc = TABLE[((crc ^ b as u32) & 0xFF) as usize] ^ (crc >> 8);
    }
    !crc
}
