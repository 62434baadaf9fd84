//! The content-addressed run store.
//!
//! ```text
//! OUT/lock                 held while a lab works on OUT (see `lock`)
//! OUT/runs/<key>/          a run's work directory: rendered inputs, then the solver's outputs
//! OUT/results/<key>.json   the run's committed RunRecord
//! ```
//!
//! A key is the BLAKE3 hash of the rendered input files (sorted by relative path; each as its path
//! and its bytes, both length-prefixed), the argv and the adapter identity. Equal inputs give equal
//! keys, so a run whose inputs did not change is found again; a changed byte gives a new key.
//!
//! # Design note
//!
//! **States of a run, as the disk shows them.**
//!
//! ```text
//! absent ──prepare──► dir, no record ──commit──► dir + record (success: finished, never rerun)
//!  (no dir)           (inputs written;           dir + record (failure: kept for `lab status`,
//!                      solver may be running)                   rerun by the next `lab run`)
//! ```
//!
//! **Invariants.** A record is committed atomically: written to `results/.<key>.json.tmp`,
//! fsynced, renamed over `results/<key>.json`, then the directory is fsynced. Readers see the old
//! record or the new one, never a torn file, whatever moment the process dies at. A record is
//! written only once its run is over (its outputs judged, or the run given up: a lost or cancelled
//! Slurm job), never while a solver may still change its outcome. Only the lock holder prepares
//! and deletes directories; only successful records count as finished.
//!
//! **What a kill leaves.** At most: a `.tmp` record (never read; deleted at the next open) and run
//! directories without a record (half-done). Opening the store takes the lock, loads every record,
//! deletes leftover temp files and deletes the half-done run directories, so they are rerun from
//! scratch — except the directories that another owner claims ([`RunStore::open_keeping`]: the
//! Slurm executor's journal of runs handed to jobs, which may be writing there now). A solver
//! that outlived a SIGKILLed `lab` may still write into a directory the next open deletes; that
//! run is redone, never mistaken for finished, because only a committed record finishes a run.
//!
//! **Why.** Content addressing makes resume and "rerun exactly what changed" the same mechanism,
//! with no index to keep consistent; the atomic commit is the single point at which a run becomes
//! finished, so every crash is recoverable by looking at the records alone. The store does not know
//! who else uses run directories: the claim comes in as a function, so the run engine's executors
//! (local, Slurm) sit above the store and the store imports neither.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::{self, File};
use std::io::Write;
use std::path::{Component, Path, PathBuf};

use super::RunRecord;
use super::lock::{LockError, OutLock};

/// Subdirectory of run work directories.
pub const RUNS_DIR: &str = "runs";
/// Subdirectory of committed records.
pub const RESULTS_DIR: &str = "results";

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error(transparent)]
    Lock(#[from] LockError),
    #[error("{}: {source}", .path.display())]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{}: not a run record: {source}", .path.display())]
    Corrupt { path: PathBuf, source: serde_json::Error },
    #[error("input file path `{}` must be relative and stay inside the run directory", .0.display())]
    BadInputPath(PathBuf),
}

impl From<StoreError> for crate::error::Error {
    fn from(e: StoreError) -> Self {
        crate::error::Error::Failed(e.to_string())
    }
}

fn io_at(path: &Path) -> impl FnOnce(std::io::Error) -> StoreError + '_ {
    move |source| StoreError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The key of a run: hash of its inputs `(relative path, bytes)`, argv and adapter identity.
