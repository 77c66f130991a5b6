//! Files in and out, the one way both binaries (firmware-sim and host-trainer) do it.
//!
//! - [`AtomicFile`] / [`write_atomic`]: every output is written to a temporary sibling
//!   (`.NAME.tmp-PID-N`) and renamed into place, so a reader sees the previous complete file or
//!   the new complete file, never half of one. On failure, or when dropped without
//!   [`AtomicFile::commit`], the temporary file is removed; temporaries left by a process that
//!   was killed are removed the next time anything writes that file ([`remove_stale_temps`]).
//!   The rename is only for regular files (and paths that do not exist yet): a path naming a
//!   FIFO or a device is written through, as `>` in a shell would, and a symbolic link is
//!   followed, its target written (atomically when that is a regular file). Renaming over them
//!   would replace the device, pipe or link with a plain file.
//! - [`write_new`]: a file written once by whichever of several racing writers comes first,
//!   whole or not at all (a grid's record, claimed by its parts).
//! - [`check_output`]: an output path is checked (its folder exists and is writable, it is not a
//!   folder) before any work, so a long evaluation never ends in "cannot write".
//! - [`read_config_text`]: reads a config or scenario file (TOML), refusing one larger than
//!   [`MAX_CONFIG_FILE`] before reading it, and never reading more than that from a pipe or a
//!   device (`/dev/zero`): every text file either binary reads comes through it.
//! - [`read_blob`]: reads a blob file, refusing one larger than any blob can be
//!   ([`policy_core::blob::MAX_BLOB_LEN`]) before reading it.

use std::fs;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Counts temporaries made by this process, so two writers of one file never share a name.
static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

/// A file being written: bytes go to a temporary sibling until [`AtomicFile::commit`] renames
/// it over the target. Dropped without a commit (an error, a panic, an early return), it
/// removes its temporary file.
///
/// ```
/// use std::io::Write;
/// use firmware_sim::files::AtomicFile;
/// let dir = std::env::temp_dir().join(format!("atomic-file-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("report.json");
/// let mut file = AtomicFile::create(&path).unwrap();
/// file.write_all(b"{}").unwrap();
/// assert!(!path.exists()); // nothing visible until the commit
/// file.commit().unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"{}");
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    /// The file the bytes go to: a temporary sibling of `target`, or `target` itself when it is
    /// written through (a FIFO or a device).
    temp: PathBuf,
    /// Whether `temp` is `target` itself (nothing to rename or remove).
    through: bool,
    /// `None` once committed.
    file: Option<io::BufWriter<fs::File>>,
}

/// Where the bytes of an output named `path` go.
enum Target {
    /// A regular file, or nothing yet: temporary sibling and rename.
    Atomic(PathBuf),
    /// A FIFO, a character or block device: opened and written in place.
    Through(PathBuf),
}

/// Classifies `path`, following a symbolic link to what it names. A link whose target is missing
/// is refused: creating the file there would write somewhere the user may not expect.
fn target_of(path: &Path) -> io::Result<Target> {
    let meta = match fs::symlink_metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Ok(Target::Atomic(path.to_path_buf()))
        }
        Err(e) => return Err(e),
    };
    if meta.file_type().is_symlink() {
        // `/dev/stdout` into a pipe: a link (through /proc/self/fd) to a pipe that has no path
        // to resolve, but opening the link writes into it.
        if fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
            return Ok(Target::Through(path.to_path_buf()));
        }
        let real = fs::canonicalize(path).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("is a symbolic link whose target cannot be reached ({e})"),
            )
        })?;
        let meta = fs::metadata(&real)?;
        return Ok(if meta.is_file() || meta.is_dir() {
            Target::Atomic(real)
        } else {
            Target::Through(real)
        });
    }
    Ok(if meta.is_file() || meta.is_dir() {
        // A folder stays on the atomic path: its rename fails with the system's message.
        Target::Atomic(path.to_path_buf())
    } else {
        Target::Through(path.to_path_buf())
    })
}

