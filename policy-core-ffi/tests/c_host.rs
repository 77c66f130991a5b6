//! A C program (tests/c/host_check.c) compiled against the committed header and the host static
//! library, run on the golden blobs: its error codes are the expected ones, and its actions and
//! Q values are policy-core's, bit for bit. Skipped, with a message, where no C compiler is
//! installed (`CC`, else `cc`, else `gcc`).
//!
//! The static library is built by cargo for this test (`cargo build -p policy-core-ffi --lib`,
//! in the same target directory, whose dependencies are built already), and found through
//! cargo's JSON messages rather than a guessed path.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use policy_core::model::{Model, Scratch};
use policy_core::slot;
use policy_core_ffi::*;

const MANIFEST_DIR: &str = env!("CARGO_MANIFEST_DIR");

fn golden(name: &str) -> PathBuf {
    Path::new(MANIFEST_DIR)
        .join("../policy-core/tests/golden")
        .join(name)
}

/// The C compiler to use, if any.
fn c_compiler() -> Option<String> {
    let candidates = std::env::var("CC")
        .ok()
        .into_iter()
        .chain(["cc".to_string(), "gcc".to_string()]);
    candidates.into_iter().find(|cc| {
        Command::new(cc)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// Builds the host static library with cargo and returns its path.
fn static_library() -> PathBuf {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    // The target directory this test was built in (CARGO_TARGET_TMPDIR is its tmp/): cargo has
    // released its lock by the time tests run, and the dependencies are already built there.
    let target_dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("CARGO_TARGET_TMPDIR is <target dir>/tmp")
        .to_path_buf();
    let out = Command::new(cargo)
        .args(["build", "--quiet", "--lib", "-p", "policy-core-ffi"])
        .args(["--message-format", "json-render-diagnostics"])
        .arg("--target-dir")
        .arg(&target_dir)
        .current_dir(MANIFEST_DIR)
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo build -p policy-core-ffi failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = String::from_utf8(out.stdout).expect("utf-8");
    // One compiler-artifact message per crate; the library's lists the .a among its files.
    json.lines()
        .filter(|l| l.contains("\"compiler-artifact\"") && l.contains("policy_core_ffi"))
        .flat_map(|l| l.split('"'))
        .find(|s| s.ends_with("libpolicy_core_ffi.a"))
        .map(PathBuf::from)
        .expect("cargo reports libpolicy_core_ffi.a")
}

fn hex(t: &str) -> u32 {
    u32::from_str_radix(t, 16).expect("hex")
}

#[test]
fn a_c_program_refuses_bad_input_and_acts_bit_exactly() {
    let Some(cc) = c_compiler() else {
        eprintln!("SKIPPED: no C compiler (CC, cc or gcc) on this machine; the C test did not run");
        return;
    };
    let lib = static_library();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c-host");
    std::fs::create_dir_all(&dir).expect("dir");
    let exe = dir.join("host_check");
    let status = Command::new(&cc)
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-O1"])
        .arg("-I")
        .arg(Path::new(MANIFEST_DIR).join("include"))
        .arg(Path::new(MANIFEST_DIR).join("tests/c/host_check.c"))
        .arg(&lib)
        // What a host staticlib built with std needs from the system (rustc
        // --print native-static-libs on Linux).
        .args(["-lpthread", "-ldl", "-lm", "-lrt", "-lutil"])
        .arg("-o")
        .arg(&exe)
        .status()
        .expect("the C compiler runs");
    assert!(status.success(), "compiling tests/c/host_check.c failed");

    // Inputs: the awkward observations and a sweep.
    let mut obs: Vec<[f32; 2]> = vec![
        [0.0, 0.0],
        [f32::NAN, 1.0],
        [f32::INFINITY, f32::NEG_INFINITY],
        [-0.0, 1.0e-39],
        [f32::MAX, -f32::MAX],
    ];
    obs.extend((0..40).map(|k| [k as f32 * 0.37 - 7.0, 5.0 - k as f32 * 0.29]));
    let obs_file = dir.join("observations.txt");
    let lines: String = obs
        .iter()
        .map(|o| format!("{:08x} {:08x}\n", o[0].to_bits(), o[1].to_bits()))
        .collect();
    std::fs::write(&obs_file, lines).expect("write observations");
    let actor = std::fs::read(golden("actor_4x48.postcard")).expect("actor");
    let critic = std::fs::read(golden("critic_2x32.postcard")).expect("critic");
    let record = |seq: u32, blob: &[u8]| {
        [&slot::header(seq, blob.len()).expect("header")[..], blob].concat()
    };
    let (slot_a, slot_b) = (dir.join("slot-a.bin"), dir.join("slot-b.bin"));
    std::fs::write(&slot_a, record(1, &actor)).expect("slot a");
    std::fs::write(&slot_b, record(2, &critic)).expect("slot b");

    let out = Command::new(&exe)
        .arg(golden("actor_4x48.postcard"))
        .arg(golden("critic_2x32.postcard"))
        .arg(&obs_file)
        .arg(&slot_a)
        .arg(&slot_b)
        .output()
        .expect("host_check runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "host_check failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // The C compiler's layout of every API type is Rust's.
    let mut sizes = BTreeMap::new();
    let mut codes = BTreeMap::new();
    let (mut acts, mut qs) = (Vec::new(), Vec::new());
    for line in stdout.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["SIZE", name, n] => {
                sizes.insert(name.to_string(), n.parse::<usize>().expect("size"));
            }
            ["CODE", name, code, ..] => {
                codes.insert(name.to_string(), (code.parse::<i32>().expect("code"), line));
            }
            ["ACT", _, a, b] => acts.push([hex(a), hex(b)]),
            ["Q", _, q] => qs.push(hex(q)),
            _ => {}
        }
    }
    assert_eq!(sizes["dcp_error"], size_of::<DcpError>());
    assert_eq!(sizes["dcp_header"], size_of::<DcpHeader>());
    assert_eq!(sizes["dcp_model"], size_of::<DcpModel>());
    assert_eq!(sizes["dcp_model_align"], align_of::<DcpModel>());
    assert_eq!(sizes["dcp_boot"], size_of::<DcpBoot>());

    let expected = [
        ("verify_null_blob", DCP_ERR_NULL_POINTER),
        ("verify_null_out", DCP_ERR_NULL_POINTER),
        ("verify_short", DCP_ERR_TRUNCATED),
        ("verify_long", DCP_ERR_TRAILING_BYTES),
        ("verify_flipped", DCP_ERR_CHECKSUM_MISMATCH),
        ("act_zeroed_model", DCP_ERR_NOT_LOADED),
        ("load_actor", DCP_OK),
        ("load_critic", DCP_OK),
        ("for_policy_critic", DCP_ERR_WRONG_KIND),
        ("act_null_obs", DCP_ERR_NULL_POINTER),
        ("act_null_scratch", DCP_ERR_NULL_POINTER),
        ("act_null_action", DCP_ERR_NULL_POINTER),
        ("act_obs_len", DCP_ERR_SIZE_MISMATCH),
        ("act_action_len", DCP_ERR_SIZE_MISMATCH),
        ("act_scratch_short", DCP_ERR_SCRATCH_TOO_SMALL),
        ("act_on_critic", DCP_ERR_WRONG_KIND),
        ("act_overlap", DCP_ERR_OVERLAP),
        ("choose_on_actor", DCP_ERR_WRONG_KIND),
        ("choice_q_on_actor", DCP_ERR_WRONG_KIND),
        ("scratch_floats", DCP_OK),
        ("slot_choose", DCP_OK),
        ("act_slot_model", DCP_OK),
        ("slot_read_erased", DCP_ERR_SLOT_EMPTY),
        ("slot_choose_erased", DCP_ERR_NO_SLOT),
        ("act_after_no_slot", DCP_ERR_NOT_LOADED),
    ];
    for (name, code) in expected {
        let (got, line) = codes
            .get(name)
            .unwrap_or_else(|| panic!("no CODE {name} line in:\n{stdout}"));
        assert_eq!(*got, code, "{line}");
    }
    assert_eq!(
        codes.len(),
        expected.len(),
        "a CODE line with no expectation"
    );
    assert!(
        codes["act_scratch_short"].1.contains("needed=48 found=47"),
        "{}",
        codes["act_scratch_short"].1
    );
    assert!(stdout.contains("FLOATS 96"), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "BOOT running={DCP_SLOT_A} a={DCP_SLOT_RUNNING}/1 b={DCP_SLOT_FAILED}/{DCP_ERR_WRONG_KIND}"
        )),
        "{stdout}"
    );
    assert!(
        stdout.contains("REASON B wrong model kind: expected actor, found critic"),
        "{stdout}"
    );

    // Bit for bit what policy-core computes.
    let a = Model::from_blob(&actor).expect("actor");
    let c = Model::from_blob(&critic).expect("critic");
    assert_eq!((acts.len(), qs.len()), (obs.len(), obs.len()));
    let mut scratch = Scratch::<64>::new();
    for (k, o) in obs.iter().enumerate() {
        let mut want = [0.0f32; 2];
        a.act(o, &mut scratch, &mut want).expect("act");
        assert_eq!(acts[k], want.map(f32::to_bits), "observation {k}: {o:?}");
        let unit = [o[0] / 4.0, o[1] / 4.0];
        let q = c.q(o, &unit, &mut scratch).expect("q");
        assert_eq!(qs[k], q.to_bits(), "observation {k}: {o:?}");
    }
}

