//! Hardware in the loop without hardware: the chip controller ([`HilChip`]) against an
//! in-process fake chip on a socket pair that runs policy-core on the host, answers as the HIL
//! firmware does, and misbehaves on purpose. A good chip gives the host loop's report bit for
//! bit; each fault stops the run with its one-line reason after the episodes that completed.
//! (The real firmware under QEMU is checked by scripts/cortex-m.sh.)

use std::os::unix::net::UnixStream;
use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use firmware_sim::controller::BlobPolicy;
use firmware_sim::hil::chip::ChipOptions;
use firmware_sim::hil::HilChip;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig, Report};
use hil_protocol::{
    decode, encode, encode_version, Calibration, Encoding, FromChip, Hello, Receiver, Running,
    Slot, SlotState, ToChip, Values, MAX_FRAME, VERSION,
};

const BLOB: &[u8] = include_bytes!("../../models/nav-walls__dcp-paper__0.postcard");
const BIN: &str = env!("CARGO_BIN_EXE_firmware-sim");

/// What the fake chip does at observation number `at` (counted from 0 over the whole run).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fault {
    None,
    /// Answers nothing from then on.
    Silent,
    /// One byte of the action frame changed.
    Garbled,
    /// The action frame cut in half, then a delimiter (its COBS code bytes then point past it).
    Truncated,
    /// The action in a frame of the next protocol version.
    OtherVersion,
    /// A new hello instead of the action: the board reset.
    Reset,
    /// The link closes.
    Closed,
    /// The action of another tick.
    WrongTick,
}

fn hello() -> Hello {
    Hello {
        running: Some(Running {
            slot: Slot::A,
            sequence: 1,
            blob_crc: u32::from_le_bytes(BLOB[BLOB.len() - 4..].try_into().expect("4 bytes")),
            blob_len: BLOB.len() as u32,
            depth: 4,
            width: 48,
            observations: 2,
            actions: 2,
            encoding: Encoding::F32,
        }),
        a: SlotState::Running { sequence: 1 },
        b: SlotState::Failed {
            reason: "empty slot".try_into().expect("fits"),
        },
        calibration: Calibration {
            instructions: 200_000,
            ticks: 5_000,
        },
    }
}

fn send(link: &mut UnixStream, frame: &[u8]) {
    use std::io::Write;
    // The host may have gone (it stops at the first fault): nothing to do then.
    let _ = link.write_all(frame);
}

/// The fake chip: the HIL firmware's loop with policy-core on the host.
fn fake_chip(mut link: UnixStream, fault: Fault, at: u64) {
    use std::io::Read;
    let mut policy = BlobPolicy::boot(BLOB).expect("boots");
    let mut buf = [0u8; MAX_FRAME];
    send(
        &mut link,
        encode(&FromChip::Hello(hello()), &mut buf).expect("fits"),
    );
    let mut rx = Receiver::new();
    let mut seen = 0u64;
    let mut byte = [0u8; 1];
    while let Ok(1) = link.read(&mut byte) {
        let Some(frame) = rx.push(byte[0]) else {
            continue;
        };
        let Ok(ToChip::Observe { tick, observation }) = frame.and_then(decode::<ToChip>) else {
            panic!("the host sent a bad frame");
        };
        let mut action = [0.0f32; 2];
        firmware_sim::controller::Controller::act(&mut policy, &observation, &mut action);
        let answer = FromChip::Action {
            tick,
            action: Values::from_slice(&action).expect("fits"),
            ticks: 540 + (tick % 3),
        };
        let fault = if seen == at { fault } else { Fault::None };
        seen += 1;
        let frame = encode(&answer, &mut buf).expect("fits").to_vec();
        match fault {
            Fault::None => send(&mut link, &frame),
            Fault::Silent => {
                // Keep the link open, answer nothing.
                while let Ok(n) = link.read(&mut byte) {
                    if n == 0 {
                        return;
                    }
                }
                return;
            }
            Fault::Garbled => {
                let mut bad = frame.clone();
                bad[3] = if bad[3] == 0x55 { 0x56 } else { 0x55 };
                send(&mut link, &bad);
            }
            Fault::Truncated => {
                let mut cut = frame[..frame.len() / 2].to_vec();
                cut.push(0);
                send(&mut link, &cut);
            }
            Fault::OtherVersion => {
                let frame = encode_version(&answer, VERSION + 1, &mut buf).expect("fits");
                send(&mut link, frame);
            }
            Fault::Reset => {
                send(&mut link, &[0]);
                send(
                    &mut link,
                    encode(&FromChip::Hello(hello()), &mut buf).expect("fits"),
                );
            }
            Fault::Closed => return,
            Fault::WrongTick => {
                let wrong = FromChip::Action {
                    tick: tick + 1,
                    action: Values::from_slice(&action).expect("fits"),
                    ticks: 1,
                };
                send(&mut link, encode(&wrong, &mut buf).expect("fits"));
            }
        }
    }
}

