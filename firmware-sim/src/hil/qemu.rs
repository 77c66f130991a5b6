//! The HIL firmware under QEMU: find its ELF, read its slot addresses, write the slot images,
//! start `qemu-system-arm` with UART0 on a Unix socket and `-icount shift=0` (SysTick then
//! counts instructions), and kill it when the run ends, whatever way it ends.

use std::fs;
use std::os::unix::net::{UnixListener, UnixStream};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use object::{Object, ObjectSymbol};

use super::chip::Backend;
use crate::Error;

/// The emulated chips.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Machine {
    /// mps2-an386, a Cortex-M4F.
    M4f,
    /// mps2-an385, a Cortex-M3.
    M3,
}

impl Machine {
    /// `qemu-m4f` or `qemu-m3`.
    pub fn name(self) -> &'static str {
        match self {
            Machine::M4f => "qemu-m4f",
            Machine::M3 => "qemu-m3",
        }
    }

    fn qemu(self) -> (&'static str, &'static str) {
        match self {
            Machine::M4f => ("mps2-an386", "cortex-m4"),
            Machine::M3 => ("mps2-an385", "cortex-m3"),
        }
    }

    /// Where `scripts/cortex-m.sh` puts this chip's HIL firmware, under a target directory.
    pub fn default_firmware(self, target_dir: &Path) -> PathBuf {
        let chip = match self {
            Machine::M4f => "m4f",
            Machine::M3 => "m3",
        };
        target_dir
            .join("cortex-m")
            .join("hil")
            .join(chip)
            .join("firmware.elf")
    }
}

/// The slot region of a firmware ELF: memory.x's `_slot_a`, `_slot_b` and `_slot_size`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotAddresses {
    /// Slot A's address.
    pub a: u64,
    /// Slot B's address.
    pub b: u64,
    /// Bytes in a slot.
    pub size: u64,
}

/// Reads the slot addresses from an ARM ELF's symbols (as scripts/cortex-m.sh reads them with
/// nm).
pub fn slot_addresses(elf: &Path) -> Result<SlotAddresses, Error> {
    let bad = |what: String| Error::Hil(format!("HIL firmware {}: {what}", elf.display()));
    let data = fs::read(elf).map_err(|e| bad(format!("cannot read it: {e}")))?;
    let file = object::File::parse(&*data).map_err(|e| bad(format!("not an ELF file ({e})")))?;
    if file.architecture() != object::Architecture::Arm {
        return Err(bad(format!(
            "built for {:?}, not a Cortex-M",
            file.architecture()
        )));
    }
    let find = |name: &str| {
        file.symbols()
            .find(|s| s.name() == Ok(name))
            .map(|s| s.address())
            .ok_or_else(|| {
                bad(format!(
                    "no {name} symbol: not a firmware linked with firmware/memory.x"
                ))
            })
    };
    Ok(SlotAddresses {
        a: find("_slot_a")?,
        b: find("_slot_b")?,
        size: find("_slot_size")?,
    })
}

/// A running QEMU: killed and reaped, and its scratch folder removed, when dropped.
#[derive(Debug)]
pub struct Qemu {
    child: Child,
    dir: PathBuf,
    log: PathBuf,
}

static RUNS: AtomicU32 = AtomicU32::new(0);

