//! Child processes that do not outlive firmware-sim (a plant process, QEMU), and finding a
//! program on `PATH` so that a missing one is named rather than blamed on the launcher.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The command that starts `program`: through util-linux's `setpriv --pdeathsig KILL` where
/// it is installed, so the kernel kills the child if firmware-sim dies (even by `kill -9`);
/// else the program itself. (A parent-death signal set directly would need `unsafe`, which the
/// workspace forbids.)
pub(crate) fn dying_with_us(program: &Path, args: &[String]) -> Command {
    const SETPRIV: &str = "/usr/bin/setpriv";
    if Path::new(SETPRIV).is_file() {
        let mut command = Command::new(SETPRIV);
        command
            .args(["--pdeathsig", "KILL", "--"])
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
