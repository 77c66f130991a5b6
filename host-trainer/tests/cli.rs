//! The `host-trainer` binary on bad input: one clear line on stderr, exit 2 (1 is the gate's
//! FAIL, never an error), no panic, and no partial files.

use std::path::{Path, PathBuf};

use host_trainer::algorithms::Algo;
use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::config::TrainConfig;
use host_trainer::run::folder;
use policy_core::{ActionBounds, Critic, Normalizer, Policy};

use crate::support::{
    assert_ok, assert_one_line_error, command, entries, host_trainer, s, scratch,
    smoke_config_file, smoke_config_file_of, temporaries, train_smoke,
};

#[test]
fn unknown_algorithm_is_one_line_and_writes_nothing() {
    let out_dir = scratch("bad-algo");
    let dir = out_dir.to_str().expect("utf-8");
    let out = host_trainer(&["train", "--algo", "sarsa", "--out", dir, "--episodes", "1"]);
    assert_one_line_error(&out, &["sarsa"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(entries(&out_dir).is_empty());
    std::fs::remove_dir_all(&out_dir).expect("cleanup");
}

#[test]
fn malformed_values_are_rejected_before_any_file_is_written() {
    let out_dir = scratch("bad-values");
    let dir = out_dir.to_str().expect("utf-8");
    for (flag, value, needle) in [
        ("--hidden", "4by48", "4by48"),
        // Beyond policy-core's limits (depth <= 64, width <= 1024); any shape within them trains.
        ("--hidden", "65x40", "depth must be in 1..=64"),
        ("--sigma", "nan", "sigma"),
        ("--t", "0", "dcp.t"),
        ("--task", "nav-nowhere", "nav-nowhere"),
        ("--reward", "best", "best"),
        ("--noise", "brownian", "brownian"),
        // Regression: these aborted on 40 GB allocations before the shape
        // check ran.
        ("--hidden", "100x100000", "unsupported network shape"),
        ("--hidden", "4x65536", "unsupported network shape"),
        ("--hidden", "4x1025", "width must be in 1..=1024"),
        // Within every size limit, but 67 million parameters: beyond the 16 MiB payload.
        ("--hidden", "64x1024", "16 MiB"),
        // Regression: a NaN or infinite reward scale was not validated.
        ("--reward-scale", "nan", "agent.reward_scale"),
        ("--reward-scale", "inf", "agent.reward_scale"),
        ("--reward-scale", "0", "agent.reward_scale"),
        // Limits checked before anything is allocated.
        ("--episodes", "18446744073709551615", "episodes"),
        ("--threads", "0", "--threads"),
        ("--threads", "many", "many"),
    ] {
        let out = host_trainer(&["train", flag, value, "--out", dir, "--episodes", "1"]);
        assert_one_line_error(&out, &[needle]);
        assert!(
            entries(&out_dir).is_empty(),
            "{flag} {value} left files: {:?}",
            entries(&out_dir)
        );
    }
    std::fs::remove_dir_all(&out_dir).expect("cleanup");
}

#[test]
fn missing_output_folder_is_an_error_and_is_not_created() {
    let base = scratch("missing-out");
    let missing = base.join("no").join("such");
    let out = host_trainer(&[
        "train",
        "--out",
        missing.to_str().expect("utf-8"),
        "--episodes",
        "1",
    ]);
    let stderr = assert_one_line_error(&out, &["does not exist"]);
    // The cause once: an error's message and its source chain must not both print it.
    assert_eq!(stderr.matches("does not exist").count(), 1, "{stderr}");
    assert!(!base.join("no").exists());
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// A folder this process cannot create files in: a read-only temp folder, or (when running as
/// root, which ignores permissions) `/sys`, which refuses new entries even to root.
fn unwritable_dir(base: &Path) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let dir = base.join("read-only");
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o555)).expect("chmod");
    if std::fs::write(dir.join("probe"), b"").is_err() {
        return dir;
    }
    let _ = std::fs::remove_file(dir.join("probe"));
    PathBuf::from("/sys")
}

#[test]
fn unwritable_output_folder_is_an_error() {
    let base = scratch("unwritable");
    let dir = unwritable_dir(&base);
    let out = host_trainer(&[
        "train",
        "--out",
        dir.to_str().expect("utf-8"),
        "--episodes",
        "1",
    ]);
    assert_one_line_error(&out, &[dir.to_str().expect("utf-8")]);
    assert!(!dir.join("nav-walls__dcp__0").exists());
    std::fs::remove_dir_all(&base).ok();
}