fn cfg() -> EvalConfig {
    EvalConfig {
        episodes: 3,
        seed: 4,
        faults: "dropout-nan:0.05,stuck:0@50".parse().expect("faults"),
        record_trajectories: true,
        ..EvalConfig::default()
    }
}

/// Runs the test protocol through a fake chip with `fault` at observation `at`.
fn run_fake(fault: Fault, at: u64, interrupt: bool) -> Report {
    let (host, chip) = UnixStream::pair().expect("socket pair");
    let fake = std::thread::spawn(move || fake_chip(chip, fault, at));
    let flag = Arc::new(AtomicBool::new(false));
    let name = BlobPolicy::boot(BLOB).expect("boots");
    let name = firmware_sim::controller::Controller::name(&name);
    let options = ChipOptions {
        link_name: "fake".into(),
        timeout: Duration::from_millis(300),
        ask_hello: false,
        interrupt: Some(Arc::clone(&flag)),
        budget: Some(541 * 40),
    };
    let mut chip = HilChip::connect(Box::new(host), None, options, name, 2, 2).expect("hello");
    // Ctrl-C after the hello.
    flag.store(interrupt, std::sync::atomic::Ordering::SeqCst);
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let mut report = evaluate_controller(&mut chip, &s, &cfg()).expect("runs");
    report.chip = Some(chip.report());
    drop(chip);
    fake.join().expect("the fake chip ends when the host goes");
    report
}

fn host_report() -> Report {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let mut policy = BlobPolicy::boot(BLOB).expect("boots");
    evaluate_controller(&mut policy, &s, &cfg()).expect("runs")
}

#[test]
fn a_chip_that_answers_gives_the_host_loops_report_bit_for_bit() {
    let hil = run_fake(Fault::None, u64::MAX, false);
    let chip = hil.chip.clone().expect("chip section");
    assert_eq!(chip.ticks, hil.total_steps);
    assert_eq!(chip.slot, "A");
    // 540..=542 ticks x 40 instructions a tick; the budget of 541 is passed by the 542s.
    assert_eq!(chip.instructions_max, 542 * 40);
    assert!(chip.ticks_over_budget > 0 && chip.ticks_over_budget < chip.ticks);
    let hil = Report {
        chip: None,
        ..hil.without_timing()
    };
    // Debug compares f64 NaN-safe and bit-exact enough for equal runs; the records hold the
    // trajectories, which follow every action.
    assert_eq!(
        format!("{:?}", hil),
        format!("{:?}", host_report().without_timing())
    );
}

/// Each fault at observation 250 (episode 1 of 3, 200 ticks each): the run stops with its
/// reason, episode 0 is kept, and the report fails.
#[test]
fn each_fault_stops_the_run_with_its_reason_after_the_episodes_that_completed() {
    let host = host_report();
    let cases = [
        (Fault::Silent, "fake: the chip sent nothing for 0.3 s, waiting for the action of tick 250: it hangs, or the link is down"),
        (Fault::Garbled, "fake: the chip sent a garbled frame (CRC-32 mismatch), waiting for the action of tick 250"),
        (Fault::Truncated, "fake: the chip sent a garbled frame (invalid COBS), waiting for the action of tick 250"),
        (Fault::OtherVersion, "fake: the chip sent a frame of protocol version 2, waiting for the action of tick 250; firmware-sim speaks version 1: flash a HIL firmware of this version"),
        (Fault::Reset, "fake: the chip reset mid-episode (a new hello at tick 250: slot A running (sequence 1); slot B failed: empty slot)"),
        (Fault::Closed, "fake: the link to the chip closed, waiting for the action of tick 250 (the link was closed)"),
        (Fault::WrongTick, "fake: the chip answered tick 250 with tick 251 (2 values for 2)"),
    ];
    for (fault, reason) in cases {
        let r = run_fake(fault, 250, false);
        let stopped = r
            .stopped
            .clone()
            .unwrap_or_else(|| panic!("{fault:?}: not stopped"));
        assert_eq!(stopped.reason, reason, "{fault:?}");
        assert_eq!(stopped.episodes_run, 1, "{fault:?}");
        assert_eq!(r.episodes.len(), 1, "{fault:?}");
        assert_eq!(
            format!("{:?}", r.episodes[0]),
            format!("{:?}", host.episodes[0]),
            "{fault:?}: the completed episode is the host's"
        );
        assert!(!r.pass.passed);
        assert!(r.pass.failures[0].starts_with("stopped after 1 episodes: fake: "));
        assert!(r.summary().contains("1 of 3 tests"), "{}", r.summary());
        assert!(!reason.contains('\n'));
    }
}