/// The order of `inputs` does not matter.
pub fn run_key(inputs: &[(PathBuf, Vec<u8>)], argv: &[String], adapter_identity: &str) -> String {
    let mut sorted: Vec<&(PathBuf, Vec<u8>)> = inputs.iter().collect();
    sorted.sort_by(|a, b| a.0.cmp(&b.0));
    let mut h = blake3::Hasher::new();
    let mut field = |bytes: &[u8]| {
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    field(b"lab-run-key/1");
    field(adapter_identity.as_bytes());
    field(&(argv.len() as u64).to_le_bytes());
    for a in argv {
        field(a.as_bytes());
    }
    field(&(sorted.len() as u64).to_le_bytes());
    for (path, bytes) in sorted {
        field(path.as_os_str().as_encoded_bytes());
        field(bytes);
    }
    // 128 bits: short enough for directory names, far from any chance collision.
    h.finalize().to_hex()[..32].to_string()
}

/// Writes `bytes` to `path` atomically and durably: temp file, fsync, rename, fsync of the directory.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().expect("a file path has a parent");
    let name = path.file_name().expect("a file path has a name").to_string_lossy();
    let tmp = dir.join(format!(".{name}.tmp"));
    {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    fs::rename(&tmp, path)?;
    File::open(dir)?.sync_all()
}

/// Commits records into a results directory. Cheap to clone; used by the executor's units, which
/// commit concurrently (each to its own key's file).
#[derive(Debug, Clone)]
pub struct Committer {
    results: PathBuf,
}

impl Committer {
    /// A committer into `results` (the Slurm worker commits without holding the store's lock).
    pub fn new(results: PathBuf) -> Self {
        Committer { results }
    }

    pub fn commit(&self, record: &RunRecord) -> Result<(), StoreError> {
        let path = self.results.join(format!("{}.json", record.key));
        let text = serde_json::to_vec_pretty(record).expect("records serialize");
        write_atomic(&path, &text).map_err(io_at(&path))
    }
}

/// The run store of one output directory, held under its lock.
#[derive(Debug)]
pub struct RunStore {
    out: PathBuf,
    records: BTreeMap<String, RunRecord>,
    /// Half-done run directories removed when the store was opened.
    cleaned: Vec<String>,
    _lock: OutLock,
}

impl RunStore {
    /// Creates `out` if needed, takes its lock, loads the records and cleans half-done runs, with
    /// no other owner of run directories (see [`RunStore::open_keeping`]).
    pub fn open(out: &Path) -> Result<RunStore, StoreError> {
        Self::open_keeping(out, |_| BTreeSet::new())
    }

    /// [`RunStore::open`], keeping the run directories that another owner claims: `claimed` is
    /// read under the lock and returns the keys whose directories are in use without a record yet
    /// (the Slurm executor's journal: runs handed to jobs). The store does not know who claims.
    pub fn open_keeping(out: &Path, claimed: impl FnOnce(&Path) -> BTreeSet<String>) -> Result<RunStore, StoreError> {
        fs::create_dir_all(out).map_err(io_at(out))?;
        let lock = OutLock::acquire(out)?;
        let runs = out.join(RUNS_DIR);
        let results = out.join(RESULTS_DIR);
        fs::create_dir_all(&runs).map_err(io_at(&runs))?;
        fs::create_dir_all(&results).map_err(io_at(&results))?;

        let records = load_records(&results, true)?;
        // Runs handed to someone else (Slurm jobs) and not yet collected: their directories are in use.
        let submitted = claimed(out);

        let mut cleaned = Vec::new();
        for entry in fs::read_dir(&runs).map_err(io_at(&runs))? {
            let path = entry.map_err(io_at(&runs))?.path();
            let key = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
            if !records.contains_key(&key) && !submitted.contains(&key) {
                remove_any(&path)?;
                cleaned.push(key);
            }
        }
        cleaned.sort();
        Ok(RunStore {
            out: out.to_path_buf(),
            records,
            cleaned,
            _lock: lock,
        })
    }

    pub fn out(&self) -> &Path {
        &self.out
    }

    /// The work directory of `key` (whether or not it exists).
    pub fn run_dir(&self, key: &str) -> PathBuf {
        self.out.join(RUNS_DIR).join(key)
    }

    /// Whether `key` has a committed success: such a run is never run again.
    pub fn is_finished(&self, key: &str) -> bool {
        self.records.get(key).is_some_and(|r| r.outcome.is_success())
    }

    /// The committed record of `key`, successful or not.
    pub fn record(&self, key: &str) -> Option<&RunRecord> {
        self.records.get(key)
    }

    /// Every committed record, by key.
    pub fn records(&self) -> impl Iterator<Item = &RunRecord> {
        self.records.values()
    }

    /// Keys of the half-done run directories removed by `open`.
    pub fn cleaned(&self) -> &[String] {
        &self.cleaned
    }

    /// Makes a fresh work directory for `key` holding exactly `inputs` (relative paths).
    /// Anything left by an earlier attempt (a failed run) is removed first.
    pub fn prepare(&self, key: &str, inputs: &[(PathBuf, Vec<u8>)]) -> Result<PathBuf, StoreError> {
        for (rel, _) in inputs {
            let inside = rel.components().all(|c| matches!(c, Component::Normal(_)));
            if !inside || rel.as_os_str().is_empty() {
                return Err(StoreError::BadInputPath(rel.clone()));
            }
        }
        let dir = self.run_dir(key);
        if fs::symlink_metadata(&dir).is_ok() {
            remove_any(&dir)?;
        }
        fs::create_dir_all(&dir).map_err(io_at(&dir))?;
        for (rel, bytes) in inputs {
            let path = dir.join(rel);
            if let Some(parent) = path.parent() {
                fs::create_dir_all(parent).map_err(io_at(parent))?;
            }
            fs::write(&path, bytes).map_err(io_at(&path))?;
        }
        Ok(dir)
    }

    /// A committer into this store's results directory, for the executor.
    pub fn committer(&self) -> Committer {
        Committer {
            results: self.out.join(RESULTS_DIR),
        }
    }

    /// Commits `record` durably and remembers it.
    pub fn commit(&mut self, record: RunRecord) -> Result<(), StoreError> {
        self.committer().commit(&record)?;
        self.remember(record);
        Ok(())
    }

    /// Removes the committed record of `key` (a failed one, before the run is submitted again).
    pub fn forget(&mut self, key: &str) -> Result<(), StoreError> {
        let path = self.out.join(RESULTS_DIR).join(format!("{key}.json"));
        match fs::remove_file(&path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io_at(&path)(e)),
            _ => {}
        }
        self.records.remove(key);
        Ok(())
    }

    /// Remembers a record already committed (by a [`Committer`]).
    pub fn remember(&mut self, record: RunRecord) {
        self.records.insert(record.key.clone(), record);
    }
}