#[test]
fn unreadable_or_invalid_config_file_is_one_line() {
    let base = scratch("config");
    let dir = base.to_str().expect("utf-8");
    let out = host_trainer(&["train", "--config", "/no/such/config.toml", "--out", dir]);
    assert_one_line_error(&out, &["/no/such/config.toml"]);
    // Writes a config file into `base` and trains with it.
    let train_with = |name: &str, text: &str| {
        let path = base.join(name);
        std::fs::write(&path, text).expect("write");
        host_trainer(&[
            "train",
            "--config",
            path.to_str().expect("utf-8"),
            "--out",
            dir,
        ])
    };
    let out = train_with("bad.toml", "episodes = 10\nlearning_rat = 0.1\n");
    assert_one_line_error(&out, &["bad.toml", "learning_rat"]);
    assert_eq!(entries(&base), vec!["bad.toml".to_string()]);
    let out = train_with("theta.toml", "[agent]\nnoise = \"ou\"\nou_theta = 1.5\n");
    assert_one_line_error(&out, &["agent.ou_theta"]);
    let mut left = entries(&base);
    left.sort();
    assert_eq!(left, vec!["bad.toml".to_string(), "theta.toml".to_string()]);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[test]
fn eval_and_export_report_missing_inputs() {
    let base = scratch("eval-export");
    let out = host_trainer(&["eval", "--blob", "/no/such/policy.postcard"]);
    assert_one_line_error(&out, &["/no/such/policy.postcard"]);
    let garbage = base.join("garbage.postcard");
    std::fs::write(&garbage, b"not a blob").expect("write");
    let out = host_trainer(&["eval", "--blob", garbage.to_str().expect("utf-8")]);
    assert_one_line_error(&out, &[]);
    let out = host_trainer(&[
        "export",
        "--run",
        base.join("nope").to_str().expect("utf-8"),
    ]);
    assert_one_line_error(&out, &["nope"]);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[test]
fn help_succeeds() {
    let out = host_trainer(&["train", "--help"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("--episodes"));
}

/// A valid actor blob of the navigation shape (zero weights), and the same blob with one weight
/// set to NaN under a correct CRC.
fn actor_blobs() -> (Vec<u8>, Vec<u8>) {
    let mut p = Policy::<2, 32, 1, 2>::ZERO;
    p.normalizer = Normalizer::identity(5.0);
    p.bounds = ActionBounds::symmetric(0.25);
    let good = p.to_blob("ok").expect("blob");
    let v = policy_core::blob::verify(&good).expect("verify");
    let payload_at = good.len() - 4 - v.payload.len();
    let mut nan = good.clone();
    // The 20th parameter is a first-layer weight (after 5 normaliser and 4 bound values).
    let at = payload_at + 4 * 20;
    nan[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let body = nan.len() - 4;
    let crc = policy_core::crc32(&nan[..body]);
    nan[body..].copy_from_slice(&crc.to_le_bytes());
    (good, nan)
}

/// Regression: `eval` of a blob that does not boot (a critic, a NaN weight
/// under a valid CRC) printed "boot error" and exited 0, so a CI gate on `eval` passed a policy
/// that never ran.
#[test]
fn eval_of_a_blob_that_does_not_boot_fails() {
    let base = scratch("eval-boot");
    // A valid critic (policy-core checks every parameter before the kind).
    let critic = Critic::<2, 32, 1, 2> {
        normalizer: Normalizer::identity(5.0),
        ..Critic::ZERO
    }
    .to_blob("critic")
    .expect("critic blob");
    let (good, nan) = actor_blobs();
    for (name, bytes, needle) in [
        ("critic.postcard", &critic, "kind"),
        ("nan.postcard", &nan, "finite"),
    ] {
        let path = base.join(name);
        std::fs::write(&path, bytes).expect("write");
        let out = host_trainer(&["eval", "--blob", s(&path), "--episodes", "2"]);
        assert_one_line_error(&out, &[name, "does not boot", needle]);
        assert!(out.stdout.is_empty(), "no report for a blob that never ran");
    }
    let path = base.join("good.postcard");
    std::fs::write(&path, good).expect("write");
    let out = host_trainer(&["eval", "--blob", s(&path), "--episodes", "2"]);
    assert_ok(&out);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Regression: `eval --episodes 18446744073709551615` panicked with
/// `capacity overflow`, and an unwritable `--json` was found only after the evaluation.
#[test]
fn eval_checks_its_limits_and_output_before_any_work() {
    let base = scratch("eval-limits");
    let (good, _) = actor_blobs();
    let blob = base.join("good.postcard");
    std::fs::write(&blob, good).expect("write");
    for n in ["18446744073709551615", "1000000000000"] {
        let out = host_trainer(&["eval", "--blob", s(&blob), "--episodes", n]);
        assert_one_line_error(&out, &["episodes", n]);
    }
    // A million episodes would run for a minute; the missing folder must stop it first, before
    // anything is printed.
    let out = host_trainer(&[
        "eval",
        "--blob",
        s(&blob),
        "--episodes",
        "1000000",
        "--json",
        "/nonexistent/r.json",
    ]);
    assert_one_line_error(&out, &["/nonexistent/r.json", "folder does not exist"]);
    assert!(out.stdout.is_empty());
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Regression: no subcommand printed the description and exited 2 without
/// saying what was missing.
#[test]
fn a_missing_subcommand_is_named() {
    let out = host_trainer(&[]);
    assert_one_line_error(&out, &["missing a subcommand", "train", "eval", "export"]);
    assert_eq!(out.status.code(), Some(2));
}

/// Regression: `--seed 18446744073709551615`, or a task file name longer than
/// 16 characters, trained to the end and then failed with "label longer than 32 bytes": no
/// blob, and export of that run failed forever.
#[test]
fn a_huge_seed_and_a_long_task_name_still_export() {
    let base = scratch("long-label");
    let task = base.join("a-task-file-with-a-long-name.toml");
    std::fs::write(
        &task,
        std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../firmware-sim/scenarios/nav-open.toml"
        ))
        .expect("scenario"),
    )
    .expect("task");
    let out = train_smoke(
        &base,
        1,
        &["--task", s(&task), "--seed", "18446744073709551615"],
    );
    assert_ok(&out);
    let run = base.join("a-task-file-with-a-long-name__dcp__18446744073709551615");
    let blob = std::fs::read(run.join("policy.postcard")).expect("blob");
    let label = policy_core::blob::verify(&blob)
        .expect("verify")
        .header
        .label;
    assert_eq!(label.as_str(), "a-ta~__dcp__18446744073709551615");
    let out = host_trainer(&["export", "--run", s(&run)]);
    assert_ok(&out);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Regression: `train --out DIR` over a finished run silently overwrote its
/// checkpoint and metrics.
#[test]
fn training_into_a_finished_run_is_refused_and_keeps_it() {
    let base = scratch("overwrite");
    let train = || train_smoke(&base, 1, &[]);
    assert_ok(&train());
    let run = base.join("nav-walls__dcp__3");
    let before: Vec<Vec<u8>> = ["checkpoint.postcard", "policy.postcard", "eval.json"]
        .iter()
        .map(|f| std::fs::read(run.join(f)).expect("run file"))
        .collect();
    let out = train();
    assert_one_line_error(&out, &["already holds a run", "--resume"]);
    let after: Vec<Vec<u8>> = ["checkpoint.postcard", "policy.postcard", "eval.json"]
        .iter()
        .map(|f| std::fs::read(run.join(f)).expect("run file"))
        .collect();
    assert_eq!(before, after);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Regression: a run trained with a relative `--task mytask.toml` could not
/// be resumed or exported from another folder or after the file was deleted, and an edited file
/// was silently used by `--resume`.
#[test]
fn a_run_resumes_and_exports_from_its_own_folder_alone() {
    let base = scratch("own-folder");
    let work = base.join("work");
    std::fs::create_dir_all(&work).expect("dir");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware-sim/scenarios/nav-open.toml"
    ))
    .expect("scenario");
    std::fs::write(work.join("mytask.toml"), &text).expect("task");
    let config = smoke_config_file(&base, 2);
    let out = command(&[
        "train",
        "--config",
        s(&config),
        "--task",
        "mytask.toml",
        "--episodes",
        "1",
        "--out",
        ".",
        "--quiet",
    ])
    .current_dir(&work)
    .output()
    .expect("runs");
    assert_ok(&out);
    let run = work.join("mytask__dcp__3");
    assert!(
        run.join("scenario.toml").exists(),
        "the run records its plant"
    );

    // Edited: resume says so and continues on the recorded plant.
    std::fs::write(
        work.join("mytask.toml"),
        text.replace("time_limit = 200", "time_limit = 20"),
    )
    .expect("edit");
    let out = command(&[
        "train",
        "--resume",
        "mytask__dcp__3",
        "--episodes",
        "2",
        "--quiet",
    ])
    .current_dir(&work)
    .output()
    .expect("runs");
    assert_ok(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("has changed") && stderr.contains("recorded plant"),
        "{stderr}"
    );

    // Deleted, and from another folder: export and resume still work.
    std::fs::remove_file(work.join("mytask.toml")).expect("delete");
    let out = host_trainer(&["export", "--run", s(&run)]);
    assert_ok(&out);
    let out = host_trainer(&["train", "--resume", s(&run), "--episodes", "3", "--quiet"]);
    assert_ok(&out);
    assert_eq!(temporaries(&run), Vec::<String>::new());
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Regression: a checkpoint with a flipped bit was accepted by `export`.
#[test]
fn export_of_a_corrupt_checkpoint_is_one_line() {
    let base = scratch("corrupt-export");
    assert_ok(&train_smoke(&base, 1, &[]));
    let run = base.join("nav-walls__dcp__3");
    let path = run.join("checkpoint.postcard");
    let mut bytes = std::fs::read(&path).expect("checkpoint");
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x10;
    std::fs::write(&path, bytes).expect("corrupt it");
    let out = host_trainer(&["export", "--run", s(&run)]);
    assert_one_line_error(&out, &["checkpoint", "checksum mismatch"]);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Issue "policy-core v2": no table of compiled shapes. A 3x40 network (never compiled) trains,
/// exports, and its blob boots and runs in firmware-sim's loop (the end-of-training evaluation
/// and `eval`), and `inspect` reads it.
#[test]
fn train_3x40_exports_and_runs_in_firmware_sim() {
    let base = scratch("train-3x40");
    let out = train_smoke(&base, 2, &["--hidden", "3x40"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    assert!(
        stdout.contains("3x40"),
        "the evaluation names the blob: {stdout}"
    );
    let blob = base.join("nav-walls__dcp__3").join("policy.postcard");
    let eval = host_trainer(&["eval", "--blob", s(&blob), "--episodes", "3"]);
    assert_ok(&eval);
    assert!(String::from_utf8_lossy(&eval.stdout).contains("3 test starts"));
    let inspect = host_trainer(&["inspect", s(&blob)]);
    let text = String::from_utf8_lossy(&inspect.stdout);
    assert_ok(&inspect);
    assert!(
        text.contains("shape       3x40 hidden, 2 observations, 2 actions\n"),
        "{text}"
    );
    let critic = host_trainer(&[
        "inspect",
        s(&base.join("nav-walls__dcp__3").join("critic.postcard")),
    ]);
    assert!(String::from_utf8_lossy(&critic.stdout).contains("kind        critic\n"));
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `inspect` prints every header field and the small vectors, from the verified bytes.
#[test]
fn inspect_prints_what_a_blob_holds() {
    let base = scratch("inspect");
    let mut p = Box::new(Policy::<2, 48, 3, 2>::ZERO);
    p.normalizer = Normalizer::identity(5.0);
    p.bounds = ActionBounds::symmetric(0.25);
    let bytes = p.to_blob("nav-walls__dcp__0").expect("blob");
    let path = base.join("policy.postcard");
    std::fs::write(&path, &bytes).expect("write");
    let out = host_trainer(&["inspect", s(&path)]);
    assert_ok(&out);
    let crc = u32::from_le_bytes(bytes[bytes.len() - 4..].try_into().expect("crc"));
    let expected = format!(
        "kind        actor
shape       4x48 hidden, 2 observations, 2 actions
activation  tanh
encoding    f32
version     2
label       \"nav-walls__dcp__0\"
parameters  7307
bytes       {} (header 36, payload 29228, CRC 4)
crc         {crc:#010x}
normaliser  mean [0.0, 0.0], inv_std [1.0, 1.0], clip 5.0
bounds      low [-0.25, -0.25], high [0.25, 0.25]
",
        bytes.len()
    );
    assert_eq!(String::from_utf8_lossy(&out.stdout), expected);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `inspect` of a file that is not a blob: one line naming the file and the reason, exit 1.
#[test]
fn inspect_of_a_bad_file_is_one_line() {
    let base = scratch("inspect-bad");
    let mut p = Policy::<2, 32, 1, 2>::ZERO;
    p.normalizer = Normalizer::identity(5.0);
    let mut flipped = p.to_blob("x").expect("blob");
    let mid = flipped.len() / 2;
    flipped[mid] ^= 8;
    let mut nan = p.clone();
    nan.trunk.output.b[0] = f32::NAN;
    let cases: [(&str, Vec<u8>, &str); 4] = [
        ("text.postcard", b"hello".to_vec(), "magic"),
        ("flipped.postcard", flipped, "checksum"),
        (
            "nan.postcard",
            nan.to_blob("x").expect("blob"),
            "NaN or infinite",
        ),
        ("empty.postcard", Vec::new(), "truncated"),
    ];
    for (name, bytes, needle) in cases {
        let path = base.join(name);
        std::fs::write(&path, bytes).expect("write");
        let out = host_trainer(&["inspect", s(&path)]);
        assert_one_line_error(&out, &[name, "is not a valid blob", needle]);
        assert_eq!(out.status.code(), Some(2));
    }
    let missing = host_trainer(&["inspect", s(&base.join("missing.postcard"))]);
    assert_one_line_error(&missing, &["cannot read blob", "missing.postcard"]);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Regression: a run killed before its first checkpoint could not be resumed.
/// Killed even before it recorded its plant (only `config.toml` written), `--resume` starts it
/// again from the config and the task it names.
#[test]
fn a_run_with_only_its_config_restarts_on_resume() {
    let base = scratch("config-only");
    assert_ok(&train_smoke(&base, 1, &[]));
    let run = base.join("nav-walls__dcp__3");
    let finished = std::fs::read(run.join("policy.postcard")).expect("blob");
    for file in [
        "checkpoint.postcard",
        "scenario.toml",
        "policy.postcard",
        "eval.json",
    ] {
        std::fs::remove_file(run.join(file)).expect("remove");
    }
    let out = host_trainer(&["train", "--resume", s(&run), "--quiet"]);
    assert_ok(&out);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("starting it again"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let again = std::fs::read(run.join("policy.postcard")).expect("blob again");
    assert_eq!(again, finished, "the restarted run is the same run");
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `train --algo ppo|dqn` runs end to end through the CLI like DCP and DDPG: a run folder, the
/// end-of-training firmware-sim evaluation and `eval.json`, a policy blob of the right kind, no
/// critic blob; `export` and `inspect` work on it.
#[test]
fn ppo_and_dqn_train_end_to_end_through_the_cli() {
    let base = scratch("ppo-dqn-cli");
    for (algo, kind) in [(Algo::Ppo, "actor"), (Algo::Dqn, "discrete policy")] {
        let config = smoke_config_file_of(&base, algo, 4);
        let out = host_trainer(&[
            "train",
            "--config",
            s(&config),
            "--out",
            s(&base),
            "--quiet",
        ]);
        assert_ok(&out);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("5 test starts"), "{algo}: {stdout}");
        let run = base.join(format!("nav-walls__{algo}__3"));
        let files = entries(&run);
        for name in [
            "checkpoint.postcard",
            "config.toml",
            "eval.json",
            "learning-curve.svg",
            "metrics.csv",
            "policy.postcard",
            "scenario.toml",
        ] {
            assert!(files.contains(&name.to_string()), "{algo}: {files:?}");
        }
        assert!(!files.contains(&"critic.postcard".to_string()), "{files:?}");
        let inspect = host_trainer(&["inspect", s(&run.join("policy.postcard"))]);
        assert_ok(&inspect);
        let text = String::from_utf8_lossy(&inspect.stdout);
        assert!(text.starts_with(&format!("kind        {kind}\n")), "{text}");
        if algo == Algo::Dqn {
            // `act` names a discrete policy's choice, the one policy-core's argmax makes.
            let bytes = std::fs::read(run.join("policy.postcard")).expect("blob");
            let model = policy_core::model::Model::from_blob(&bytes).expect("boots");
            let mut work = vec![0.0f32; model.scratch_floats()];
            let choice = model.choose_in(&[1.0, 2.0], &mut work).expect("choose");
            let act = host_trainer(&[
                "act",
                "--blob",
                s(&run.join("policy.postcard")),
                "--obs",
                "1,2",
            ]);
            assert_ok(&act);
            let line = String::from_utf8_lossy(&act.stdout);
            assert!(line.contains(&format!(" choice {choice} q ")), "{line}");
            // The rows' Q bits, whose argmax is the choice.
            let bits = line
                .rsplit_once('[')
                .expect("q bits")
                .1
                .trim_end_matches("]\n");
            let q: Vec<f32> = bits
                .split(' ')
                .map(|b| f32::from_bits(u32::from_str_radix(b, 16).expect("hex")))
                .collect();
            assert_eq!(q.len(), usize::from(model.header().shape.choices), "{line}");
            assert_eq!(policy_core::model::argmax(&q), choice, "{line}");
        }
        let export = host_trainer(&["export", "--run", s(&run)]);
        assert_ok(&export);
        let said = String::from_utf8_lossy(&export.stdout);
        assert!(
            said.contains("policy.postcard") && !said.contains("critic"),
            "{said}"
        );
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `export --encoding f16|int8` writes the quantised policy beside the f32 one; it boots in
/// firmware-sim (`eval`), `inspect` names its encoding and, `--against` the f32 blob, each
/// layer's largest weight error; an unknown encoding is a one-line error that writes nothing.
#[test]
fn quantised_exports_inspect_and_evaluate() {
    let base = scratch("quantised-export");
    assert_ok(&train_smoke(&base, 2, &[]));
    let run = base.join("nav-walls__dcp__3");
    let f32 = run.join("policy.postcard");
    for (encoding, version) in [("f16", "3"), ("int8", "3")] {
        let out = host_trainer(&["export", "--run", s(&run), "--encoding", encoding]);
        assert_ok(&out);
        let file = run.join(format!("policy-{encoding}.postcard"));
        assert!(file.is_file(), "{encoding}: {:?}", entries(&run));
        let inspect = host_trainer(&["inspect", s(&file), "--against", s(&f32)]);
        assert_ok(&inspect);
        let text = String::from_utf8_lossy(&inspect.stdout);
        assert!(
            text.contains(&format!("encoding    {encoding}\n")),
            "{text}"
        );
        assert!(text.contains(&format!("version     {version}\n")), "{text}");
        assert_eq!(
            text.matches("largest weight error").count(),
            3,
            "2x32: 3 layers\n{text}"
        );
        let eval = host_trainer(&["eval", "--blob", s(&file), "--episodes", "3"]);
        assert_ok(&eval);
    }
    // Against a blob of another kind (the critic): a one-line error, not a comparison.
    let int8 = run.join("policy-int8.postcard");
    let mismatch = host_trainer(&[
        "inspect",
        s(&int8),
        "--against",
        s(&run.join("critic.postcard")),
    ]);
    assert!(!mismatch.status.success());
    let stderr = String::from_utf8_lossy(&mismatch.stderr);
    assert!(
        stderr.contains("cannot compare")
            && stderr.contains("the reference holds a critic and the blob an actor"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let before = entries(&run);
    let bad = host_trainer(&["export", "--run", s(&run), "--encoding", "int4"]);
    assert_one_line_error(&bad, &["int4"]);
    assert_eq!(entries(&run), before, "nothing written");
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `export --encoding integer` calibrates on the observations the policy meets in test episodes
/// and writes policy-integer.postcard (format version 4); `inspect` shows its input map, zero
/// points and multipliers and, `--against` the f32 blob, the action error; it boots in
/// firmware-sim; a calibration of 0 episodes is a one-line error that writes nothing.
#[test]
fn integer_export_calibrates_inspects_and_evaluates() {
    let base = scratch("integer-export");
    assert_ok(&train_smoke(&base, 2, &[]));
    let run = base.join("nav-walls__dcp__3");
    let f32 = run.join("policy.postcard");
    let before = entries(&run);
    let none = host_trainer(&[
        "export",
        "--run",
        s(&run),
        "--encoding",
        "integer",
        "--calibration-episodes",
        "0",
    ]);
    assert_one_line_error(&none, &["calibration-episodes"]);
    assert_eq!(entries(&run), before, "nothing written");
    let out = host_trainer(&[
        "export",
        "--run",
        s(&run),
        "--encoding",
        "integer",
        "--calibration-episodes",
        "3",
    ]);
    assert_ok(&out);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("policy-integer.postcard") && said.contains("from 3 test episodes"),
        "{said}"
    );
    let file = run.join("policy-integer.postcard");
    let inspect = host_trainer(&["inspect", s(&file), "--against", s(&f32)]);
    assert_ok(&inspect);
    let text = String::from_utf8_lossy(&inspect.stdout);
    for expected in [
        "encoding    integer\n",
        "version     4\n",
        "input       scales [",
        "layer 0     2x32, output zero point ",
        "layer 2     32x2, output zero point ",
        "tanh table",
        "actions     over 10000 observations of the normaliser's box",
    ] {
        assert!(text.contains(expected), "{expected:?} in\n{text}");
    }
    let eval = host_trainer(&["eval", "--blob", s(&file), "--episodes", "3"]);
    assert_ok(&eval);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `export --image bin|hex --slot a|b --sequence N [--address A]` writes the slot record beside
/// the policy: the raw image boots in firmware-sim's slot rule (the newer slot runs), the Intel
/// HEX image carries the slot's address; a record that does not fit the slot, or --image
/// without --slot, is a one-line error that writes nothing.
#[test]
fn export_writes_flash_slot_images() {
    use firmware_sim::boot::PlantSizes;
    use firmware_sim::slots::{boot_slots, FIRMWARE_SCRATCH_WIDTH};
    let base = scratch("slot-images");
    assert_ok(&train_smoke(&base, 2, &[]));
    let run = base.join("nav-walls__dcp__3");
    let export = |extra: &[&str]| {
        let mut args = vec!["export", "--run", s(&run)];
        args.extend_from_slice(extra);
        host_trainer(&args)
    };
    assert_ok(&export(&[
        "--image",
        "bin",
        "--slot",
        "a",
        "--sequence",
        "4",
    ]));
    let out = export(&[
        "--encoding",
        "int8",
        "--image",
        "bin",
        "--slot",
        "b",
        "--sequence",
        "5",
    ]);
    assert_ok(&out);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.contains("--base-address 0x00060000"), "{said}");
    let a = std::fs::read(run.join("policy.slot-a.bin")).expect("slot A image");
    let b = std::fs::read(run.join("policy-int8.slot-b.bin")).expect("slot B image");
    let int8 = std::fs::read(run.join("policy-int8.postcard")).expect("int8 policy");
    assert_eq!(b[16..], int8[..], "the record holds the exported blob");
    let f32 = std::fs::read(run.join("policy.postcard")).expect("f32 policy");
    assert_eq!(a[16..], f32[..]);
    let nav = PlantSizes {
        observations: 2,
        actions: 2,
    };
    let boot = boot_slots(&a, &b, &nav, FIRMWARE_SCRATCH_WIDTH).expect("boot");
    assert_eq!(boot.running, Some(policy_core::slot::SlotId::B));
    assert!(boot.controller.name().contains("int8"));

    assert_ok(&export(&[
        "--image",
        "hex",
        "--slot",
        "b",
        "--sequence",
        "6",
        "--address",
        "0x08060000",
    ]));
    let hex = std::fs::read_to_string(run.join("policy.slot-b.hex")).expect("hex image");
    assert!(
        hex.starts_with(":020000040806EC\n:1000000044435053"),
        "{hex}"
    );
    assert!(hex.ends_with(":00000001FF\n"));

    let before = entries(&run);
    let small = export(&[
        "--image",
        "bin",
        "--slot",
        "a",
        "--sequence",
        "7",
        "--slot-size",
        "1024",
    ]);
    assert_one_line_error(&small, &["does not fit its slot"]);
    let no_slot = export(&["--image", "bin", "--sequence", "7"]);
    assert!(!no_slot.status.success());
    let bad_address = export(&[
        "--image",
        "hex",
        "--slot",
        "a",
        "--sequence",
        "1",
        "--address",
        "0xZZ",
    ]);
    assert!(!bad_address.status.success());
    assert!(String::from_utf8_lossy(&bad_address.stderr).contains("0xZZ"));
    // A refused image is refused before anything is written.
    assert_eq!(entries(&run), before, "no new file");
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[test]
fn usage_errors_name_the_missing_arguments_and_the_accepted_values() {
    let base = scratch("usage-errors");
    for (args, needles) in [
        (
            vec![
                "export",
                "--run",
                s(&base),
                "--image",
                "bin",
                "--sequence",
                "1",
            ],
            vec!["--slot"],
        ),
        (vec!["sweep", "--seeds", "0"], vec!["--out"]),
        (
            vec!["export", "--run", s(&base), "--image", "elf"],
            vec!["elf", "bin", "hex"],
        ),
        (vec!["train", "--algo", "foo"], vec!["foo", "dcp", "ppo"]),
    ] {
        let out = host_trainer(&args);
        assert_one_line_error(&out, &needles);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// A run folder killed before its first checkpoint holds only its config: `export` wrote the
/// config's untrained networks as the run's policy and exited 0.
#[test]
fn export_of_a_run_without_a_checkpoint_is_refused() {
    let base = scratch("export-no-checkpoint");
    let run = base.join("run");
    std::fs::create_dir_all(&run).expect("run folder");
    let config = smoke_config_file(&base, 2);
    std::fs::copy(&config, run.join("config.toml")).expect("config");
    let out = host_trainer(&["export", "--run", s(&run)]);
    assert_one_line_error(&out, &["no checkpoint", "nothing to export"]);
    assert_eq!(entries(&run), ["config.toml"]);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `--config` and `--task` files were read whole: `/dev/zero` grew the trainer (and a sweep)
/// to gigabytes before anything was said. A file past the limit, or an endless one, is refused.
#[test]
fn endless_or_huge_config_and_task_files_are_refused_in_one_line() {
    let base = scratch("huge-inputs");
    let huge = base.join("huge.toml");
    let file = std::fs::File::create(&huge).expect("huge file");
    file.set_len(64 << 20).expect("sparse 64 MiB");
    let out_dir = base.join("out");
    std::fs::create_dir_all(&out_dir).expect("out");
    for input in [s(&huge), "/dev/zero"] {
        for args in [
            vec!["train", "--config", input, "--out", s(&out_dir)],
            vec!["train", "--task", input, "--out", s(&out_dir)],
            vec![
                "sweep",
                "--config",
                input,
                "--seeds",
                "1",
                "--out",
                s(&out_dir),
            ],
        ] {
            let out = host_trainer(&args);
            assert_one_line_error(
                &out,
                &["larger than the 1048576 bytes a text input may have"],
            );
        }
    }
    assert!(entries(&out_dir).is_empty(), "{:?}", entries(&out_dir));
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `--image hex` at 0xFFFFFFFF said the slot had 1 byte while `--image bin` at the same address
/// exited 0, and an unaligned slot address was accepted although the payload's alignment depends
/// on it. Both kinds go through one check, and nothing is written.
#[test]
fn slot_addresses_are_checked_the_same_way_for_bin_and_hex() {
    let base = scratch("slot-address");
    assert_ok(&train_smoke(&base, 1, &[]));
    let run = base.join("nav-walls__dcp__3");
    let before = entries(&run);
    for image in ["bin", "hex"] {
        for (address, needle) in [
            ("0xFFFFFFFF", "multiple of 4"),
            ("0xFFFFFFF0", "room for"),
            ("0x40001", "multiple of 4"),
        ] {
            let out = host_trainer(&[
                "export",
                "--run",
                s(&run),
                "--image",
                image,
                "--slot",
                "a",
                "--sequence",
                "1",
                "--address",
                address,
            ]);
            assert_one_line_error(&out, &[needle]);
        }
    }
    assert_eq!(entries(&run), before);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `train --resume R --episodes N` below the checkpoint's episode exited 0 as "trained", and
/// above it left `config.toml` at the old budget, so a sweep of the old budget counted the
/// longer run as its own. A lower budget is refused; a higher one is recorded, and the sweep
/// sees it.
#[test]
fn resume_with_episodes_records_the_new_budget_and_refuses_a_smaller_one() {
    let base = scratch("resume-budget");
    assert_ok(&train_smoke(&base, 2, &[]));
    let run = base.join("nav-walls__dcp__3");
    let out = host_trainer(&["train", "--resume", s(&run), "--episodes", "1", "--quiet"]);
    assert_one_line_error(&out, &["--episodes", "at least the 2 episodes"]);
    let out = host_trainer(&["train", "--resume", s(&run), "--episodes", "3", "--quiet"]);
    assert_ok(&out);
    let recorded = std::fs::read_to_string(run.join("config.toml")).expect("config");
    assert!(recorded.contains("episodes = 3"), "{recorded}");
    let config = smoke_config_file(&base, 2);
    let out = host_trainer(&[
        "sweep",
        "--config",
        s(&config),
        "--seeds",
        "3",
        "--out",
        s(&base),
        "--quiet",
    ]);
    assert_one_line_error(&out, &["episodes = 3 recorded, 2 in the sweep"]);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `--algo dqn|ppo` with `--sigma`, `--noise`, `--t` or `--dropout`, and `--algo ddpg --t`,
/// were recorded in `config.toml` and changed nothing. A flag the algorithm ignores is refused,
/// naming the algorithms that use it, and nothing is written.
#[test]
fn flags_the_algorithm_does_not_use_are_refused() {
    let base = scratch("unused-flags");
    for algo in ["dqn", "ppo"] {
        for (flag, value, users) in [
            ("--sigma", "0.9", "dcp, ddpg, td3"),
            ("--noise", "ou", "dcp, ddpg, td3"),
            ("--t", "3", "dcp"),
            ("--dropout", "0.5", "dcp, ddpg, td3"),
        ] {
            let out = host_trainer(&[
                "train",
                "--algo",
                algo,
                flag,
                value,
                "--out",
                s(&base),
                "--episodes",
                "1",
            ]);
            assert_one_line_error(&out, &[flag, algo, users]);
        }
    }
    let out = host_trainer(&[
        "train",
        "--algo",
        "ddpg",
        "--t",
        "100000",
        "--out",
        s(&base),
        "--episodes",
        "1",
    ]);
    assert_one_line_error(&out, &["--t", "ddpg", "only by dcp"]);
    assert!(entries(&base).is_empty(), "{:?}", entries(&base));
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `inspect X --against critic.postcard` read backwards ("expected critic, found actor") and
/// spoke of a compiled shape; a quantised reference was accepted. Each names what the
/// reference must be: the f32 blob of the same model.
#[test]
fn inspect_against_names_what_the_reference_must_be() {
    let base = scratch("inspect-against");
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("../policy-core/tests/golden");
    let (actor, critic) = (
        golden.join("actor_2x32.postcard"),
        golden.join("critic_2x32.postcard"),
    );
    let int8 = base.join("actor-int8.postcard");
    let bytes = std::fs::read(&actor).expect("golden actor");
    let encoded = host_trainer::blob::export::encode(&bytes, policy_core::Encoding::Int8);
    std::fs::write(&int8, encoded.expect("encodes")).expect("write");
    let wide = golden.join("actor_4x48.postcard");
    let cases: [(&Path, &Path, &[&str]); 3] = [
        (
            &int8,
            &critic,
            &["the reference holds a critic and the blob an actor"],
        ),
        (&int8, &int8, &["the reference is int8-encoded"]),
        (
            &int8,
            &wide,
            &["the reference's network is", "and the blob's"],
        ),
    ];
    for (blob, reference, needles) in cases {
        let out = host_trainer(&["inspect", s(blob), "--against", s(reference)]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{stderr}");
        assert!(stderr.contains("--against takes the f32 blob"), "{stderr}");
        assert!(!stderr.contains("compiled for"), "{stderr}");
        for n in needles {
            assert!(stderr.contains(n), "{n}: {stderr}");
        }
    }
    assert_ok(&host_trainer(&[
        "inspect",
        s(&int8),
        "--against",
        s(&actor),
    ]));
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// A config file's section for another algorithm was recorded and changed nothing, like the
/// flags above. A setting away from its default that the run's algorithm does not read is
/// refused by `train` naming its key and readers; a sweep accepts it when one of its algorithms
/// reads it, and each run records its own algorithm's settings only.
#[test]
fn config_settings_the_algorithm_does_not_read_are_refused() {
    let base = scratch("unread-settings");
    let mut config = TrainConfig::smoke(Algo::Ddpg, 3);
    config.dcp.t = 7;
    let file = base.join("ddpg-with-dcp.toml");
    std::fs::write(&file, config.to_toml()).expect("config");
    let train = host_trainer(&["train", "--config", s(&file), "--out", s(&base)]);
    assert_one_line_error(&train, &["dcp.t = 7", "not used by ddpg", "only by dcp"]);
    let sweep = host_trainer(&[
        "sweep",
        "--config",
        s(&file),
        "--seeds",
        "0",
        "--out",
        s(&base),
    ]);
    assert_one_line_error(&sweep, &["dcp.t = 7", "not used by ddpg", "only by dcp"]);
    // TD3's smoothing σ is DCP's too; its policy delay is TD3's alone.
    config.dcp.t = TrainConfig::default().dcp.t;
    config.td3.policy_delay = 3;
    std::fs::write(&file, config.to_toml()).expect("config");
    let train = host_trainer(&[
        "train",
        "--config",
        s(&file),
        "--algo",
        "dcp",
        "--out",
        s(&base),
    ]);
    assert_one_line_error(&train, &["td3.policy_delay = 3", "only by td3"]);
    // The sweep's folder lock is all that was added.
    assert_eq!(
        entries(&base),
        [".host-trainer.lock", "ddpg-with-dcp.toml"],
        "nothing written"
    );

    // One sweep of DDPG and TD3: the delay is TD3's, the DDPG runs record the default.
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let sweep = || {
        host_trainer(&[
            "sweep",
            "--config",
            s(&file),
            "--algo",
            "ddpg,td3",
            "--seeds",
            "0",
            "--out",
            s(&out),
            "--quiet",
        ])
    };
    assert_ok(&sweep());
    let recorded = |algo: &str| {
        TrainConfig::from_file(&out.join(format!("nav-walls__{algo}__0/config.toml")))
            .expect("recorded config")
    };
    assert_eq!(recorded("td3").td3.policy_delay, 3);
    assert_eq!(
        recorded("ddpg").td3.policy_delay,
        TrainConfig::default().td3.policy_delay
    );
    // Run again, the same sweep finds both runs finished (the recorded DDPG config is its own).
    let again = sweep();
    assert_ok(&again);
    assert_eq!(
        String::from_utf8_lossy(&again.stdout)
            .matches("skipped")
            .count(),
        2
    );
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Two sweeps on one `--out` both ran, marking each other's runs failed or resuming runs the
/// other was still training; a trainer could start in a folder another was writing. A folder
/// has one writer: a second is refused naming the holder's pid, and nothing is touched.
#[test]
fn a_second_writer_of_a_locked_sweep_or_run_folder_is_refused() {
    let base = scratch("folder-lock");
    assert_ok(&train_smoke(&base, 1, &[]));
    let run = base.join("nav-walls__dcp__3");
    let config = smoke_config_file(&base, 1);
    let before = std::fs::read(run.join("checkpoint.postcard")).expect("checkpoint");
    let pid = std::process::id().to_string();
    {
        // This test process stands for a running sweep, then for a running trainer.
        let _sweep = host_trainer::run::lock::acquire(&base).expect("lock the sweep folder");
        let out = host_trainer(&[
            "sweep",
            "--config",
            s(&config),
            "--seeds",
            "3",
            "--out",
            s(&base),
            "--quiet",
        ]);
        assert_one_line_error(&out, &["in use by host-trainer process", &pid]);
    }
    {
        let _trainer = host_trainer::run::lock::acquire(&run).expect("lock the run folder");
        for args in [
            vec!["train", "--resume", s(&run), "--episodes", "2", "--quiet"],
            vec!["export", "--run", s(&run)],
        ] {
            let out = host_trainer(&args);
            assert_one_line_error(&out, &["in use by host-trainer process", &pid]);
        }
    }
    assert_eq!(
        std::fs::read(run.join("checkpoint.postcard")).expect("kept"),
        before
    );
    assert!(!base.join("sweep.md").exists());
    // Released (as when its holder dies), the lock is taken over.
    assert_ok(&host_trainer(&["export", "--run", s(&run)]));
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// More worker threads than cores is allowed (the same bytes, only slower) and said once; the
/// thread count is not part of the run: its `config.toml` does not record it.
#[test]
fn more_threads_than_cores_is_said_once_and_not_recorded() {
    let base = scratch("threads-note");
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = (cores + 1).to_string();
    let out = train_smoke(&base, 1, &["--threads", &threads]);
    assert_ok(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let notes = stderr
        .matches(&format!("--threads {threads} is more than the"))
        .count();
    assert_eq!(notes, 1, "{stderr}");
    let config = base.join("nav-walls__dcp__3").join("config.toml");
    let config = std::fs::read_to_string(config).expect("config.toml");
    assert!(!config.contains("threads"), "{config}");
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[test]
fn a_reader_that_goes_away_ends_inspect_quietly() {
    // `host-trainer inspect BLOB | head -1`: the pipe closes before the listing is written.
    // The read end is closed before the process starts (closing it after the spawn raced with
    // the listing, which a loaded machine let through into the pipe's buffer).
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_host-trainer"))
        .args(["inspect", "models/nav-walls__dcp-paper__0.postcard"])
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.code(), Some(141), "{err}");
}

#[test]
fn keep_checkpoints_keeps_a_copy_of_each_and_changes_no_bit() {
    let (with, without) = (scratch("keep-ckpt-a"), scratch("keep-ckpt-b"));
    assert_ok(&train_smoke(&with, 3, &["--keep-checkpoints"]));
    assert_ok(&train_smoke(&without, 3, &[]));
    let run = |base: &Path| base.join("nav-walls__dcp__3");
    // (The checkpoints themselves hold each episode's wall-clock speed, so they differ.)
    for file in [folder::POLICY, folder::CRITIC] {
        let a = std::fs::read(run(&with).join(file)).expect("with");
        assert!(
            a == std::fs::read(run(&without).join(file)).expect("without"),
            "{file}"
        );
    }
    // The smoke config checkpoints every 2 episodes, and at the start and the end.
    let kept = run(&with).join(folder::KEPT_CHECKPOINTS);
    assert_eq!(
        entries(&kept),
        [
            "episode-0000000.postcard",
            "episode-0000002.postcard",
            "episode-0000003.postcard"
        ]
    );
    let last = std::fs::read(kept.join("episode-0000003.postcard")).expect("kept");
    assert!(last == std::fs::read(run(&with).join(folder::CHECKPOINT)).expect("checkpoint"));
    let second = Checkpoint::load(&kept.join("episode-0000002.postcard")).expect("loads");
    assert_eq!(second.episode, 2);
    assert!(!run(&without).join(folder::KEPT_CHECKPOINTS).exists());
    for base in [with, without] {
        std::fs::remove_dir_all(&base).expect("cleanup");
    }
}

/// `team` refuses a team of 0 or 1 player, a budget of 0 points, DQN, a missing output folder,
/// an unknown scenario and a resume of a folder holding no team, in one line, writing nothing;
/// a tiny team trains, exports its players and refuses to be created twice.
#[test]
fn team_bad_input_is_one_line_and_writes_nothing() {
    let out_dir = scratch("team-cli");
    let dir = out_dir.to_str().expect("utf-8");
    for (args, needle) in [
        (vec!["--players", "1"], "players"),
        (vec!["--players", "0"], "players"),
        (vec!["--points", "0"], "points"),
        (vec!["--algo", "dqn"], "dqn"),
        (vec!["--scenario", "no-such-court.toml"], "no-such-court"),
    ] {
        let mut all = vec!["team", "--out", dir, "--quiet"];
        all.extend(args);
        let out = host_trainer(&all);
        assert_one_line_error(&out, &[needle]);
        assert!(entries(&out_dir).is_empty(), "{all:?} wrote something");
    }
    let missing = out_dir.join("missing").join("deeper");
    let out = host_trainer(&["team", "--out", missing.to_str().expect("utf-8")]);
    assert_one_line_error(&out, &["does not exist"]);
    let out = host_trainer(&["team", "--resume", dir]);
    assert_one_line_error(&out, &["checkpoint"]);

    let tiny = [
        "team",
        "--players",
        "2",
        "--points",
        "6",
        "--out",
        dir,
        "--quiet",
    ];
    assert_ok(&host_trainer(&tiny));
    let player = out_dir.join("badminton__dcp-t16__0/players/p01/player.toml");
    assert!(player.is_file(), "{player:?}");
    let again = host_trainer(&tiny);
    assert_one_line_error(&again, &["already holds a run"]);
    std::fs::remove_dir_all(&out_dir).expect("cleanup");
}

/// `team --resume OUTDIR` (the `--out` folder, not the team folder inside it) gave the system's
/// raw missing-file error on OUTDIR/checkpoint.postcard; it names the team folder to give.
#[test]
fn team_resume_of_the_out_folder_names_the_team_inside() {
    let out_dir = scratch("team-resume-out");
    let dir = out_dir.to_str().expect("utf-8");
    let out = host_trainer(&["team", "--resume", dir]);
    assert_one_line_error(
        &out,
        &[
            "no team checkpoint (checkpoint.postcard)",
            "not a team folder",
        ],
    );
    let tiny = [
        "team",
        "--players",
        "2",
        "--points",
        "4",
        "--out",
        dir,
        "--quiet",
    ];
    assert_ok(&host_trainer(&tiny));
    let team = out_dir.join("badminton__dcp-t16__0");
    let out = host_trainer(&["team", "--resume", dir]);
    assert_one_line_error(
        &out,
        &[&format!(
            "it holds the team folder {}; resume with --resume {}",
            team.display(),
            team.display()
        )],
    );
    assert!(!String::from_utf8_lossy(&out.stderr).contains("os error"));
    std::fs::remove_dir_all(&out_dir).expect("cleanup");
}

/// `--threads` had no upper bound: 100,000 started threads one by one for over a minute. Above
/// the cap (1024, the same on every machine) it is refused when the command line is parsed,
/// in one line naming the range, before anything starts or is written.
#[test]
fn threads_above_the_cap_are_refused_at_parse_time() {
    let out_dir = scratch("threads-cap");
    let dir = out_dir.to_str().expect("utf-8");
    let started = std::time::Instant::now();
    let out = host_trainer(&[
        "train",
        "--threads",
        "100000",
        "--out",
        dir,
        "--episodes",
        "1",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_one_line_error(&out, &["100000", "1024"]);
    assert!(started.elapsed().as_secs() < 10, "{:?}", started.elapsed());
    assert!(entries(&out_dir).is_empty());
    let out = host_trainer(&[
        "train",
        "--threads",
        "1025",
        "--out",
        dir,
        "--episodes",
        "1",
    ]);
    assert_one_line_error(&out, &["1025"]);
    std::fs::remove_dir_all(&out_dir).expect("cleanup");
}

/// `team` accepted what `train` refuses: `--algo ddpg --t 4` recorded `dcp.t = 4` in the team's
/// config (a setting nothing reads), and `--resume --points` below the points already played
/// marked the team finished past its budget. Both are one line now, as in `train`.
#[test]
fn team_refuses_an_unread_t_and_a_budget_below_its_checkpoint() {
    let out_dir = scratch("team-as-train");
    let dir = out_dir.to_str().expect("utf-8");
    let out = host_trainer(&[
        "team", "--algo", "ddpg", "--t", "4", "--out", dir, "--quiet",
    ]);
    assert_one_line_error(&out, &["--t", "ddpg", "dcp"]);
    assert!(entries(&out_dir).is_empty(), "nothing written");

    let tiny = [
        "team",
        "--players",
        "2",
        "--points",
        "6",
        "--out",
        dir,
        "--quiet",
    ];
    assert_ok(&host_trainer(&tiny));
    let team = out_dir.join("badminton__dcp-t16__0");
    let config = std::fs::read_to_string(team.join("config.toml")).expect("config");
    let out = host_trainer(&["team", "--resume", s(&team), "--points", "3", "--quiet"]);
    assert_one_line_error(&out, &["--points", "at least the 6 points", "3"]);
    assert_eq!(
        std::fs::read_to_string(team.join("config.toml")).expect("config"),
        config,
        "the budget is not changed"
    );
    std::fs::remove_dir_all(&out_dir).expect("cleanup");
}

/// The README's first command (`train --out /tmp/runs`) failed on a fresh machine, and
/// `reproduce` wanted its `--out` made first while `train` made its run folder: `train`,
/// `sweep`, `reproduce` and `team` now make a missing output folder whose parent exists (a
/// mistyped parent is still refused); `--out FILE` says "not a folder", not `Not a directory
/// (os error 20)`.
#[test]
fn a_missing_output_folder_is_created_and_a_file_is_not_a_folder() {
    let base = scratch("out-created");
    let config = smoke_config_file(&base, 1);
    let c = s(&config);
    let made = |name: &str| base.join(name);
    let (m, r) = (made("m"), made("r"));
    assert_ok(&host_trainer(&[
        "train",
        "--config",
        c,
        "--out",
        s(&made("t")),
        "--quiet",
    ]));
    assert_eq!(entries(&made("t")).len(), 1, "the run's folder");
    assert_ok(&host_trainer(&[
        "sweep",
        "--config",
        c,
        "--seeds",
        "0",
        "--out",
        s(&made("s")),
        "--quiet",
    ]));
    assert!(made("s/sweep.md").is_file());
    let team = [
        "team",
        "--players",
        "2",
        "--points",
        "6",
        "--out",
        s(&m),
        "--quiet",
    ];
    assert_ok(&host_trainer(&team));
    assert!(made("m/badminton__dcp-t16__0").is_dir());
    let part = [
        "reproduce",
        "exp1",
        "--quick",
        "--seeds",
        "1",
        "--slice",
        "0/56",
        "--out",
        s(&r),
        "--quiet",
    ];
    let o = host_trainer(&part);
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(1),
        "{o:?}"
    );
    assert!(made("r/grid.json").is_file());

    let deeper = made("no/such");
    let out = host_trainer(&["train", "--config", c, "--out", s(&deeper), "--quiet"]);
    assert_one_line_error(&out, &["does not exist", "holds it"]);
    assert!(!made("no").exists());

    let file = made("file");
    std::fs::write(&file, "").expect("file");
    for args in [
        vec![
            "reproduce",
            "exp1",
            "--quick",
            "--seeds",
            "1",
            "--out",
            s(&file),
        ],
        vec![
            "reproduce",
            "exp1",
            "--quick",
            "--seeds",
            "1",
            "--merge",
            "--out",
            s(&file),
        ],
        vec!["team", "--out", s(&file), "--quiet"],
    ] {
        let out = host_trainer(&args);
        let stderr = assert_one_line_error(&out, &["not a folder"]);
        assert!(!stderr.contains("os error"), "{stderr}");
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `--keep-checkpoints` over a run whose `checkpoints` is a file failed with `File exists (os
/// error 17)` at the first checkpoint; it is refused by name before anything is written.
#[test]
fn keep_checkpoints_over_a_file_named_checkpoints_is_not_a_folder() {
    let base = scratch("keep-ckpt-file");
    assert_ok(&train_smoke(&base, 2, &[]));
    let run = base.join("nav-walls__dcp__3");
    std::fs::write(run.join(folder::KEPT_CHECKPOINTS), "in the way").expect("file");
    let out = host_trainer(&[
        "train",
        "--resume",
        s(&run),
        "--episodes",
        "3",
        "--keep-checkpoints",
        "--quiet",
    ]);
    let stderr = assert_one_line_error(&out, &["checkpoints", "not a folder"]);
    assert!(!stderr.contains("os error"), "{stderr}");
    let config = std::fs::read_to_string(run.join(folder::CONFIG)).expect("config");
    assert!(
        config.contains("episodes = 2"),
        "the budget is unchanged:\n{config}"
    );
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `train --resume`'s summary counted only the resumed part's environment steps as if they
/// were the run's: it gives the run's total (the checkpoint's) and says how many were this
/// part's.
#[test]
fn the_summary_after_resume_gives_the_runs_total_steps_and_this_parts() {
    let base = scratch("resume-summary");
    assert_ok(&train_smoke(&base, 2, &[]));
    let run = base.join("nav-walls__dcp__3");
    let before = Checkpoint::load(&run.join(folder::CHECKPOINT)).expect("checkpoint");
    let out = host_trainer(&["train", "--resume", s(&run), "--episodes", "4", "--quiet"]);
    assert_ok(&out);
    let after = Checkpoint::load(&run.join(folder::CHECKPOINT)).expect("checkpoint");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let part = after.total_steps - before.total_steps;
    assert!(
        stdout.contains(&format!(
            "(4 episodes, {} env steps in all; this part: 2 episodes, {part} env steps in",
            after.total_steps
        )),
        "{stdout}"
    );
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// docs/cortex-m.md exported slot A as Intel HEX, then checked `policy.slot-a.bin` in
/// firmware-sim, which no step had written. The page's steps run here in order: each export
/// command as written, and every image a later step checks, flashes or loads must exist by
/// then (slot records that verify, for the raw ones).
#[test]
fn the_cortex_m_pages_slot_steps_write_every_image_they_use() {
    let page = include_str!("../../docs/cortex-m.md");
    let start = page
        .find("**2. A policy, any number of times.**")
        .expect("step 2");
    let end = page[start..]
        .find("Any blob up to 64 wide")
        .expect("the end of the steps");
    let work = scratch("cortex-m-steps");
    let runs = work.join("runs");
    std::fs::create_dir_all(&runs).expect("runs");
    for seed in ["0", "1"] {
        let out = host_trainer(&[
            "train",
            "--episodes",
            "2",
            "--seed",
            seed,
            "--out",
            runs.to_str().expect("utf-8"),
            "--quiet",
        ]);
        assert_ok(&out);
    }
    let exists = |file: &str, step: &str| {
        let path = work.join(file);
        assert!(
            path.is_file(),
            "{step}: {file} was not written by an earlier step"
        );
        if file.ends_with(".bin") {
            let image = std::fs::read(&path).expect("image");
            policy_core::slot::read(&image).expect("a slot record");
        }
    };
    let (mut exports, mut uses) = (0, 0);
    let text = page[start..start + end].replace("\\\n", " ");
    for line in text.lines().map(str::trim) {
        let words: Vec<&str> = line.split_whitespace().collect();
        if let Some(args) = line.strip_prefix("cargo run --release -- export ") {
            let args: Vec<&str> = std::iter::once("export")
                .chain(args.split_whitespace())
                .collect();
            let out = command(&args).current_dir(&work).output().expect("runs");
            assert_ok(&out);
            exports += 1;
        } else if line.contains("firmware-sim -- run") {
            for flag in ["--slot-a", "--slot-b"] {
                let at = words.iter().position(|w| *w == flag).expect(flag);
                exists(words[at + 1], line);
                uses += 1;
            }
        } else if line.starts_with("probe-rs download") {
            exists(words.last().expect("a file"), line);
            uses += 1;
        } else if line.contains("loader,file=") {
            for part in line.split("loader,file=").skip(1) {
                let file = part.split([',', ' ']).next().expect("a file");
                exists(file, line);
                uses += 1;
            }
        }
    }
    assert_eq!((exports, uses), (5, 6), "the steps the page holds");
    std::fs::remove_dir_all(&work).expect("cleanup");
}

/// `act` prints what policy-core computes, bit for bit, for an actor and a critic, from flags
/// and from a file; a wrong count or a non-number is one line naming the input, before any
/// output.
#[test]
fn act_prints_the_chips_outputs_bit_for_bit() {
    use policy_core::model::Model;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let actor = root.join("models/nav-walls__dcp-paper__0.postcard");
    let critic = root.join("models/nav-walls__dcp-paper__0__actor-critic/critic.postcard");
    let inputs: [[f32; 2]; 5] = [
        [4.0, -2.5],
        [0.0, 0.0],
        [f32::NAN, f32::INFINITY],
        [-1e30, 5.75],
        [-0.0, 1e-40],
    ];
    let bytes = std::fs::read(&actor).expect("actor");
    let model = Model::from_blob(&bytes).expect("boots");
    let base = scratch("act");
    let file = base.join("inputs.txt");
    let mut text = String::from("# observations, one per line\n\n");
    for i in &inputs {
        text.push_str(&format!("{} {}  # a comment\n", i[0], i[1]));
    }
    std::fs::write(&file, text).expect("inputs");
    let out = host_trainer(&["act", "--blob", s(&actor), "--obs-file", s(&file)]);
    assert_ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), inputs.len(), "{stdout}");
    for (i, line) in inputs.iter().zip(&lines) {
        let mut action = [0.0f32; 2];
        let mut work = vec![0.0f32; model.scratch_floats()];
        model.act_in(i, &mut work, &mut action).expect("acts");
        let bits = format!("[{:08x} {:08x}]", action[0].to_bits(), action[1].to_bits());
        assert!(
            line.ends_with(&bits),
            "{i:?}: {line} should end with {bits}"
        );
    }
    let bytes = std::fs::read(&critic).expect("critic");
    let q = Model::from_blob(&bytes).expect("boots");
    let mut work = vec![0.0f32; q.scratch_floats()];
    let value = q.q_in(&[4.0, -2.5], &[0.5, -0.5], &mut work).expect("q");
    let out = host_trainer(&["act", "--blob", s(&critic), "--obs", "4,-2.5,0.5,-0.5"]);
    assert_ok(&out);
    assert!(
        String::from_utf8_lossy(&out.stdout).ends_with(&format!("[{:08x}]\n", value.to_bits())),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let bad = host_trainer(&["act", "--blob", s(&actor), "--obs", "1,2", "--obs", "1,2,3"]);
    assert_one_line_error(&bad, &["--obs 2", "3 values", "takes 2"]);
    assert!(bad.stdout.is_empty(), "no half output");
    let bad = host_trainer(&["act", "--blob", s(&actor), "--obs", "1,two"]);
    assert_one_line_error(&bad, &["--obs 1", "\"two\" is not a number"]);
    let none = host_trainer(&["act", "--blob", s(&actor)]);
    assert_one_line_error(&none, &["no input"]);
    let _ = std::fs::remove_dir_all(&base);
}