#[test]
fn ctrl_c_stops_the_run_before_the_first_tick() {
    let r = run_fake(Fault::None, u64::MAX, true);
    let stopped = r.stopped.expect("stopped");
    assert_eq!(stopped.episodes_run, 0);
    assert_eq!(
        stopped.reason,
        "fake: interrupted (Ctrl-C), waiting for the action of tick 0"
    );
    // Rates over no episode are 0, not NaN.
    assert_eq!(r.success_rate, 0.0);
}

#[test]
fn a_chip_silent_from_the_start_is_refused_at_connect() {
    let (host, _chip) = UnixStream::pair().expect("socket pair");
    let options = ChipOptions {
        link_name: "fake".into(),
        timeout: Duration::from_millis(100),
        ask_hello: false,
        interrupt: None,
        budget: None,
    };
    let e = HilChip::connect(Box::new(host), None, options, "x".into(), 2, 2).expect_err("silent");
    assert_eq!(
        e.to_string(),
        "fake: the chip sent nothing for 0.1 s, waiting for the hello: it hangs, or the link is down"
    );
}

fn cli(args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(BIN)
        .arg("run")
        .args(args)
        .env("CARGO_TARGET_DIR", "/nonexistent-target")
        .output()
        .expect("spawn");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn hil_bad_input_is_one_line_and_exit_2() {
    let blob = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../models/nav-walls__dcp-paper__0.postcard"
    );
    let manifest = concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml");
    let cases: [(&[&str], &str); 5] = [
        (&["--blob", blob, "--hil", "qemu-m7"], "expected qemu-m4f, qemu-m3 or serial:PATH"),
        (
            &["--blob", blob, "--hil", "qemu-m4f"],
            "error: no HIL firmware at /nonexistent-target/cortex-m/hil/m4f/firmware.elf: build it with `bash scripts/cortex-m.sh --hil-only` (or give --hil-firmware ELF)",
        ),
        (
            &["--blob", blob, "--hil", "qemu-m4f", "--hil-firmware", manifest],
            "not an ELF file",
        ),
        (
            &["--blob", blob, "--hil", "serial:/nonexistent/tty"],
            "error: serial port /nonexistent/tty: no such device (is the board plugged in?)",
        ),
        (&["--blob", blob, "--tick-budget", "5"], "--hil"),
    ];
    for (args, needle) in cases {
        let (code, err) = cli(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

/// A chip in the safe state has no blob and so no action size: it answers an empty action,
/// which the host applies as the plant's zero action. A running chip's empty action is still a
/// wrong size.
#[test]
fn a_chip_in_the_safe_state_answers_empty_actions_applied_as_zeros() {
    use firmware_sim::controller::Controller;
    for running in [false, true] {
        let (host, mut link) = UnixStream::pair().expect("socket pair");
        let fake = std::thread::spawn(move || {
            use std::io::Read;
            let mut h = hello();
            if !running {
                h.running = None;
                h.a = SlotState::Failed {
                    reason: "empty slot".try_into().expect("fits"),
                };
            }
            let mut buf = [0u8; MAX_FRAME];
            send(
                &mut link,
                encode(&FromChip::Hello(h), &mut buf).expect("fits"),
            );
            let (mut rx, mut byte) = (Receiver::new(), [0u8; 1]);
            while let Ok(1) = link.read(&mut byte) {
                if let Some(Ok(ToChip::Observe { tick, .. })) =
                    rx.push(byte[0]).map(|f| f.and_then(decode::<ToChip>))
                {
                    let empty = FromChip::Action {
                        tick,
                        action: Values::new(),
                        ticks: 1,
                    };
                    send(&mut link, encode(&empty, &mut buf).expect("fits"));
                }
            }
        });
        let options = ChipOptions {
            link_name: "fake".into(),
            timeout: Duration::from_millis(300),
            ask_hello: false,
            interrupt: None,
            budget: None,
        };
        let mut chip =
            HilChip::connect(Box::new(host), None, options, "x".into(), 2, 2).expect("hello");
        let mut action = [0.25f32; 2];
        chip.act(&[0.5, f32::NAN], &mut action);
        assert_eq!(action, [0.0; 2]);
        let failure = chip.failure().map(|e| e.to_string());
        if running {
            assert_eq!(
                failure.as_deref(),
                Some("fake: the chip answered tick 0 with tick 0 (0 values for 2)")
            );
        } else {
            assert_eq!(failure, None);
        }
        drop(chip);
        fake.join().expect("the fake chip ends when the host goes");
    }
}

/// A serial line that streams bad frames, and a frame of another protocol version, never
/// restarts the wait for the hello: `--tick-timeout` bounds the whole wait, and the error says
/// what came instead of blaming silence. The board is a pty.
#[test]
fn a_hello_stream_of_bad_frames_still_times_out() {
    use std::io::Write;
    use std::sync::atomic::Ordering;
    let (mut board, port) = serialport::TTYPort::pair().expect("a pty");
    let path = serialport::SerialPort::name(&port).expect("the pty's name");
    let stop = Arc::new(AtomicBool::new(false));
    let writer = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut buf = [0u8; MAX_FRAME];
            let other = encode_version(&FromChip::Hello(hello()), VERSION + 1, &mut buf)
                .expect("fits")
                .to_vec();
            let _ = board.write_all(&other);
            while !stop.load(Ordering::SeqCst) {
                // Line noise: bytes that are no frame, then a delimiter.
                let _ = board.write_all(b"\x03noise\x00");
                std::thread::sleep(Duration::from_millis(20));
            }
        })
    };
    let started = std::time::Instant::now();
    let (code, err) = cli(&[
        "--blob",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../models/nav-walls__dcp-paper__0.postcard"
        ),
        "--episodes",
        "1",
        "--hil",
        &format!("serial:{path}"),
        "--tick-timeout",
        "1",
    ]);
    let took = started.elapsed();
    stop.store(true, Ordering::SeqCst);
    writer.join().expect("writer");
    drop(port);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        took < Duration::from_secs(4),
        "the wait took {took:?}, for a timeout of 1 s"
    );
    let expected = format!("error: serial:{path}: no hello within 1.0 s: received ");
    assert!(err.starts_with(&expected), "{err}");
    assert!(
        err.contains(
            " bad frames and 1 frame of protocol version 2 (firmware-sim speaks version 1"
        ),
        "{err}"
    );
}

