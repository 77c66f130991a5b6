//! Checks `policy_core::tanh::tanhf` against `libm::tanhf` on all 2³² inputs, bit for bit.
//!
//! `cargo run --release -p policy-core --example tanh_exhaustive` (about a minute on two cores).
//! Exits non-zero and prints the first differences if any input disagrees.

use std::process::ExitCode;

fn mismatches(range: std::ops::Range<u64>) -> Vec<u32> {
    let mut found = Vec::new();
    for bits in range {
        let x = f32::from_bits(bits as u32);
        if policy_core::tanh::tanhf(x).to_bits() != libm::tanhf(x).to_bits() {
            found.push(bits as u32);
        }
    }
    found
}

fn main() -> ExitCode {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()) as u64;
    let chunk = (1u64 << 32) / threads;
    let found: Vec<u32> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|i| {
                let end = if i + 1 == threads {
                    1 << 32
                } else {
                    (i + 1) * chunk
                };
                s.spawn(move || mismatches(i * chunk..end))
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    if found.is_empty() {
        println!("tanh_exhaustive: all 4294967296 inputs bit-identical to libm::tanhf");
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "tanh_exhaustive: {} inputs differ, first: {:08x?}",
            found.len(),
            &found[..found.len().min(10)]
        );
        ExitCode::FAILURE
    }
}
