//! `scripts/runs-archive.sh`, the script that carries a `reproduce` grid's runs between
//! machines: archives that must not be trusted, and the refusals they get. Archives are built
//! with `tar` in a scratch folder; the script runs under `bash` as a user would run it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::support::scratch;

/// The script, from the repository root.
fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/runs-archive.sh")
}

/// Runs the script with `args` to the end.
fn runs_archive(args: &[&Path]) -> Output {
    Command::new("bash")
        .arg(script())
        .args(args)
        .output()
        .expect("bash runs")
}

/// Packs `members` of `from` (names relative to it, kept as they are) into `archive` with xz.
fn pack(from: &Path, archive: &Path, members: &[&str]) {
    let status = Command::new("tar")
        .arg("-cJf")
        .arg(archive)
        .arg("-C")
        .arg(from)
        .args(members)
        .status()
        .expect("tar runs");
    assert!(status.success(), "tar packs {members:?}");
}

/// Asserts the script failed with exit 1 and one line on stderr naming every `needle`.
fn assert_refused(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line:\n{stderr}");
    assert!(stderr.starts_with("runs-archive: "), "{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "stderr should name {n:?}: {stderr}");
    }
}

/// A restore must not write outside OUT through a symbolic link an earlier archive planted:
/// `001.tar.xz` holding `runs -> VICTIM` (absolute) or `parts -> ../../VICTIM` (relative) and
/// `002.tar.xz` holding `runs/x` or `parts/x` once wrote `VICTIM/x` and exited 0. Every member
/// is checked before anything is unpacked, and the refusal names the archive and the member.
#[test]
fn restore_refuses_a_symbolic_link_member() {
    let dir = scratch("archive-symlink");
    let victim = dir.join("victim");
    std::fs::create_dir(&victim).expect("scratch files");
    for (link, target) in [
        ("runs", victim.clone()),
        ("parts", PathBuf::from("../../victim")),
    ] {
        let (first, second, archives) = (
            dir.join(format!("{link}-1")),
            dir.join(format!("{link}-2")),
            dir.join(format!("{link}-archives")),
        );
        for d in [&first, &second.join(link), &archives] {
            std::fs::create_dir_all(d).expect("scratch files");
        }
        std::fs::write(first.join("grid.json"), "{}").expect("scratch files");
        std::os::unix::fs::symlink(&target, first.join(link)).expect("scratch files");
        pack(&first, &archives.join("001.tar.xz"), &["grid.json", link]);
        std::fs::write(second.join(link).join("x"), "planted").expect("scratch files");
        pack(
            &second,
            &archives.join("002.tar.xz"),
            &[&format!("{link}/x")],
        );

        let out = dir.join(format!("{link}-restored"));
        let result = runs_archive(&[Path::new("restore"), &archives, &out]);
        assert_refused(&result, &["001.tar.xz", "symbolic link", link]);
        assert!(!out.exists(), "nothing restored");
        assert!(
            std::fs::read_dir(&victim)
                .expect("scratch files")
                .next()
                .is_none(),
            "nothing written through the link"
        );
    }
    std::fs::remove_dir_all(&dir).expect("scratch files");
}

/// Hard links and fifos have no place in a run either: refused by name like a symbolic link
/// (a hard link could name a file an earlier archive made a link), nothing restored.
#[test]
fn restore_refuses_a_hard_link_or_fifo_member() {
    let dir = scratch("archive-special");
    let (from, archives) = (dir.join("from"), dir.join("archives"));
    std::fs::create_dir_all(&from).expect("scratch files");
    std::fs::create_dir_all(&archives).expect("scratch files");
    std::fs::write(from.join("grid.json"), "{}").expect("scratch files");
    std::fs::hard_link(from.join("grid.json"), from.join("again.json")).expect("scratch files");
    pack(
        &from,
        &archives.join("001.tar.xz"),
        &["grid.json", "again.json"],
    );
    let out = dir.join("restored");
    let result = runs_archive(&[Path::new("restore"), &archives, &out]);
    assert_refused(&result, &["001.tar.xz", "hard link", "again.json"]);
    assert!(!out.exists());

    let status = Command::new("mkfifo")
        .arg(from.join("pipe"))
        .status()
        .expect("mkfifo runs");
    assert!(status.success());
    std::fs::remove_file(archives.join("001.tar.xz")).expect("scratch files");
    pack(&from, &archives.join("001.tar.xz"), &["grid.json", "pipe"]);
    let result = runs_archive(&[Path::new("restore"), &archives, &out]);
    assert_refused(&result, &["001.tar.xz", "fifo", "pipe"]);
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).expect("scratch files");
}