/// A board that boots as its port opens sends its boot hello, then answers the host's request
/// for one with a second hello: the second, before the first action, is the same boot, not a
/// reset at tick 0.
#[test]
fn a_boot_hello_before_the_first_tick_is_not_a_reset() {
    let (host, mut link) = UnixStream::pair().expect("socket pair");
    let fake = std::thread::spawn(move || {
        use std::io::Read;
        let mut policy = BlobPolicy::boot(BLOB).expect("boots");
        let mut buf = [0u8; MAX_FRAME];
        send(
            &mut link,
            encode(&FromChip::Hello(hello()), &mut buf).expect("fits"),
        );
        let (mut rx, mut byte) = (Receiver::new(), [0u8; 1]);
        while let Ok(1) = link.read(&mut byte) {
            let answer = match rx.push(byte[0]).map(|f| f.and_then(decode::<ToChip>)) {
                Some(Ok(ToChip::Hello)) => FromChip::Hello(hello()),
                Some(Ok(ToChip::Observe { tick, observation })) => {
                    let mut action = [0.0f32; 2];
                    firmware_sim::controller::Controller::act(
                        &mut policy,
                        &observation,
                        &mut action,
                    );
                    FromChip::Action {
                        tick,
                        action: Values::from_slice(&action).expect("fits"),
                        ticks: 540,
                    }
                }
                _ => continue,
            };
            send(&mut link, encode(&answer, &mut buf).expect("fits"));
        }
    });
    let options = ChipOptions {
        link_name: "fake".into(),
        timeout: Duration::from_millis(300),
        ask_hello: true,
        interrupt: None,
        budget: None,
    };
    let name = firmware_sim::controller::Controller::name(&BlobPolicy::boot(BLOB).expect("boots"));
    let mut chip = HilChip::connect(Box::new(host), None, options, name, 2, 2).expect("hello");
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let report = evaluate_controller(&mut chip, &s, &cfg()).expect("runs");
    assert_eq!(report.stopped.as_ref().map(|s| &s.reason), None);
    assert_eq!(
        format!("{:?}", report.without_timing().episodes),
        format!("{:?}", host_report().without_timing().episodes)
    );
    drop(chip);
    fake.join().expect("the fake chip ends when the host goes");
}