/// The header compiles alone as C89 (pedantic), as C++98, and with `DCP_ALIGNED` defined by the
/// caller, as a compiler other than GCC, Clang or MSVC must (tests/c/c89.c: its size macros are
/// constant expressions, and `dcp_model` keeps its alignment, each a compile-time check).
#[test]
fn the_header_compiles_as_c89_and_cpp98_with_a_caller_defined_alignment() {
    let Some(cc) = c_compiler() else {
        eprintln!("SKIPPED: no C compiler (CC, cc or gcc) on this machine; the C test did not run");
        return;
    };
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c89");
    std::fs::create_dir_all(&dir).expect("dir");
    let source = Path::new(MANIFEST_DIR).join("tests/c/c89.c");
    let include = Path::new(MANIFEST_DIR).join("include");
    let builds: [&[&str]; 3] = [
        &["-std=c89", "-pedantic"],
        &["-x", "c++", "-std=c++98", "-pedantic"],
        &[
            "-std=c89",
            "-pedantic",
            "-DDCP_ALIGNED(n)=__attribute__((__aligned__(n)))",
        ],
    ];
    for flags in builds {
        let status = Command::new(&cc)
            .args(flags)
            .args(["-Wall", "-Wextra", "-Werror", "-c"])
            .arg("-I")
            .arg(&include)
            .arg(&source)
            .arg("-o")
            .arg(dir.join("c89.o"))
            .status()
            .expect("the C compiler runs");
        assert!(
            status.success(),
            "the header with {flags:?} does not compile"
        );
    }
}