/// A minimal `reproduce --out` folder as `save` reads it: a grid record and `runs` finished
/// runs (each with its config and eval.json) in one cell, with the cell's sweep logs folder.
fn grid_folder(dir: &Path, runs: usize) -> PathBuf {
    let out = dir.join("grid");
    std::fs::create_dir_all(&out).expect("scratch files");
    std::fs::write(out.join("grid.json"), "{}").expect("scratch files");
    std::fs::create_dir_all(out.join("runs/cell/sweep-logs")).expect("scratch files");
    for seed in 0..runs {
        let run = out.join(format!("runs/cell/nav-walls__dcp__{seed}"));
        std::fs::create_dir_all(&run).expect("scratch files");
        std::fs::write(run.join("config.toml"), "").expect("scratch files");
        std::fs::write(run.join("eval.json"), "{}").expect("scratch files");
    }
    out
}

/// `save` over an earlier archive that is truncated once printed xz's message, exited 0 and
/// wrote a new archive saving those runs again, a set `restore` then refused whole. Every
/// earlier archive is verified first: its name, exit 1, nothing written.
#[test]
fn save_refuses_a_corrupt_earlier_archive() {
    let dir = scratch("archive-corrupt");
    let out = grid_folder(&dir, 2);
    let archives = dir.join("archives");
    let saved = runs_archive(&[Path::new("save"), &out, &archives]);
    assert!(saved.status.success(), "{saved:?}");
    let first = archives.join("001.tar.xz");
    let bytes = std::fs::read(&first).expect("scratch files");
    std::fs::write(&first, &bytes[..bytes.len() / 2]).expect("scratch files");
    let run = out.join("runs/cell/nav-walls__dcp__2");
    std::fs::create_dir_all(&run).expect("scratch files");
    std::fs::write(run.join("eval.json"), "{}").expect("scratch files");

    let result = runs_archive(&[Path::new("save"), &out, &archives]);
    assert_refused(&result, &["001.tar.xz", "corrupt"]);
    assert_eq!(
        crate::support::entries(&archives),
        ["001.tar.xz"],
        "no new archive"
    );
    std::fs::remove_dir_all(&dir).expect("scratch files");
}

/// The processes of process group `pgid` still alive (zombies, dead but not reaped, excluded).
fn live_members(pgid: u32) -> Vec<String> {
    let mut live = Vec::new();
    for entry in std::fs::read_dir("/proc")
        .expect("/proc lists processes")
        .flatten()
    {
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
            continue;
        };
        // After the command name in parentheses: state, parent pid, process group.
        let Some((_, rest)) = stat.rsplit_once(") ") else {
            continue;
        };
        let fields: Vec<&str> = rest.split(' ').collect();
        if fields.len() > 2 && fields[2] == pgid.to_string() && fields[0] != "Z" {
            live.push(stat);
        }
    }
    live
}

/// A `setpriv` that waits `delay` before running the real one: it holds the pipeline's children
/// in the moment between their fork and the arming of their death signal, where a loaded
/// machine once caught them.
fn slow_setpriv(dir: &Path, delay: &str) -> PathBuf {
    let real = std::env::split_paths(&std::env::var_os("PATH").expect("PATH is set"))
        .map(|d| d.join("setpriv"))
        .find(|p| p.is_file())
        .expect("setpriv (util-linux) is installed");
    let bin = dir.join("slow-bin");
    std::fs::create_dir_all(&bin).expect("scratch files");
    let wrapper = bin.join("setpriv");
    std::fs::write(
        &wrapper,
        format!("#!/bin/sh\nsleep {delay}\nexec {} \"$@\"\n", real.display()),
    )
    .expect("scratch files");
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755))
        .expect("scratch files");
    bin
}