impl AtomicFile {
    /// Starts writing `path`; removes temporaries of `path` that dead processes left behind.
    /// A FIFO or device is opened for writing in place (a FIFO waits for its reader here); a
    /// symbolic link is followed.
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        let path = match target_of(path)? {
            Target::Atomic(path) => path,
            Target::Through(path) => {
                let file = fs::OpenOptions::new().write(true).open(&path)?;
                return Ok(AtomicFile {
                    target: path.clone(),
                    temp: path,
                    through: true,
                    file: Some(io::BufWriter::new(file)),
                });
            }
        };
        let name = file_name(&path)?;
        let dir = folder_of(&path);
        remove_stale_temps(dir, Some(&name))?;
        let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
        let temp = dir.join(format!(".{name}.tmp-{}-{n}", std::process::id()));
        let file = fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp)?;
        Ok(AtomicFile {
            target: path.clone(),
            temp,
            through: false,
            file: Some(io::BufWriter::new(file)),
        })
    }

    /// Flushes, syncs to disk and renames the temporary file over the target (written through:
    /// flushes only, since a pipe or device cannot be synced).
    pub fn commit(mut self) -> io::Result<()> {
        let Some(writer) = self.file.take() else {
            return Ok(());
        };
        let file = writer.into_inner().map_err(|e| e.into_error());
        if self.through {
            return file.map(drop);
        }
        let result = file
            .and_then(|file| file.sync_all())
            .and_then(|()| fs::rename(&self.temp, &self.target));
        if result.is_err() {
            let _ = fs::remove_file(&self.temp);
        }
        result
    }

    /// The temporary file's path: the bytes written so far, before the commit (the JSON report
    /// reads its episode spool back from it). Written through, it is the target itself.
    pub fn temp_path(&self) -> &Path {
        &self.temp
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.file {
            Some(f) => f.write(buf),
            None => Err(io::Error::other("file already committed")),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.file {
            Some(f) => f.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() && !self.through {
            // Best effort: an uncommitted write leaves nothing behind.
            let _ = fs::remove_file(&self.temp);
        }
    }
}

/// Writes `bytes` to `path` atomically (see [`AtomicFile`]).
///
/// ```
/// let path = std::env::temp_dir().join(format!("write-atomic-doc-{}.txt", std::process::id()));
/// firmware_sim::files::write_atomic(&path, b"hello").unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"hello");
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut file = AtomicFile::create(path)?;
    file.write_all(bytes)?;
    file.commit()
}

/// Writes `bytes` to `path` only if nothing is there yet, and whole: the bytes go to a hidden
/// sibling, synced, then hard-linked to `path`, which the system refuses (`AlreadyExists`) when
/// `path` exists. So of several writers racing (two parts of one grid started together, on one
/// machine or on nodes sharing the folder), exactly one wins, and every reader sees either no
/// file or the complete one, never an empty or half-written file, as `create_new` followed by a
/// write would show for a moment (or for ever, if the writer was killed in between). The
/// sibling is removed in every case; only a kill between its creation and its removal leaves it
/// (`.NAME.new-PID-N`, a few bytes). It is not a `.tmp-` name, so no other writer's clean-up
/// of dead processes' temporaries (which judges by process ids on this machine) removes it
/// while a process on another node still needs it.
///
/// ```
/// use std::io::ErrorKind;
/// let path = std::env::temp_dir().join(format!("write-new-doc-{}.json", std::process::id()));
/// firmware_sim::files::write_new(&path, b"first").unwrap();
/// let err = firmware_sim::files::write_new(&path, b"second").unwrap_err();
/// assert_eq!(err.kind(), ErrorKind::AlreadyExists);
/// assert_eq!(std::fs::read(&path).unwrap(), b"first");
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn write_new(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let name = file_name(path)?;
    let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
    let temp = folder_of(path).join(format!(".{name}.new-{}-{n}", std::process::id()));
    let written = fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .and_then(|mut file| {
            file.write_all(bytes)?;
            file.sync_all()
        })
        .and_then(|()| fs::hard_link(&temp, path));
    let _ = fs::remove_file(&temp);
    written
}

/// Removes the temporary files (`.NAME.tmp-PID-N`) in `dir` that a process no longer running
/// left behind, for one target `NAME` or, with `None`, for every target. Temporaries of live
/// processes (a concurrent writer) are kept. Returns how many were removed.
pub fn remove_stale_temps(dir: &Path, name: Option<&str>) -> io::Result<usize> {
    let entries = match fs::read_dir(dir) {
        Ok(entries) => entries,
        // A missing folder holds no temporaries; creating the file will report it.
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(e),
    };
    let mut removed = 0;
    for entry in entries {
        let entry = entry?;
        let file_name = entry.file_name();
        let Some((target, pid)) = file_name.to_str().and_then(parse_temp_name) else {
            continue;
        };
        if name.is_some_and(|n| n != target) || process_alive(pid) {
            continue;
        }
        match fs::remove_file(entry.path()) {
            Ok(()) => removed += 1,
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(e),
        }
    }
    Ok(removed)
}