/// `--baud` with QEMU (whose UART has no speed), `--hil-firmware` with a board (which runs
/// what is flashed on it) and `--baud 0` (B0 hangs up a real tty) were accepted and ignored.
#[test]
fn hil_flags_the_link_would_ignore_are_refused() {
    let blob = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../models/nav-walls__dcp-paper__0.postcard"
    );
    let elf = concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml");
    let cases: [(&[&str], &str); 3] = [
        (
            &["--blob", blob, "--hil", "qemu-m4f", "--baud", "9600"],
            "error: --baud sets a serial port's speed; --hil qemu-m4f has none: drop --baud, or give --hil serial:PATH",
        ),
        (
            &["--blob", blob, "--hil", "serial:/dev/ttyACM0", "--hil-firmware", elf],
            "error: --hil-firmware is the ELF that QEMU runs; the board on serial:/dev/ttyACM0 runs the firmware flashed on it: drop --hil-firmware, or give --hil qemu-m4f|qemu-m3",
        ),
        (
            &["--blob", blob, "--hil", "serial:/dev/ttyACM0", "--baud", "0"],
            "error: invalid value '0' for '--baud <BAUD>': 0 is not in 1..=4294967295",
        ),
    ];
    for (args, expected) in cases {
        let (code, err) = cli(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end(), expected, "{args:?}");
    }
}