/// Starts QEMU on `elf` with each `(address, image)` loaded into flash (a flasher's job on a
/// board), UART0 on a Unix socket; returns it and the socket once QEMU has connected.
/// `extra` are more QEMU arguments (tests: e.g. `-S`, a chip that never starts).
pub fn start(
    machine: Machine,
    elf: &Path,
    images: &[(u64, &[u8])],
    extra: &[String],
    timeout: Duration,
) -> Result<(Qemu, UnixStream), Error> {
    let io = |what: &str, e: std::io::Error| Error::Hil(format!("{what}: {e}"));
    let dir = std::env::temp_dir().join(format!(
        "firmware-sim-hil-{}-{}",
        std::process::id(),
        RUNS.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = fs::remove_dir_all(&dir);
    remove_stale_scratch();
    fs::create_dir_all(&dir).map_err(|e| io("cannot create a scratch folder", e))?;
    // From here the guard removes the folder on every path out.
    let cleanup = Cleanup(dir.clone());
    let socket = dir.join("uart.sock");
    let listener = UnixListener::bind(&socket).map_err(|e| io("cannot open the UART socket", e))?;
    listener
        .set_nonblocking(true)
        .map_err(|e| io("cannot open the UART socket", e))?;
    let (board, cpu) = machine.qemu();
    // QEMU dies with firmware-sim, however firmware-sim ends (kill -9 included).
    let qemu = crate::process::find_program("qemu-system-arm").map_err(|_| {
        Error::Hil(
            "qemu-system-arm not found: install it with `bash scripts/cortex-m.sh --install-only`"
                .into(),
        )
    })?;
    let mut cmd = crate::process::dying_with_us(&qemu, &[]);
    cmd.args(["-M", board, "-cpu", cpu, "-nodefaults", "-display", "none"])
        .args(["-icount", "shift=0"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-chardev")
        .arg(format!("socket,id=hil,path={}", socket.display()))
        .args(["-serial", "chardev:hil"]);
    for (k, (addr, image)) in images.iter().enumerate() {
        let path = dir.join(format!("slot-{k}.bin"));
        fs::write(&path, image).map_err(|e| io("cannot write a slot image", e))?;
        cmd.arg("-device")
            .arg(format!("loader,file={},addr={addr:#x}", path.display()));
    }
    cmd.arg("-kernel").arg(elf).args(extra);
    let log = dir.join("qemu.log");
    let out = fs::File::create(&log).map_err(|e| io("cannot create QEMU's log", e))?;
    let err = out
        .try_clone()
        .map_err(|e| io("cannot create QEMU's log", e))?;
    // Its own process group: Ctrl-C reaches firmware-sim, which reports and then stops QEMU.
    cmd.stdin(Stdio::null())
        .stdout(out)
        .stderr(err)
        .process_group(0);
    let child = cmd.spawn().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::Hil(
                "qemu-system-arm not found: install it with `bash scripts/cortex-m.sh --install-only`"
                    .into(),
            )
        } else {
            io("cannot start qemu-system-arm", e)
        }
    })?;
    std::mem::forget(cleanup);
    let mut qemu = Qemu { child, dir, log };
    let deadline = Instant::now() + timeout;
    loop {
        match listener.accept() {
            Ok((stream, _)) => {
                stream
                    .set_nonblocking(false)
                    .map_err(|e| io("the UART socket", e))?;
                return Ok((qemu, stream));
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
            Err(e) => return Err(io("the UART socket", e)),
        }
        if let Some(note) = qemu.exit_note(Duration::ZERO) {
            return Err(Error::Hil(format!(
                "{}: QEMU did not start: {note}",
                machine.name()
            )));
        }
        if Instant::now() >= deadline {
            return Err(Error::Hil(format!(
                "{}: QEMU did not connect its UART within {:.1} s",
                machine.name(),
                timeout.as_secs_f64()
            )));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

impl Qemu {
    /// QEMU's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }
}

impl Backend for Qemu {
    fn exit_note(&mut self, grace: Duration) -> Option<String> {
        let deadline = Instant::now() + grace;
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(10))
                }
                _ => return None,
            }
        };
        let log = fs::read_to_string(&self.log).unwrap_or_default();
        let last = log
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("no output");
        Some(format!("QEMU exited ({status}): {}", last.trim()))
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = fs::remove_dir_all(&self.dir);
    }
}

/// Removes the scratch folders of firmware-sim processes that are gone (killed before they
/// could clean up): `firmware-sim-hil-PID-N` whose PID no longer runs.
fn remove_stale_scratch() {
    let Ok(entries) = fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let pid = name
            .to_str()
            .and_then(|n| n.strip_prefix("firmware-sim-hil-"))
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok());
        if let Some(pid) = pid {
            if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
                let _ = fs::remove_dir_all(entry.path());
            }
        }
    }
}

/// Removes a scratch folder unless forgotten.
struct Cleanup(PathBuf);

impl Drop for Cleanup {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}
