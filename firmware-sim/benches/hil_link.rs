//! The hardware-in-the-loop link's own cost, without an emulator: whole test episodes (200
//! ticks) of the firmware loop through `HilChip` over a Unix socket pair to an in-process fake
//! chip that runs the same blob with policy-core (frames encoded, sent, decoded both ways, a
//! thread wake-up each way), against the same episodes with the blob in-process.
//!
//! - `hil_link/socket-pair`: through the link; `hil_link/in-process`: the host loop.
//!
//! Their difference per tick is what the link costs; `run --hil qemu-m4f`'s time per tick less
//! both is QEMU's share (docs/firmware-sim.md, "Hardware in the loop").
//! `cargo bench -p firmware-sim --bench hil_link`.

use std::os::unix::net::UnixStream;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use firmware_sim::controller::{BlobPolicy, Controller};
use firmware_sim::hil::chip::ChipOptions;
use firmware_sim::hil::HilChip;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};
use hil_protocol::{
    decode, encode, Calibration, FromChip, Hello, Receiver, SlotState, ToChip, Values, MAX_FRAME,
};

const BLOB: &[u8] = include_bytes!("../../models/nav-walls__dcp-paper__0.postcard");

/// Answers every observation with the blob's action, as the HIL firmware does.
fn fake_chip(mut link: UnixStream) {
    use std::io::{Read, Write};
    let mut policy = BlobPolicy::boot(BLOB).expect("boots");
    let mut buf = [0u8; MAX_FRAME];
    let hello = FromChip::Hello(Hello {
        running: None,
        a: SlotState::Running { sequence: 1 },
        b: SlotState::Standby { sequence: 0 },
        calibration: Calibration {
            instructions: 1,
            ticks: 1,
        },
    });
    if link
        .write_all(encode(&hello, &mut buf).expect("fits"))
        .is_err()
    {
        return;
    }
    let mut rx = Receiver::new();
    let mut bytes = [0u8; 256];
    while let Ok(n @ 1..) = link.read(&mut bytes) {
        for &b in &bytes[..n] {
            let Some(Ok(frame)) = rx.push(b) else {
                continue;
            };
            let Ok(ToChip::Observe { tick, observation }) = decode::<ToChip>(frame) else {
                return;
            };
            let mut action = [0.0f32; 2];
            policy.act(&observation, &mut action);
            let answer = FromChip::Action {
                tick,
                action: Values::from_slice(&action).expect("fits"),
                ticks: 1,
            };
            if link
                .write_all(encode(&answer, &mut buf).expect("fits"))
                .is_err()
            {
                return;
            }
        }
    }
}

fn bench(c: &mut Criterion) {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let cfg = EvalConfig {
        episodes: 1,
        ..EvalConfig::default()
    };
    let mut g = c.benchmark_group("hil_link");
    g.throughput(Throughput::Elements(u64::from(s.time_limit)));
    g.measurement_time(Duration::from_secs(5));

    let (host, chip) = UnixStream::pair().expect("socket pair");
    let fake = std::thread::spawn(move || fake_chip(chip));
    let options = ChipOptions {
        link_name: "bench".into(),
        timeout: Duration::from_secs(5),
        ask_hello: false,
        interrupt: None,
        budget: None,
    };
    let name = BlobPolicy::boot(BLOB).expect("boots").name();
    let mut through = HilChip::connect(Box::new(host), None, options, name, 2, 2).expect("hello");
    g.bench_function("socket-pair", |b| {
        b.iter(|| evaluate_controller(&mut through, &s, &cfg).expect("runs"))
    });
    drop(through);
    fake.join().expect("the fake chip ends with the link");

    let mut local = BlobPolicy::boot(BLOB).expect("boots");
    g.bench_function("in-process", |b| {
        b.iter(|| evaluate_controller(&mut local, &s, &cfg).expect("runs"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