/// A 32-bit little-endian ARM ELF by hand: the slot symbols of firmware/mps2/memory.x and build
/// attributes naming `cpu`, its Tag_CPU_arch and its Tag_CPU_arch_profile.
fn arm_elf(cpu: &str, arch: u8, profile: u8) -> Vec<u8> {
    let u16le = |v: u16| v.to_le_bytes().to_vec();
    let u32le = |v: u32| v.to_le_bytes().to_vec();
    // .ARM.attributes: version 'A', one "aeabi" subsection holding the file's attributes.
    let mut tags = vec![67];
    tags.extend(b"2.09\0");
    tags.push(5);
    tags.extend(cpu.as_bytes());
    tags.extend([0, 6, arch, 7, profile]);
    let mut file_attrs = vec![1];
    file_attrs.extend(u32le(5 + tags.len() as u32));
    file_attrs.extend(tags);
    let mut attributes = vec![b'A'];
    attributes.extend(u32le(4 + 6 + file_attrs.len() as u32));
    attributes.extend(b"aeabi\0");
    attributes.extend(file_attrs);
    let strtab = b"\0_slot_a\0_slot_b\0_slot_size\0".to_vec();
    let mut symtab = vec![0u8; 16];
    for (name, value) in [(1u32, 0x0004_0000u32), (9, 0x0006_0000), (17, 0x0002_0000)] {
        symtab.extend(u32le(name));
        symtab.extend(u32le(value));
        symtab.extend(u32le(0));
        symtab.extend([0x10, 0]); // global, no type
        symtab.extend(u16le(0xfff1)); // an absolute symbol
    }
    let shstrtab = b"\0.ARM.attributes\0.symtab\0.strtab\0.shstrtab\0".to_vec();
    // The sections' bytes follow the 52-byte header; the section headers come last.
    let bodies = [&attributes, &symtab, &strtab, &shstrtab];
    let mut offsets = Vec::new();
    let mut at = 52u32;
    for body in bodies {
        // Aligned, as the symbol table's entries must be.
        at = at.next_multiple_of(4);
        offsets.push(at);
        at += body.len() as u32;
    }
    let shoff = at.next_multiple_of(4);
    let mut elf = vec![0x7f, b'E', b'L', b'F', 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    elf.extend(u16le(2)); // an executable
    elf.extend(u16le(40)); // EM_ARM
    elf.extend(u32le(1));
    elf.extend(u32le(0x0000_0101)); // entry
    elf.extend(u32le(0)); // no program headers
    elf.extend(u32le(shoff));
    elf.extend(u32le(0x0500_0000)); // EABI version 5
    elf.extend(u16le(52));
    elf.extend(u16le(32));
    elf.extend(u16le(0));
    elf.extend(u16le(40));
    elf.extend(u16le(5));
    elf.extend(u16le(4));
    for (body, offset) in bodies.iter().zip(&offsets) {
        elf.resize(*offset as usize, 0);
        elf.extend(body.iter());
    }
    elf.resize(shoff as usize, 0);
    elf.extend([0u8; 40]);
    // name, type, flags, addr, offset, size, link, info, align, entsize
    let headers = [
        [
            1,
            0x7000_0003,
            0,
            0,
            offsets[0],
            attributes.len() as u32,
            0,
            0,
            1,
            0,
        ],
        [17, 2, 0, 0, offsets[1], symtab.len() as u32, 3, 1, 4, 16],
        [25, 3, 0, 0, offsets[2], strtab.len() as u32, 0, 0, 1, 0],
        [33, 3, 0, 0, offsets[3], shstrtab.len() as u32, 0, 0, 1, 0],
    ];
    for header in headers {
        for field in header {
            elf.extend(u32le(field));
        }
    }
    elf
}

/// Only the ELF's machine was checked, which is ARM for Cortex-A firmware too: an A-profile
/// ELF with the slot symbols passed as HIL firmware. The build attributes' profile decides.
#[test]
fn a_cortex_a_elf_with_the_slot_symbols_is_not_hil_firmware() {
    use firmware_sim::hil::qemu::slot_addresses;
    let dir = std::env::temp_dir().join(format!("firmware-sim-elf-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let cases = [
        ("cortex-m4", 13, b'M', None),
        ("cortex-m3", 10, b'M', None),
        ("cortex-a9", 10, b'A', Some("built for an A-profile core (Cortex-A), architecture tag 10, not a Cortex-M (M-profile)")),
        ("cortex-r5", 10, b'R', Some("built for an R-profile core (Cortex-R), architecture tag 10, not a Cortex-M (M-profile)")),
    ];
    for (cpu, arch, profile, refused) in cases {
        let path = dir.join(format!("{cpu}.elf"));
        std::fs::write(&path, arm_elf(cpu, arch, profile)).expect("write");
        match (slot_addresses(&path), refused) {
            (Ok(slots), None) => assert_eq!(
                (slots.a, slots.b, slots.size),
                (0x0004_0000, 0x0006_0000, 0x0002_0000),
                "{cpu}"
            ),
            (Err(e), Some(reason)) => {
                assert!(e.to_string().contains(reason), "{cpu}: {e}")
            }
            (outcome, _) => panic!("{cpu}: {outcome:?}"),
        }
    }
    // And through the command line: one line, exit 2, before QEMU is looked for.
    let elf = dir.join("cortex-a9.elf");
    let (code, err) = cli(&[
        "--blob",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../models/nav-walls__dcp-paper__0.postcard"
        ),
        "--hil",
        "qemu-m4f",
        "--hil-firmware",
        elf.to_str().expect("utf-8"),
    ]);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("not a Cortex-M (M-profile)"), "{err}");
}

/// `--hil-firmware DIR` said "no such file" of a folder that exists.
#[test]
fn a_folder_as_hil_firmware_is_named_a_folder() {
    let blob = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../models/nav-walls__dcp-paper__0.postcard"
    );
    let dir = env!("CARGO_MANIFEST_DIR");
    let (code, err) = cli(&["--blob", blob, "--hil", "qemu-m4f", "--hil-firmware", dir]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(
        err.trim_end(),
        format!("error: --hil-firmware {dir}: a folder, not an ELF file: give the firmware's ELF, such as target/cortex-m/hil/m4f/firmware.elf")
    );
}