/// A save killed with SIGKILL (no trap runs) once left its `tar | xz` pipeline running, which
/// went on writing a full-size hidden temporary archive. Now the pipeline dies with the script
/// and the next save removes the dead save's temporary. The save is killed while its children
/// are still on their way to arming their death signal (a slow `setpriv`), the moment a loaded
/// machine once hit by chance.
#[test]
fn a_killed_save_leaves_no_pipeline_and_its_temporary_is_removed() {
    use std::os::unix::process::CommandExt;
    let dir = scratch("archive-killed");
    let out = grid_folder(&dir, 1);
    let slow = slow_setpriv(&dir, "0.3");
    let tmp = dir.join("tmp");
    std::fs::create_dir_all(&tmp).expect("scratch files");
    let path = std::env::join_paths(std::iter::once(slow).chain(std::env::split_paths(
        &std::env::var_os("PATH").expect("PATH is set"),
    )))
    .expect("a PATH");
    // Incompressible bytes, enough to keep xz -9 busy for seconds.
    let mut x = 0x9E37_79B9_7F4A_7C15_u64;
    let noise: Vec<u8> = (0..24_000_000)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect();
    let metrics = out.join("runs/cell/nav-walls__dcp__0/metrics.csv");
    std::fs::write(&metrics, noise).expect("scratch files");
    let archives = dir.join("archives");
    let mut save = Command::new("bash")
        .arg(script())
        .args([Path::new("save"), &out, &archives])
        .process_group(0)
        .env("PATH", path)
        .env("TMPDIR", &tmp)
        .stdout(std::process::Stdio::null())
        .spawn()
        .expect("bash runs");
    let started = std::time::Instant::now();
    while !archives.is_dir() || crate::support::entries(&archives).is_empty() {
        assert!(
            started.elapsed().as_secs() < 60,
            "no temporary archive appeared"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    save.kill().expect("kill the save");
    save.wait().expect("reap the save");
    let mut live = live_members(save.id());
    for _ in 0..250 {
        if live.is_empty() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
        live = live_members(save.id());
    }
    assert!(
        live.is_empty(),
        "still running after the save died: {live:?}"
    );

    std::fs::write(&metrics, "small").expect("scratch files");
    let again = Command::new("bash")
        .arg(script())
        .args([Path::new("save"), &out, &archives])
        .env("TMPDIR", &tmp)
        .output()
        .expect("bash runs");
    assert!(again.status.success(), "{again:?}");
    assert_eq!(crate::support::entries(&archives), ["001.tar.xz"]);
    assert!(
        crate::support::entries(&tmp).is_empty(),
        "the killed save's lists are left in TMPDIR: {:?}",
        crate::support::entries(&tmp)
    );
    std::fs::remove_dir_all(&dir).expect("scratch files");
}

/// `restore ARCHIVES .` (an empty current folder) once failed with rmdir's raw message; it
/// restores into the folder. `save OUT FILE` once printed mkdir's message above its own: one
/// line now, exit 2.
#[test]
fn restore_into_the_current_folder_and_save_into_a_file_are_one_line() {
    let dir = scratch("archive-paths");
    let out = grid_folder(&dir, 1);
    let archives = dir.join("archives");
    assert!(runs_archive(&[Path::new("save"), &out, &archives])
        .status
        .success());
    let here = dir.join("here");
    std::fs::create_dir(&here).expect("scratch files");
    let restored = Command::new("bash")
        .arg(script())
        .args([Path::new("restore"), &archives, Path::new(".")])
        .current_dir(&here)
        .output()
        .expect("bash runs");
    assert!(restored.status.success(), "{restored:?}");
    assert!(here.join("runs/cell/nav-walls__dcp__0/eval.json").is_file());
    assert_eq!(crate::support::entries(&here), ["grid.json", "runs"]);

    let file = dir.join("file");
    std::fs::write(&file, "").expect("scratch files");
    let result = runs_archive(&[Path::new("save"), &out, &file]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("not a folder"), "{stderr}");
    std::fs::remove_dir_all(&dir).expect("scratch files");
}
