//! The HIL firmware under QEMU: find its ELF, read its slot addresses, write the slot images,
//! start `qemu-system-arm` with UART0 on a Unix socket and `-icount shift=0` (SysTick then
//! counts instructions), and kill it when the run ends, whatever way it ends.

use std::fs;
use std::io::{Read, Seek, SeekFrom};
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
    let core =
        arm_core(&file).map_err(|e| bad(format!("unreadable ARM build attributes ({e})")))?;
    if !core.is_m_profile() {
        return Err(bad(format!(
            "built for {}, not a Cortex-M (M-profile): give the HIL firmware that scripts/cortex-m.sh --hil-only builds",
            core.describe()
        )));
    }
    let find = |name: &str| {
        file.symbols()
            .find(|s| s.name() == Ok(name))
            .map(|s| s.address())
            .ok_or_else(|| {
                bad(format!(
                    "no {name} symbol: not a firmware linked with a board's memory.x (firmware/mps2/memory.x)"
                ))
            })
    };
    Ok(SlotAddresses {
        a: find("_slot_a")?,
        b: find("_slot_b")?,
        size: find("_slot_size")?,
    })
}

/// What an ARM ELF's build attributes (`.ARM.attributes`, the "aeabi" file attributes) say
/// about the core it was built for: every ARM toolchain (rustc's LLVM, arm-none-eabi-gcc)
/// writes them, and they tell an M-profile core from an A- or R-profile one, which the ELF's
/// machine (ARM for all three) does not.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct ArmCore {
    /// Tag_CPU_arch: 11 v6-M, 12 v6S-M, 13 v7E-M, 16 v8-M baseline, 17 v8-M mainline, 21
    /// v8.1-M mainline; 10 is v7 (A, R or M: the profile says which).
    arch: Option<u64>,
    /// Tag_CPU_arch_profile: `A`, `R`, `M` or `S` (A or R), as its character.
    profile: Option<u8>,
}

impl ArmCore {
    fn is_m_profile(self) -> bool {
        match self.profile {
            Some(p) => p == b'M',
            None => matches!(self.arch, Some(11 | 12 | 13 | 16 | 17 | 21)),
        }
    }

    fn describe(self) -> String {
        let profile = match self.profile {
            Some(b'A') => "an A-profile core (Cortex-A)".to_string(),
            Some(b'R') => "an R-profile core (Cortex-R)".to_string(),
            Some(b'S') => "an A- or R-profile core".to_string(),
            Some(p) => format!("a core of profile {:?}", char::from(p)),
            None => "a core of no stated profile".to_string(),
        };
        match (self.arch, self.profile) {
            (None, None) => "a core its build attributes do not name (no .ARM.attributes)".into(),
            (Some(arch), _) => format!("{profile}, architecture tag {arch}"),
            (None, _) => profile,
        }
    }
}

/// Reads Tag_CPU_arch and Tag_CPU_arch_profile from the ELF's file attributes.
fn arm_core(file: &object::File<'_>) -> object::read::Result<ArmCore> {
    use object::read::elf::AttributesSection;
    use object::ObjectSection;
    let mut core = ArmCore::default();
    let Some(section) = file.section_by_name(".ARM.attributes") else {
        return Ok(core);
    };
    let data = section.data()?;
    let attributes = AttributesSection::<object::elf::FileHeader32<object::Endianness>>::new(
        file.endianness(),
        data,
    )?;
    let mut subsections = attributes.subsections()?;
    while let Some(subsection) = subsections.next()? {
        if subsection.vendor() != b"aeabi" {
            continue;
        }
        let mut subsubsections = subsection.subsubsections();
        while let Some(subsubsection) = subsubsections.next()? {
            // Tag_File: attributes of the whole file.
            if subsubsection.tag() != 1 {
                continue;
            }
            let mut reader = subsubsection.attributes();
            while let Some(tag) = reader.read_tag()? {
                // The ARM ABI's rule for a tag's type: 4, 5 and 67 are strings, 32 a number
                // then a string; other tags below 32 numbers, above it odd ones strings.
                match tag {
                    4 | 5 | 67 => {
                        reader.read_string()?;
                    }
                    32 => {
                        reader.read_integer()?;
                        reader.read_string()?;
                    }
                    6 => core.arch = Some(reader.read_integer()?),
                    7 => core.profile = u8::try_from(reader.read_integer()?).ok(),
                    t if t > 32 && t % 2 == 1 => {
                        reader.read_string()?;
                    }
                    _ => {
                        reader.read_integer()?;
                    }
                }
            }
        }
    }
    Ok(core)
}

/// A running QEMU: killed and reaped, and its scratch folder removed, when dropped.
///
/// The scratch folder (the UART socket, the slot images, QEMU's log) is removed as soon as the
/// chip has booted: QEMU has read the images and holds its socket and log open, and the log is
/// read through a handle kept here. A `kill -9` of firmware-sim after that leaves nothing
/// behind (QEMU dies with it by its parent-death signal); one during QEMU's start leaves the
/// folder to the next run's clean-up.
#[derive(Debug)]
pub struct Qemu {
    child: Child,
    dir: PathBuf,
    log: fs::File,
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
    // Read through its own handle: the folder goes once the chip has booted.
    let log_reader = fs::File::open(&log).map_err(|e| io("cannot read QEMU's log", e))?;
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
    let mut qemu = Qemu {
        child,
        dir,
        log: log_reader,
    };
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
        let mut log = String::new();
        let _ = self.log.seek(SeekFrom::Start(0));
        let _ = self.log.read_to_string(&mut log);
        Some(format!("QEMU exited ({status}): {}", telling_line(&log)))
    }

    fn booted(&mut self) {
        let _ = fs::remove_dir_all(&self.dir);
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = fs::remove_dir_all(&self.dir);
    }
}

/// The line of QEMU's output that says what went wrong: a fatal error is followed by a register
/// dump (`R00=...`, `FPSCR: 00000000`), so the last line that names QEMU, a fatal error or a
/// lockup, else the last line (a firmware's own last words, `DONE`).
fn telling_line(log: &str) -> &str {
    let lines = || log.lines().map(str::trim).filter(|l| !l.is_empty());
    let telling = |l: &&str| {
        let l = l.to_ascii_lowercase();
        ["qemu", "fatal", "lockup", "error", "abort"]
            .iter()
            .any(|w| l.contains(w))
    };
    lines()
        .rfind(telling)
        .or_else(|| lines().next_back())
        .unwrap_or("no output")
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

#[cfg(test)]
mod tests {
    /// Regression: a QEMU fatal error was reported as its register dump's last line.
    #[test]
    fn a_qemu_fatal_error_is_reported_by_its_fatal_line_not_the_register_dump() {
        let log = "qemu: fatal: Lockup: can't escalate 3 to HardFault (current priority -1)\n\n\
                   R00=00000000 R01=00000000 R02=00000000 R03=00000000\n\
                   XPSR=40000003 -Z-- T handler\nFPSCR: 00000000\n";
        assert_eq!(
            super::telling_line(log),
            "qemu: fatal: Lockup: can't escalate 3 to HardFault (current priority -1)"
        );
        assert_eq!(super::telling_line("boot\nDONE\n"), "DONE");
        assert_eq!(super::telling_line(""), "no output");
    }
}