/// `--tick-timeout 1e300` printed the number as 301 digits.
#[test]
fn a_huge_tick_timeout_is_named_in_exponent_form() {
    let blob = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../models/nav-walls__dcp-paper__0.postcard"
    );
    let (code, err) = cli(&[
        "--blob",
        blob,
        "--hil",
        "serial:/dev/null",
        "--tick-timeout",
        "1e300",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(
        err.trim_end(),
        "error: --tick-timeout must be in (0, 3600] seconds, found 1e300"
    );
}

/// `kill -9` of `firmware-sim run --hil qemu-*` left QEMU running (re-parented to init) and its
/// scratch folder in the temporary folder. Here QEMU is a stand-in on `PATH` that connects to
/// the UART socket, says the hello and then outlives its link by a minute unless it is killed:
/// once the run has started, its scratch folder is already gone, and after `kill -9` of
/// firmware-sim no process of the run is left. (scripts/cortex-m.sh does the same with the
/// real QEMU and HIL firmware.)
#[test]
fn kill_9_of_a_hil_run_leaves_no_qemu_and_no_scratch_folder() {
    use std::io::{BufRead, BufReader};
    use std::os::unix::fs::PermissionsExt;
    if !std::path::Path::new("/usr/bin/setpriv").is_file() {
        eprintln!("no /usr/bin/setpriv: QEMU cannot die with firmware-sim here; not checked");
        return;
    }
    let root = std::env::temp_dir().join(format!("firmware-sim-kill9-{}", std::process::id()));
    let (bin, tmp) = (root.join("bin"), root.join("tmp"));
    std::fs::create_dir_all(&bin).expect("dir");
    std::fs::create_dir_all(&tmp).expect("dir");
    let fake = bin.join("qemu-system-arm");
    std::fs::write(
        &fake,
        "#!/usr/bin/env python3\n\
         import os, socket, sys, time\n\
         path = [a.split('path=')[1] for a in sys.argv if a.startswith('socket,id=hil,path=')][0]\n\
         s = socket.socket(socket.AF_UNIX)\n\
         s.connect(path)\n\
         s.sendall(bytes.fromhex(os.environ['FAKE_CHIP_HELLO']))\n\
         while s.recv(4096):\n    pass\n\
         time.sleep(60)\n",
    )
    .expect("fake QEMU");
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    let elf = root.join("firmware.elf");
    std::fs::write(&elf, arm_elf("cortex-m4", 13, b'M')).expect("elf");
    let mut buf = [0u8; MAX_FRAME];
    let hello_frame = encode(&FromChip::Hello(hello()), &mut buf).expect("fits");
    let hex: String = hello_frame.iter().map(|b| format!("{b:02x}")).collect();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut run = Command::new(BIN)
        .args(["run", "--blob"])
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../models/nav-walls__dcp-paper__0.postcard"
        ))
        .args([
            "--episodes",
            "1",
            "--tick-timeout",
            "30",
            "--hil",
            "qemu-m4f",
        ])
        .arg("--hil-firmware")
        .arg(&elf)
        .env("PATH", path)
        .env("TMPDIR", &tmp)
        .env("FAKE_CHIP_HELLO", hex)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("firmware-sim");
    let pid = run.id();
    let mut lines = BufReader::new(run.stdout.take().expect("stdout")).lines();
    let started = lines
        .next()
        .and_then(Result::ok)
        .unwrap_or_else(|| panic!("no line from the run ({:?})", run.try_wait()));
    assert!(started.ends_with("slot A runs"), "{started}");
    // The chip has said its hello and waits for its first observation's answer.
    let scratch = || -> Vec<String> {
        std::fs::read_dir(&tmp)
            .expect("tmp")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect()
    };
    assert_eq!(
        scratch(),
        Vec::<String>::new(),
        "the scratch folder outlived the boot"
    );
    run.kill().expect("kill -9");
    run.wait().expect("reaped");
    // The stand-in names the run's socket, under our TMPDIR, on its command line.
    let marker = format!("firmware-sim-hil-{pid}-");
    let left = || -> Vec<String> {
        std::fs::read_dir("/proc")
            .expect("/proc")
            .flatten()
            .filter_map(|e| std::fs::read(e.path().join("cmdline")).ok())
            .map(|c| String::from_utf8_lossy(&c).replace('\0', " "))
            .filter(|c| c.contains(&marker))
            .collect()
    };
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    while !left().is_empty() && std::time::Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(left(), Vec::<String>::new(), "QEMU outlived firmware-sim");
    assert_eq!(scratch(), Vec::<String>::new());
    let _ = std::fs::remove_dir_all(&root);
}