/// Whether `program --version` runs on this machine.
fn installed(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Compiles `tests/c/NAME.c` against the committed header and the host library with `flags`.
fn compile(cc: &str, lib: &Path, name: &str, flags: &[&str], exe: &Path) {
    let status = Command::new(cc)
        .args(flags)
        .args(["-Wall", "-Wextra", "-Werror", "-g"])
        .arg("-I")
        .arg(Path::new(MANIFEST_DIR).join("include"))
        .arg(Path::new(MANIFEST_DIR).join(format!("tests/c/{name}.c")))
        .arg(lib)
        .args(["-lpthread", "-ldl", "-lm", "-lrt", "-lutil"])
        .arg("-o")
        .arg(exe)
        .status()
        .expect("the C compiler runs");
    assert!(
        status.success(),
        "compiling tests/c/{name}.c with {flags:?} failed"
    );
}

/// Runs `command` and requires every check of tests/c/contract.c to pass.
fn expect_contract(mut command: Command, how: &str) -> String {
    let out = command.output().expect("the contract program runs");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success() && !stdout.contains("FAIL"),
        "{how}: exit status {:?}\n{stdout}\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The C contract of docs/c-api.md, as a C program sees it (tests/c/contract.c): built with
/// AddressSanitizer and UndefinedBehaviorSanitizer, and run again under valgrind's memcheck,
/// which fails on any byte of `dcp_header`, `dcp_error` or `dcp_boot` the library left
/// uninitialised (their padding was once filled from the library's stack). Each tool is skipped,
/// with a message, where it is not installed.
#[test]
fn the_c_contract_holds_under_sanitizers_and_valgrind() {
    let Some(cc) = c_compiler() else {
        eprintln!("SKIPPED: no C compiler (CC, cc or gcc) on this machine; the C test did not run");
        return;
    };
    let lib = static_library();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c-contract");
    std::fs::create_dir_all(&dir).expect("dir");
    let actor = std::fs::read(golden("actor_4x48.postcard")).expect("actor");
    let slot_a = dir.join("slot-a.bin");
    let record = [&slot::header(1, actor.len()).expect("header")[..], &actor].concat();
    std::fs::write(&slot_a, record).expect("slot a");
    let args = [
        golden("actor_4x48.postcard"),
        golden("critic_2x32.postcard"),
        slot_a,
    ];

    let sanitized = dir.join("contract-sanitized");
    compile(
        &cc,
        &lib,
        "contract",
        &[
            "-std=c99",
            "-O1",
            "-fsanitize=address,undefined",
            "-fno-sanitize-recover=all",
        ],
        &sanitized,
    );
    let mut run = Command::new(&sanitized);
    // LeakSanitizer needs ptrace, which a container may forbid; leaks are valgrind's job here.
    run.args(&args).env("ASAN_OPTIONS", "detect_leaks=0");
    let stdout = expect_contract(run, "ASan + UBSan");
    for check in ["padding_reserved", "one_slot", "abi", "sizes"] {
        assert!(stdout.contains(&format!("OK {check}\n")), "{stdout}");
    }

    assert!(stdout.contains(&format!(
        "ABI header={DCP_ABI_VERSION} library={DCP_ABI_VERSION} status=0 Ok"
    )));

    // The same program built against a header of the next ABI version: the library refuses it.
    let other = dir.join("other-abi");
    std::fs::create_dir_all(&other).expect("dir");
    let header = std::fs::read_to_string(Path::new(MANIFEST_DIR).join("include/policy_core.h"))
        .expect("header");
    let from = format!("#define DCP_ABI_VERSION {DCP_ABI_VERSION}\n");
    assert!(header.contains(&from), "the header defines DCP_ABI_VERSION");
    let next = DCP_ABI_VERSION + 1;
    let edited = header.replace(&from, &format!("#define DCP_ABI_VERSION {next}\n"));
    std::fs::write(other.join("policy_core.h"), edited).expect("write header");
    let mismatched = dir.join("contract-other-abi");
    let include = format!("-I{}", other.display());
    compile(
        &cc,
        &lib,
        "contract",
        &[include.as_str(), "-std=c99"],
        &mismatched,
    );
    let mut run = Command::new(&mismatched);
    run.args(&args);
    let refused = expect_contract(run, "another ABI version");
    assert!(
        refused.contains(&format!(
            "ABI header={next} library={DCP_ABI_VERSION} status={DCP_ERR_ABI_MISMATCH} AbiMismatch"
        )),
        "{refused}"
    );

    if !installed("valgrind") {
        eprintln!("SKIPPED: valgrind is not installed; the uninitialised-byte check did not run");
        return;
    }
    let plain = dir.join("contract");
    compile(&cc, &lib, "contract", &["-std=c99", "-O0"], &plain);
    let mut run = Command::new("valgrind");
    run.args(["--quiet", "--error-exitcode=3", "--track-origins=yes"])
        .arg(&plain)
        .args(&args);
    let under_valgrind = expect_contract(run, "valgrind");
    assert_eq!(under_valgrind, stdout, "the same checks, the same sums");
}
