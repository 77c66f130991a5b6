//! Child processes that do not outlive firmware-sim (a plant process, QEMU), and finding a
//! program on `PATH` so that a missing one is named rather than blamed on the launcher.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The command that starts `program`: through util-linux's `setpriv --pdeathsig KILL` where
/// it is installed, so the kernel kills the child if firmware-sim dies (even by `kill -9`);
/// else the program itself. (A parent-death signal set directly would need `unsafe`, which the
/// workspace forbids.)
pub(crate) fn dying_with_us(program: &Path, args: &[String]) -> Command {
    dying_with(std::process::id(), program, args)
}

/// [`dying_with_us`] for a parent of pid `parent`. The signal is armed only when setpriv runs, a
/// moment after the fork; a parent killed in that moment would leave the child armed against
/// its new parent (init). So once armed, the child checks that its parent is still `parent` and
/// quits if not, the check C programs make after `prctl(PR_SET_PDEATHSIG)`; `exec` keeps the
/// child's pid the program's.
fn dying_with(parent: u32, program: &Path, args: &[String]) -> Command {
    const SETPRIV: &str = "/usr/bin/setpriv";
    if Path::new(SETPRIV).is_file() {
        let mut command = Command::new(SETPRIV);
        command
            .args(["--pdeathsig", "KILL", "--", "/bin/sh", "-c"])
            .arg(r#"[ "$PPID" = "$1" ] || exit 1; shift; exec "$@""#)
            .arg("dying-with-us")
            .arg(parent.to_string())
            .arg(program)
            .args(args);
        command
    } else {
        let mut command = Command::new(program);
        command.args(args);
        command
    }
}

/// The program's path: as given if it names a file (it has a `/`), else found on `PATH`.
pub(crate) fn find_program(name: &str) -> Result<PathBuf, String> {
    let executable = |path: &Path| {
        use std::os::unix::fs::PermissionsExt;
        path.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    };
    if name.contains('/') {
        let path = PathBuf::from(name);
        return if executable(&path) {
            Ok(path)
        } else if path.exists() {
            Err(format!("{name} is not an executable file"))
        } else {
            Err(format!("no such file {name}"))
        };
    }
    std::env::var_os("PATH")
        .iter()
        .flat_map(std::env::split_paths)
        .map(|dir| dir.join(name))
        .find(|path| executable(path))
        .ok_or_else(|| format!("no program {name} on PATH"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_child_runs_the_program_with_its_arguments_as_given() {
        let out = dying_with_us(Path::new("/bin/echo"), &["a b".into(), "$HOME".into()])
            .output()
            .expect("echo runs");
        assert!(out.status.success());
        assert_eq!(String::from_utf8_lossy(&out.stdout), "a b $HOME\n");
    }

    /// A child whose parent is not the one it was started for (as when firmware-sim dies before
    /// the death signal is armed) quits without running the program.
    #[test]
    fn a_child_whose_parent_is_gone_quits_without_running_the_program() {
        if !Path::new("/usr/bin/setpriv").is_file() {
            return; // no death signal to arm: the program runs as is
        }
        let not_us = std::process::id().wrapping_add(1);
        let out = dying_with(not_us, Path::new("/bin/echo"), &["ran".into()])
            .output()
            .expect("setpriv runs");
        assert_eq!(out.status.code(), Some(1));
        assert!(out.stdout.is_empty(), "{out:?}");
    }
}