/// Every committed record in `results`, by key; with `clean`, leftover temp files are deleted.
fn load_records(results: &Path, clean: bool) -> Result<BTreeMap<String, RunRecord>, StoreError> {
    let mut records = BTreeMap::new();
    let entries = match fs::read_dir(results) {
        Ok(entries) => entries,
        Err(e) if !clean && e.kind() == std::io::ErrorKind::NotFound => return Ok(records),
        Err(e) => return Err(io_at(results)(e)),
    };
    for entry in entries {
        let path = entry.map_err(io_at(results))?.path();
        let name = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
        if name.starts_with('.') && name.ends_with(".tmp") {
            if clean {
                fs::remove_file(&path).map_err(io_at(&path))?; // a commit that never reached its rename
            }
            continue;
        }
        let Some(key) = name.strip_suffix(".json") else {
            continue;
        };
        let bytes = fs::read(&path).map_err(io_at(&path))?;
        let record: RunRecord = serde_json::from_slice(&bytes).map_err(|source| StoreError::Corrupt {
            path: path.clone(),
            source,
        })?;
        records.insert(key.to_string(), record);
    }
    Ok(records)
}

/// What is in a store, read without its lock and without changing anything (for `lab status`).
#[derive(Debug, Default)]
pub struct Snapshot {
    pub records: BTreeMap<String, RunRecord>,
    /// Keys that have a run directory.
    pub run_dirs: std::collections::BTreeSet<String>,
}

impl Snapshot {
    pub fn read(out: &Path) -> Result<Snapshot, StoreError> {
        let records = load_records(&out.join(RESULTS_DIR), false)?;
        let runs = out.join(RUNS_DIR);
        let run_dirs = match fs::read_dir(&runs) {
            Ok(entries) => entries
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect(),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Default::default(),
            Err(e) => return Err(io_at(&runs)(e)),
        };
        Ok(Snapshot { records, run_dirs })
    }
}

fn remove_any(path: &Path) -> Result<(), StoreError> {
    let meta = fs::symlink_metadata(path).map_err(io_at(path))?;
    let r = if meta.is_dir() {
        fs::remove_dir_all(path)
    } else {
        fs::remove_file(path)
    };
    r.map_err(io_at(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs(pairs: &[(&str, &str)]) -> Vec<(PathBuf, Vec<u8>)> {
        pairs
            .iter()
            .map(|(p, b)| (PathBuf::from(p), b.as_bytes().to_vec()))
            .collect()
    }

    #[test]
    fn key_ignores_order_and_sees_every_part() {
        let argv = vec!["solver".to_string(), "-i".to_string()];
        let k = run_key(&inputs(&[("a", "1"), ("b", "2")]), &argv, "id");
        assert_eq!(k, run_key(&inputs(&[("b", "2"), ("a", "1")]), &argv, "id"));
        assert_eq!(k.len(), 32);
        assert_ne!(k, run_key(&inputs(&[("a", "1"), ("b", "3")]), &argv, "id"));
        assert_ne!(k, run_key(&inputs(&[("a", "1"), ("c", "2")]), &argv, "id"));
        assert_ne!(k, run_key(&inputs(&[("a", "1"), ("b", "2")]), &argv[..1], "id"));
        assert_ne!(k, run_key(&inputs(&[("a", "1"), ("b", "2")]), &argv, "id2"));
        // Length prefixes: moving bytes between a name and its content changes the key.
        assert_ne!(
            run_key(&inputs(&[("ab", "c")]), &argv, "id"),
            run_key(&inputs(&[("a", "bc")]), &argv, "id")
        );
    }

    #[test]
    fn prepare_refuses_paths_leaving_the_run_directory() {
        let out = tempfile::tempdir().unwrap();
        let store = RunStore::open(out.path()).unwrap();
        for bad in ["../x", "/etc/x", "a/../../x", ""] {
            assert!(
                matches!(
                    store.prepare("k", &inputs(&[(bad, "1")])),
                    Err(StoreError::BadInputPath(_))
                ),
                "{bad}"
            );
        }
        let dir = store.prepare("k", &inputs(&[("sub/in.txt", "1")])).unwrap();
        assert_eq!(fs::read_to_string(dir.join("sub/in.txt")).unwrap(), "1");
    }
}
