//! One `lab` per output directory.
//!
//! `OUT/lock` is held with an exclusive `flock` for as long as the [`OutLock`] lives. The kernel
//! drops an `flock` when the last descriptor of the open file is closed, so a holder killed with
//! SIGKILL never leaves the directory stuck: there is no stale-pid check to get wrong. The file's
//! text (pid, host, start time) only *names* the holder for the error message; it never decides
//! who holds the lock. Files opened by std carry `O_CLOEXEC`, so solver children do not inherit
//! the descriptor (and cannot keep the lock alive after `lab` dies).
//!
//! `flock` is advisory and, on some network filesystems, local to one host; the host name in the
//! message helps to spot a holder on another machine.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// Name of the lock file inside the output directory.
pub const LOCK_FILE: &str = "lock";

/// Who holds a lock, as written into the lock file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Holder {
    pub pid: u32,
    pub host: String,
    /// Seconds since the Unix epoch.
    pub started: u64,
}

impl Holder {
    fn me() -> Self {
        let host = nix::unistd::gethostname()
            .map(|h| h.to_string_lossy().into_owned())
            .unwrap_or_else(|_| "?".into());
        Holder {
            pid: std::process::id(),
            host,
            started: super::now_ms() / 1000,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error("{}: another lab is running on this output directory ({}); wait for it or stop it", .path.display(), describe(.holder))]
    Held { path: PathBuf, holder: Option<Holder> },
    #[error("{}: {source}", .path.display())]
    Io { path: PathBuf, source: std::io::Error },
}

fn describe(holder: &Option<Holder>) -> String {
    match holder {
        Some(h) => format!(
            "pid {} on host {}, started {} s ago (unix time {})",
            h.pid,
            h.host,
            (super::now_ms() / 1000).saturating_sub(h.started),
            h.started
        ),
        None => "holder not yet written".to_string(),
    }
}

/// The held lock on an output directory; released on drop (or by the kernel when the process dies).
#[derive(Debug)]
pub struct OutLock {
    file: File,
    path: PathBuf,
}

impl OutLock {
    /// Takes the lock on `out` (which must exist) without waiting; refuses if another process holds it.
    pub fn acquire(out: &Path) -> Result<OutLock, LockError> {
        let path = out.join(LOCK_FILE);
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        // Not truncated on open: the text belongs to the current holder until we hold the lock.
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let holder = written_holder(&mut file);
                return Err(LockError::Held { path, holder });
            }
            Err(TryLockError::Error(e)) => return Err(io(e)),
        }
        let text = serde_json::to_string(&Holder::me()).expect("holder serializes");
        file.set_len(0).map_err(io)?;
        file.seek(SeekFrom::Start(0)).map_err(io)?;
        file.write_all(text.as_bytes()).map_err(io)?;
        file.sync_all().map_err(io)?;
        Ok(OutLock { file, path })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Whether a live process holds the lock on `out`, without taking it for longer than a check and
/// without touching the holder's text (for `lab status`). `None` when nobody holds it (or there is
/// no lock file yet); `Some(holder)` when someone does (`holder` may be unreadable: `None` inside).
pub fn probe(out: &Path) -> Result<Option<Option<Holder>>, LockError> {
    let path = out.join(LOCK_FILE);
    let io = |source| LockError::Io {
        path: path.clone(),
        source,
    };
    let mut file = match OpenOptions::new().read(true).open(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io(e)),
    };
    // A shared lock conflicts with the holder's exclusive one and never blocks another reader.
    match file.try_lock_shared() {
        Ok(()) => {
            let _ = file.unlock();
            Ok(None)
        }
        Err(TryLockError::WouldBlock) => Ok(Some(written_holder(&mut file))),
        Err(TryLockError::Error(e)) => Err(io(e)),
    }
}

/// The holder the lock file names, when its text reads as one.
fn written_holder(file: &mut File) -> Option<Holder> {
    let mut text = String::new();
    file.read_to_string(&mut text)
        .ok()
        .and_then(|_| serde_json::from_str(&text).ok())
}

impl Drop for OutLock {
    fn drop(&mut self) {
        // Closing the file releases the lock anyway; unlocking first makes the order explicit.
        let _ = self.file.unlock();
    }
}