/// `.NAME.tmp-PID-N` → `(NAME, PID)`.
fn parse_temp_name(file_name: &str) -> Option<(&str, u32)> {
    let rest = file_name.strip_prefix('.')?;
    let (target, suffix) = rest.rsplit_once(".tmp-")?;
    let (pid, n) = suffix.split_once('-')?;
    n.parse::<u64>().ok()?;
    Some((target, pid.parse().ok()?))
}

/// Whether a process with this id runs now. Our own id always counts as alive. Where `/proc`
/// is missing (not Linux) every other process counts as dead: the temporaries of a concurrent
/// writer of the *same file* may then be removed, which makes that writer's commit fail loudly
/// rather than lose data.
fn process_alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists()
}

/// Checks, before any work, that `path` can be written: it names a file (not a folder), and its
/// folder exists and accepts new files (probed by creating and removing a temporary file).
///
/// ```
/// use firmware_sim::files::check_output;
/// let dir = std::env::temp_dir();
/// assert!(check_output(&dir.join("report.json")).is_ok());
/// let err = check_output(&dir.join("no-such-folder-7f3a").join("r.json")).unwrap_err();
/// assert!(err.to_string().contains("folder does not exist"), "{err}");
/// assert!(check_output(&dir).is_err()); // a folder, not a file
/// ```
pub fn check_output(path: &Path) -> io::Result<()> {
    file_name(path)?;
    if path.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::IsADirectory,
            "is a folder, expected a file path",
        ));
    }
    let dir = folder_of(path);
    if !dir.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!("folder does not exist: {}", dir.display()),
        ));
    }
    let path = match target_of(path)? {
        Target::Atomic(path) => path,
        // Opening a FIFO to probe it would wait for a reader: the write reports what fails.
        Target::Through(_) => return Ok(()),
    };
    let probe = AtomicFile::create(&path)?;
    drop(probe); // removes the probe
    Ok(())
}

/// Checks the outputs of one command together, before any work: each as [`check_output`]
/// does, and no two naming the same file, compared by canonical folder and file name (so
/// `same.out` and `./same.out`, or a link and its target, are caught: one would overwrite the
/// other's report).
///
/// ```
/// use firmware_sim::files::check_outputs;
/// use std::path::Path;
/// let dir = std::env::temp_dir();
/// let (a, b) = (dir.join("a.json"), dir.join("b.svg"));
/// assert!(check_outputs(&[&a, &b]).is_ok());
/// let same = dir.join(".").join("a.json");
/// let err = check_outputs(&[&a, &same]).unwrap_err().to_string();
/// assert!(err.contains("same file"), "{err}");
/// ```
pub fn check_outputs(paths: &[&Path]) -> io::Result<()> {
    let mut seen: Vec<(PathBuf, &Path)> = Vec::new();
    for path in paths {
        check_output(path).map_err(|e| {
            io::Error::new(e.kind(), format!("cannot write {}: {e}", path.display()))
        })?;
        let real = match target_of(path)? {
            Target::Atomic(p) | Target::Through(p) => p,
        };
        let dir = fs::canonicalize(folder_of(&real))?;
        let key = dir.join(file_name(&real)?);
        if let Some((_, first)) = seen.iter().find(|(k, _)| *k == key) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "{} and {} name the same file {}: give two different files",
                    first.display(),
                    path.display(),
                    key.display()
                ),
            ));
        }
        seen.push((key, path));
    }
    Ok(())
}

/// Reads a blob file. A file larger than any blob can be ([`policy_core::blob::MAX_BLOB_LEN`])
/// is refused from its size, before it is read; the bytes are not checked otherwise (booting
/// them does that).
///
/// ```
/// let path = std::env::temp_dir().join(format!("read-blob-doc-{}", std::process::id()));
/// std::fs::write(&path, b"DCPB").unwrap();
/// assert_eq!(firmware_sim::files::read_blob(&path).unwrap(), b"DCPB");
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn read_blob(path: &Path) -> io::Result<Vec<u8>> {
    let max = policy_core::blob::MAX_BLOB_LEN as u64;
    let bytes = read_bounded(path, max, |size| {
        format!(
            "file is {size} bytes, larger than any blob can be ({max} bytes): not a policy blob"
        )
    })?;
    // A slot image starts with the slot record's magic, not a blob's: say what it is (the
    // blob's own check would only say "found [68, 67, 80, 83]").
    if bytes.starts_with(&policy_core::slot::MAGIC) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            "this looks like a flash slot image: give it with --slot-a/--slot-b, or give the blob (policy.postcard)",
        ));
    }
    Ok(bytes)
}

