//! Helpers of the live Slurm tests (tests/slurm_live.rs, tests/slurm_interrupt.rs): find the
//! Slurm of scripts/slurm-up.sh (skip without one, fail with CI=true), copy a study into a temp
//! directory, read the journal, the solvers' start logs and the queue.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// SLURM_CONF (from the environment, or the one scripts/slurm-up.sh writes) when Slurm answers.
pub fn slurm_conf() -> Option<String> {
    let conf = std::env::var("SLURM_CONF").unwrap_or_else(|_| "/tmp/lab-slurm/slurm.conf".into());
    let ok = Path::new(&conf).is_file()
        && Command::new("sinfo")
            .env("SLURM_CONF", &conf)
            .arg("-h")
            .output()
            .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "no Slurm answers in CI (SLURM_CONF={conf}): .ci/run must start it with scripts/slurm-up.sh"
        );
        eprintln!("SKIPPED: no Slurm (run scripts/slurm-up.sh and export SLURM_CONF); CI=true makes this fail");
        return None;
    }
    Some(conf)
}

/// `lab ARGS` in `dir` against the Slurm of `conf`, without the test solvers' hooks.
pub fn lab(conf: &str, dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lab"));
    c.args(args)
        .current_dir(dir)
        .env("SLURM_CONF", conf)
        .env_remove("LAB_TEST_SOLVER_LOG")
        .env_remove("LAB_TEST_SOLVER_SLEEP");
    c
}

/// A PATH holding crushsim's directory and the system's (Slurm's clients are in /usr/bin).
pub fn path_with_crushsim() -> String {
    let crushsim = crate::crushsim_bin::crushsim();
    format!("{}:/usr/bin:/bin", crushsim.parent().unwrap().display())
}

pub fn results(out: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap()
}

/// Copies `files` (relative to studies/) into `to`, then applies `edits` to `yaml` there.
pub fn copy_study(to: &Path, files: &[&str], yaml: &str, edits: &[(&str, &str)]) -> PathBuf {
    for rel in files {
        let dest = to.join(rel);
        std::fs::create_dir_all(dest.parent().unwrap()).unwrap();
        std::fs::copy(repo().join("studies").join(rel), dest).unwrap();
    }
    let path = to.join(yaml);
    let mut text = std::fs::read_to_string(&path).unwrap();
    for (from, into) in edits {
        assert!(text.contains(from), "test bug: `{from}` not in {yaml}");
        text = text.replacen(from, into, 1);
    }
    std::fs::write(&path, text).unwrap();
    path
}

/// The compliance study's solver runs: its 18 sampled runs, then the solver at the fitted
/// parameters at each of its 3 tested designs (the confirmation runs).
pub const COMPLIANCE_RUNS: usize = 21;

/// The compliance study (18 runs of studies/solvers/beam.py and 3 confirmation runs) in `to`, with
/// `slurm` settings.
pub fn compliance_study(to: &Path, slurm: &str) -> PathBuf {
    copy_study(
        to,
        &[
            "cantilever-compliance.yaml",
            "cantilever-tests.csv",
            "cantilever-compliance/beam.txt.tera",
            "solvers/beam.py",
        ],
        "cantilever-compliance.yaml",
        &[("    timeout: 60\n", &format!("    timeout: 60\n    slurm: {slurm}\n"))],
    )
}

/// Journal entries (OUT/slurm/*.json) of `out`.
pub fn journal_files(out: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(out.join("slurm"))
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "json"))
                .collect()
        })
        .unwrap_or_default()
}

/// Job ids of the journal entries that have one.
pub fn journaled_ids(out: &Path) -> Vec<String> {
    journal_files(out)
        .iter()
        .filter_map(|p| {
            let v: serde_json::Value = serde_json::from_slice(&std::fs::read(p).ok()?).ok()?;
            v["job_id"].as_str().map(str::to_string)
        })
        .collect()
}

/// Polls `done` every 50 ms for up to `limit`; whether it turned true.
pub fn wait_until(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    done()
}

/// Run directory names in a solver start log (`start <name>` per start), in order.
pub fn starts(log: &Path) -> Vec<String> {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .map(|l| l.strip_prefix("start ").unwrap_or(l).to_string())
        .collect()
}

/// Asserts no run started twice; the set of runs started.
#[track_caller]
pub fn started_once(log: &Path) -> BTreeSet<String> {
    let all = starts(log);
    let distinct: BTreeSet<String> = all.iter().cloned().collect();
    assert_eq!(all.len(), distinct.len(), "a run was executed twice: {all:?}");
    distinct
}

/// Which of `ids` squeue still shows as pending, running or completing (its default states).
pub fn queued(conf: &str, ids: &[String]) -> Vec<String> {
    if ids.is_empty() {
        return Vec::new();
    }
    let o = Command::new("squeue")
        .env("SLURM_CONF", conf)
        .args(["-h", "-o", "%i", "-j", &ids.join(",")])
        .output()
        .unwrap();
    String::from_utf8_lossy(&o.stdout)
        .split_whitespace()
        .map(str::to_string)
        .collect()
}

/// Run records of `out` by key: (outcome class, the record).
pub fn records(out: &Path) -> Vec<(String, String, serde_json::Value)> {
    let mut all = Vec::new();
    for e in std::fs::read_dir(out.join("results")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "json") {
            continue;
        }
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
        let key = p.file_stem().unwrap().to_string_lossy().into_owned();
        let class = v["outcome"]["class"].as_str().unwrap_or_default().to_string();
        all.push((key, class, v));
    }
    all
}

/// Keys of the records of `out` whose outcome class is `class`.
pub fn keys_with(out: &Path, class: &str) -> BTreeSet<String> {
    records(out)
        .into_iter()
        .filter(|(_, c, _)| c == class)
        .map(|(k, _, _)| k)
        .collect()
}

/// Runs `lab` again (`cmd`, solver starts logged to `log`): it must finish (exit 0) after re-attaching
/// to the jobs left by the previous `lab`. Returns its stderr and the distinct runs started in all.
pub fn rerun_reattaches(mut cmd: Command, log: &Path) -> (String, BTreeSet<String>) {
    let o = cmd.env("LAB_TEST_SOLVER_LOG", log).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("re-attached"), "{err}");
    (err, started_once(log))
}
