//! The `host-trainer` binary on bad input: one clear line on stderr, a non-zero exit, no panic,
//! and no partial files.

use std::path::{Path, PathBuf};

use crate::support::{assert_one_line_error, entries, host_trainer, scratch};

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
        ("--hidden", "5x40", "unsupported"),
        ("--sigma", "nan", "sigma"),
        ("--t", "0", "dcp.t"),
        ("--task", "nav-nowhere", "nav-nowhere"),
        ("--reward", "best", "best"),
        ("--noise", "brownian", "brownian"),
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
