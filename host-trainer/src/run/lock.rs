//! One writer per folder: an advisory lock on a file in a run folder (held by `train` and
//! `export` for their whole life) or a sweep's `--out` (held by `sweep`).
//!
//! The operating system releases the lock when its holder dies, however it dies, so a lock
//! left by a killed process is taken over by the next one without any clean-up.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;

use crate::Error;

/// The lock file in a locked folder; it holds the holder's process id.
pub const LOCK: &str = ".host-trainer.lock";

/// A held lock; dropping it (or the process ending) releases it.
#[derive(Debug)]
pub struct FolderLock {
    _file: File,
}

/// Takes the folder's lock, or refuses with the process id of the one holding it.
pub fn acquire(dir: &Path) -> Result<FolderLock, Error> {
    let path = dir.join(LOCK);
    let io = |source| Error::Io {
        path: path.clone(),
        source,
    };
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&path)
        .map_err(io)?;
    match fs4::FileExt::try_lock(&file) {
        Ok(()) => {}
        Err(fs4::TryLockError::WouldBlock) => {
            let mut holder = String::new();
            // The holder wrote its pid right after locking; unreadable, it is still a holder.
            let _ = file.read_to_string(&mut holder);
            let holder = holder.trim();
            return Err(Error::Locked {
                path: dir.to_path_buf(),
                holder: if holder.is_empty() {
                    "another host-trainer process".to_string()
                } else {
                    format!("host-trainer process {holder}")
                },
            });
        }
        Err(fs4::TryLockError::Error(source)) => return Err(io(source)),
    }
    file.set_len(0).map_err(io)?;
    file.seek(SeekFrom::Start(0)).map_err(io)?;
    writeln!(file, "{}", std::process::id()).map_err(io)?;
    Ok(FolderLock { _file: file })
}

/// Who holds `dir`'s lock, if anyone does: the holder's process id as it wrote it (empty if
/// unreadable). Looks without taking the lock: a shared lock, held only for the look, so it
/// neither writes the file nor outlives this call.
pub fn holder(dir: &Path) -> Option<String> {
    let mut file = OpenOptions::new().read(true).open(dir.join(LOCK)).ok()?;
    match fs4::FileExt::try_lock_shared(&file) {
        Err(fs4::TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = file.read_to_string(&mut holder);
            Some(holder.trim().to_string())
        }
        // Not held (or not lockable at all): nobody is writing there.
        _ => None,
    }
}
