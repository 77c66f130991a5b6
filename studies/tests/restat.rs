use std::path::{Path, PathBuf};

use crate::study;

const BIN: &str = env!("CARGO_BIN_EXE_restat");

/// The repository root, where the pages and their rows live.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate lives in the workspace")
        .to_path_buf()
}

#[test]
fn every_page_is_what_its_rows_give() {
    let out = study(BIN, &["--check"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.matches(": up to date").count(), 8, "{text}");
}

/// A copy of the dcp-vs-ddpg page and its rows in a scratch root, for a check to fail on.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("restat-{name}-{}", std::process::id()));
    for file in [
        "docs/results/dcp-vs-ddpg.md",
        "experiments/dcp-vs-ddpg/per-seed.tsv",
    ] {
        let to = dir.join(file);
        std::fs::create_dir_all(to.parent().expect("a folder")).expect("folders");
        std::fs::copy(root().join(file), &to).expect("copy");
    }
    dir
}

fn check_in(dir: &Path) -> (bool, String) {
    let out = std::process::Command::new(BIN)
        .args(["--check", "dcp-vs-ddpg"])
        .current_dir(dir)
        .output()
        .expect("restat runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_figure_edited_by_hand_fails_the_check() {
    let dir = scratch("edited");
    let page = dir.join("docs/results/dcp-vs-ddpg.md");
    let text = std::fs::read_to_string(&page).expect("page");
    let section = text
        .find("**Means over the 5 seeds**")
        .expect("the section's table");
    let edited = format!(
        "{}{}",
        &text[..section],
        text[section..].replacen("0.85 [", "0.86 [", 1)
    );
    std::fs::write(&page, edited).expect("write");
    let (ok, err) = check_in(&dir);
    assert!(
        !ok && err.contains("differs from what its rows give"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

#[test]
fn a_row_the_page_does_not_show_fails_the_check() {
    let dir = scratch("row");
    let rows = dir.join("experiments/dcp-vs-ddpg/per-seed.tsv");
    let text = std::fs::read_to_string(&rows).expect("rows");
    std::fs::write(&rows, text.replacen("0.106", "0.107", 1)).expect("write");
    let (ok, err) = check_in(&dir);
    assert!(
        !ok && err.contains("is not on docs/results/dcp-vs-ddpg.md"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

#[test]
fn writing_needs_the_commit_it_names() {
    let out = study(BIN, &["dcp-vs-ddpg"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("restat: usage"), "{err}");
    let out = study(BIN, &["no-such-page", "--check"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("no page \"no-such-page\""),
        "{err}"
    );
}