/// The largest config or scenario file [`read_config_text`] takes (1 MiB): the shipped ones are
/// under 4 KiB, and a larger file is almost surely the wrong file.
pub const MAX_CONFIG_FILE: u64 = 1 << 20;

/// Reads a config or scenario file as text, refusing a file larger than [`MAX_CONFIG_FILE`]
/// from its size before reading it, a stream (a pipe, `/dev/zero`) after at most that many
/// bytes and one more, and bytes that are not UTF-8.
///
/// ```
/// use firmware_sim::files::read_config_text;
/// let path = std::env::temp_dir().join(format!("read-config-doc-{}.toml", std::process::id()));
/// std::fs::write(&path, "episodes = 5\n").unwrap();
/// assert_eq!(read_config_text(&path).unwrap(), "episodes = 5\n");
/// std::fs::write(&path, vec![b'#'; 2 << 20]).unwrap();
/// let err = read_config_text(&path).unwrap_err().to_string();
/// assert!(err.contains("larger than"), "{err}");
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn read_config_text(path: &Path) -> io::Result<String> {
    read_text(path, MAX_CONFIG_FILE)
}

/// Reads at most `max` bytes of `path` as UTF-8 text (see [`read_config_text`]).
///
/// ```
/// let path = std::env::temp_dir().join(format!("read-text-doc-{}.txt", std::process::id()));
/// std::fs::write(&path, "0123456789").unwrap();
/// assert_eq!(firmware_sim::files::read_text(&path, 10).unwrap(), "0123456789");
/// assert!(firmware_sim::files::read_text(&path, 9).is_err());
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn read_text(path: &Path, max: u64) -> io::Result<String> {
    let bytes = read_bounded(path, max, |size| {
        format!("file is {size} bytes or more, larger than the {max} bytes a text input may have")
    })?;
    String::from_utf8(bytes).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("is not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        )
    })
}

/// Reads at most `max` bytes of `path`; a larger file (by its size, or by what a pipe or a
/// growing file delivers) is `InvalidData` with `too_large(size)` as the message.
fn read_bounded(path: &Path, max: u64, too_large: impl Fn(u64) -> String) -> io::Result<Vec<u8>> {
    let error = |size| io::Error::new(io::ErrorKind::InvalidData, too_large(size));
    let file = fs::File::open(path)?;
    let size = file.metadata()?.len();
    if size > max {
        return Err(error(size));
    }
    // The size may change under us or be unknown (a pipe): never read past the limit.
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(max + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(error(bytes.len() as u64));
    }
    Ok(bytes)
}

/// The largest slot image [`read_slot`] takes (64 MiB): a whole slot dumped from flash fits,
/// with room to spare; a larger file is not a slot of any microcontroller.
pub const MAX_SLOT_FILE: u64 = 64 << 20;

/// Reads a flash slot image: the slot record a flasher writes (`host-trainer export --image bin`)
/// or a dump of the whole slot. Intel HEX is refused with a message (give the `.bin` image), as
/// is a file larger than [`MAX_SLOT_FILE`]; the bytes are not checked otherwise (booting does).
///
/// ```
/// let path = std::env::temp_dir().join(format!("read-slot-doc-{}", std::process::id()));
/// std::fs::write(&path, b":020000040804EE").unwrap();
/// let err = firmware_sim::files::read_slot(&path).unwrap_err().to_string();
/// assert!(err.contains("Intel HEX"), "{err}");
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn read_slot(path: &Path) -> io::Result<Vec<u8>> {
    let bytes = read_bounded(path, MAX_SLOT_FILE, |size| {
        format!("file is {size} bytes, larger than any flash slot ({MAX_SLOT_FILE} bytes)")
    })?;
    if bytes.first() == Some(&b':') {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            "this is an Intel HEX image: give the raw .bin image of the slot (export --image bin)",
        ));
    }
    Ok(bytes)
}

fn file_name(path: &Path) -> io::Result<String> {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "is not a file path"))
}

