//! The main job with the fixed design it had before it sampled sequentially (LHS, 24 samples and
//! 5 check runs per design: 246 runs with the hardening's probes and loop), recorded live with
//! crushsim once per test binary. The main job itself samples sequentially, so a run that
//! fails or is left out changes the runs it asks for next; tests that damage recordings on purpose
//! and need every replay to ask for the same runs use this variant instead.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use super::crushsim_bin;

/// The main job's sampling, replaced by the fixed design.
pub const SEQUENTIAL: &str =
    "sampling: {method: sequential, batch: 3, seed: 1, replaces: {method: lhs, count: 24, seed: 1, check_runs: 5}}";
/// The fixed design: 24 Latin-hypercube samples and 5 check runs per design.
pub const FIXED: &str = "sampling: {method: lhs, count: 24, seed: 1, check_runs: 5}";
/// Samples per design in `FIXED`.
#[allow(dead_code)] // not every test binary that includes this module reads it
pub const SAMPLES: u64 = 24;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The main job with the fixed design and `extra` lines after `surrogate: linear` (e.g. a
/// `quality:` line), written into `dir` with its paths made absolute.
#[allow(dead_code)]
pub fn study(dir: &Path, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("studies/honeycomb.yaml")).unwrap();
    assert!(text.contains(SEQUENTIAL), "the main job's sampling changed");
    let text = text
        .replace(SEQUENTIAL, FIXED)
        .replace("../", &format!("{}/", root().display()))
        .replace("  surrogate: linear\n", &format!("  surrogate: linear\n{extra}"));
    let path = dir.join("honeycomb.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The fixed-design main job's recordings, made live with crushsim on first use.
#[allow(dead_code)] // not every test binary that includes this module records
pub fn recordings() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let work = tempfile::tempdir().unwrap();
        let study = study(work.path(), "");
        let path = format!("{}:/usr/bin:/bin", crushsim_bin::crushsim().parent().unwrap().display());
        let o = Command::new(env!("CARGO_BIN_EXE_lab"))
            .arg("run")
            .arg(&study)
            .arg("--record")
            .arg(dir.path())
            .arg("--out")
            .arg(work.path().join("out"))
            .env("PATH", path)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
        dir
    })
    .path()
}

/// The recording keys in `dir`, sorted.
#[allow(dead_code)]
pub fn keys(dir: &Path) -> Vec<String> {
    let mut keys: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("manifest.json").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    keys.sort();
    keys
}