fn folder_of(path: &Path) -> &Path {
    path.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// `println!` for the binaries: [`write_stdout`], so a reader that goes away (`| head`) ends
/// the program quietly instead of a panic.
#[macro_export]
macro_rules! outln {
    () => {
        $crate::files::write_stdout(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::files::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` for the binaries: see [`outln!`].
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::files::write_stdout(format_args!($($arg)*))
    };
}

/// `eprintln!` for the binaries: [`write_stderr`], so a reader of standard error that goes
/// away (`firmware-sim run ... 2>&1 | head -4`) ends the program as a closed standard output
/// does, with status 141, instead of a panic (status 101).
#[macro_export]
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::files::write_stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// The exit status after standard output's reader went away: a shell's status for a process
/// killed by SIGPIPE.
pub const BROKEN_PIPE_STATUS: i32 = 141;

/// Writes to standard output. If its reader has gone away (`firmware-sim run ... | head -3`),
/// the process ends quietly with status 141, as `cat` ends when SIGPIPE kills it (128 + 13:
/// not 0, so a gate whose report nobody read never passes), instead of panicking as `print!`
/// does on a closed pipe; any other write error is reported on stderr once, and the process
/// goes on (its files are what it is for). The binaries' `outln!` and `out!` call this.
pub fn write_stdout(args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let mut stdout = io::stdout().lock();
    let result = stdout.write_fmt(args).and_then(|()| stdout.flush());
    match result {
        Ok(()) => {}
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => std::process::exit(BROKEN_PIPE_STATUS),
        Err(e) => {
            use std::sync::atomic::{AtomicBool, Ordering};
            static REPORTED: AtomicBool = AtomicBool::new(false);
            if !REPORTED.swap(true, Ordering::Relaxed) {
                let _ = writeln!(
                    io::stderr(),
                    "warning: cannot write to standard output: {e}"
                );
            }
        }
    }
}

/// Writes to standard error. If its reader has gone away (it shares standard output's pipe,
/// `2>&1 | head`), the process ends with status 141, as [`write_stdout`] does: `eprintln!`
/// panics there instead, and its panic message has nowhere to go either. Any other error is
/// ignored: there is nowhere left to report it.
pub fn write_stderr(args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let mut stderr = io::stderr().lock();
    if let Err(e) = stderr.write_fmt(args).and_then(|()| stderr.flush()) {
        if e.kind() == io::ErrorKind::BrokenPipe {
            std::process::exit(BROKEN_PIPE_STATUS);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("files-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp_file() {
        let dir = scratch("replace");
        let path = dir.join("a.bin");
        write_atomic(&path, b"one").expect("first write");
        write_atomic(&path, b"two").expect("second write");
        assert_eq!(fs::read(&path).expect("read"), b"two");
        assert_eq!(names(&dir), ["a.bin"]);
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: a failed write left `.NAME.tmpPID` behind.
    #[test]
    fn failed_commit_removes_the_temporary_file() {
        let dir = scratch("failed-commit");
        // The target is a folder: the rename fails after the bytes were written.
        let target = dir.join("out");
        fs::create_dir(&target).expect("folder");
        fs::write(target.join("keep"), b"x").expect("non-empty folder");
        assert!(write_atomic(&target, b"report").is_err());
        assert_eq!(names(&dir), ["out"]);
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn dropped_uncommitted_file_leaves_nothing() {
        let dir = scratch("dropped");
        let path = dir.join("r.json");
        let mut f = AtomicFile::create(&path).expect("create");
        f.write_all(b"half").expect("write");
        drop(f);
        assert!(names(&dir).is_empty());
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: temporaries of killed writers were never removed.
    #[test]
    fn temporaries_of_dead_processes_are_removed_on_the_next_write() {
        let dir = scratch("stale");
        // No process has id u32::MAX - 1; our own temporaries (live) are kept.
        let dead = format!(".checkpoint.postcard.tmp-{}-0", u32::MAX - 1);
        let live = format!(".checkpoint.postcard.tmp-{}-999", std::process::id());
        let other = format!(".metrics.csv.tmp-{}-0", u32::MAX - 1);
        for n in [&dead, &live, &other] {
            fs::write(dir.join(n), b"partial").expect("temp");
        }
        write_atomic(&dir.join("checkpoint.postcard"), b"new").expect("write");
        assert_eq!(names(&dir), [live.as_str(), &other, "checkpoint.postcard"]);
        assert_eq!(remove_stale_temps(&dir, None).expect("sweep"), 1);
        assert_eq!(names(&dir), [live.as_str(), "checkpoint.postcard"]);
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn temp_names_parse_only_our_pattern() {
        assert_eq!(parse_temp_name(".a.json.tmp-12-3"), Some(("a.json", 12)));
        assert_eq!(parse_temp_name("a.json.tmp-12-3"), None);
        assert_eq!(parse_temp_name(".a.json.tmp-x-3"), None);
        assert_eq!(parse_temp_name(".a.json.tmp-12"), None);
    }

    /// Regression: output paths were checked only after the work.
    #[test]
    fn check_output_catches_missing_folders_and_folders_and_leaves_nothing() {
        let dir = scratch("check");
        assert!(check_output(&dir.join("ok.svg")).is_ok());
        assert!(names(&dir).is_empty(), "the probe must not stay");
        let missing = check_output(&dir.join("nope").join("r.json")).expect_err("missing");
        assert!(missing.to_string().contains("folder does not exist"));
        assert!(check_output(&dir).is_err());
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: a FIFO given as an output was replaced by a regular file (so was a device,
    /// `/dev/null` included, when run as root): the bytes must go through the pipe.
    #[cfg(unix)]
    #[test]
    fn a_fifo_output_is_written_through_not_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let dir = scratch("fifo");
        let fifo = dir.join("out.fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.expect("mkfifo runs").success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || fs::read(fifo).expect("read the fifo"))
        };
        check_output(&fifo).expect("a fifo is a valid output");
        write_atomic(&fifo, b"report").expect("write through");
        assert_eq!(reader.join().expect("reader"), b"report");
        let kind = fs::symlink_metadata(&fifo)
            .expect("still there")
            .file_type();
        assert!(kind.is_fifo(), "the fifo was replaced: {kind:?}");
        assert_eq!(names(&dir), ["out.fifo"]);
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: a symbolic link given as an output was replaced by a file, its target left
    /// untouched. The link stays and its target gets the bytes (atomically).
    #[cfg(unix)]
    #[test]
    fn a_symlink_output_writes_its_target_and_stays_a_link() {
        let dir = scratch("symlink");
        let target = dir.join("real.json");
        fs::write(&target, b"old").expect("target");
        let link = dir.join("link.json");
        std::os::unix::fs::symlink("real.json", &link).expect("symlink");
        check_output(&link).expect("a link to a file is a valid output");
        write_atomic(&link, b"new").expect("write via the link");
        assert!(fs::symlink_metadata(&link)
            .expect("link")
            .file_type()
            .is_symlink());
        assert_eq!(fs::read(&target).expect("target"), b"new");
        assert_eq!(names(&dir), ["link.json", "real.json"]);
        // A dangling link is refused in one line rather than guessed at.
        let dangling = dir.join("dangling.json");
        std::os::unix::fs::symlink("missing/x.json", &dangling).expect("symlink");
        let e = write_atomic(&dangling, b"x").expect_err("dangling");
        assert!(e.to_string().contains("symbolic link"), "{e}");
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: `--scenario /dev/zero` (or any endless stream) grew until the process ran
    /// out of memory; a huge file was read whole.
    #[cfg(unix)]
    #[test]
    fn an_endless_or_huge_config_file_is_refused() {
        let e = read_config_text(Path::new("/dev/zero")).expect_err("endless");
        assert!(e.to_string().contains("larger than"), "{e}");
        let dir = scratch("big-config");
        let path = dir.join("huge.toml");
        let file = fs::File::create(&path).expect("create");
        file.set_len(300 << 20).expect("sparse 300 MB");
        let e = read_config_text(&path).expect_err("huge");
        assert!(e.to_string().contains("314572800 bytes"), "{e}");
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: a 1 GB file passed as a blob was read whole before its magic was
    /// checked.
    #[test]
    fn an_oversized_blob_file_is_refused_from_its_size() {
        let dir = scratch("big-blob");
        let path = dir.join("huge.postcard");
        let f = fs::File::create(&path).expect("create");
        // A sparse file: no disk space, but its length says 1 GiB.
        f.set_len(1 << 30).expect("set_len");
        let err = read_blob(&path).expect_err("too large");
        assert!(err.to_string().contains("larger than any blob"), "{err}");
        fs::remove_dir_all(&dir).expect("cleanup");
    }
}
