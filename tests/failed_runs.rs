//! Issue 54: a failed run is never silent, on the main job (`studies/honeycomb.yaml`, sampled
//! sequentially).
//!
//! - **Damaged recordings**: 10 replays of the main job's recordings, three recordings damaged in
//!   each by a seeded mutation (lines deleted, file cut short, garbage inserted; `tests/damage`).
//!   A damaged run changes what the sequence plans next, which a replay cannot serve: every replay
//!   must end with exit 1, no panic, no hang, and name every damaged recording with the damaged file.
//! - **A failing solver, live**: crushsim behind `tests/failing_solver/crushsim`, which fails one run
//!   in N (a crash, a hang past the timeout, or output cut short; chosen by a seeded hash of the run
//!   directory). With 1 in 10 the main job reaches its verdict; with 1 in 3 it reaches one or stops
//!   with an error naming the failures. Either way every failed run is named on stderr and counted in
//!   `results.json` (`runs.failed`, `runs.outcomes` per stage and class, `sampling.sequence[].failed`),
//!   no figure is `inf` or `NaN`, and every finished run's record is kept.
//! - **Resume**: the failing solver's study killed (SIGKILL) in the middle of a batch after runs
//!   failed, then run again: the same sequence, batch by batch, as a run never interrupted.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

use crate::crushsim_bin;
use crate::damage;

use damage::{Mutation, copy_recordings, mutate, root, run_lab};

/// The main job's recordings (every run a replay of it asks for).
fn recordings() -> PathBuf {
    root().join("fixtures/honeycomb")
}

fn recorded_keys() -> Vec<String> {
    lab::execute::replay::manifests(&recordings())
        .into_iter()
        .map(|m| m.key)
        .collect()
}

#[test]
fn a_sequential_replay_names_every_damaged_recording() {
    let keys = recorded_keys();
    assert!(keys.len() >= 40, "{} recordings", keys.len());
    let mut rng = ChaCha8Rng::seed_from_u64(54);
    let study = root().join("studies/honeycomb.yaml");
    for replay in 0..10 {
        let copy = tempfile::tempdir().unwrap();
        copy_recordings(&recordings(), &keys, copy.path());
        let mut chosen: Vec<usize> = Vec::new();
        while chosen.len() < 3 {
            let k = rng.random_range(0..keys.len());
            if !chosen.contains(&k) {
                chosen.push(k);
            }
        }
        let damaged: Vec<(&String, Mutation)> = chosen
            .iter()
            .map(|&k| (&keys[k], mutate(&mut rng, &copy.path().join(&keys[k]))))
            .collect();
        let out = tempfile::tempdir().unwrap();
        let (code, stderr) =
            run_lab(&study, copy.path(), out.path()).unwrap_or_else(|| panic!("replay {replay}: hung"));
        assert!(!stderr.contains("panicked"), "replay {replay}: panic\n{stderr}");
        assert_eq!(code, Some(1), "replay {replay}: exit {code:?}\n{stderr}");
        assert!(
            stderr.contains("are damaged") && !stderr.contains("the sampling plan changed"),
            "replay {replay}: the error does not say the recordings are damaged\n{stderr}"
        );
        for (key, m) in &damaged {
            let named = stderr
                .lines()
                .any(|l| l.contains(&format!("recording {}", copy.path().join(key).display())) && l.contains(m.file));
            assert!(
                named,
                "replay {replay}: damaged recording {key} ({} {}: {}) not named with its file\n{stderr}",
                m.kind, m.file, m.what
            );
        }
        // Only damaged recordings are called damaged.
        let called: BTreeSet<&str> = keys
            .iter()
            .filter(|k| stderr.contains(&format!("recording {} (", copy.path().join(k).display())))
            .map(String::as_str)
            .collect();
        let truth: BTreeSet<&str> = damaged.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(called, truth, "replay {replay}\n{stderr}");
    }
}

/// A copy of the main job for a live run behind the failing solver: paths made absolute, the
/// timeout 5 s (the wrapper's hang is 60 s).
fn failing_study(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("studies/honeycomb.yaml")).unwrap();
    let repo = format!("{}/", root().display());
    let text = text.replace("../", &repo).replace("timeout: 600", "timeout: 5");
    assert!(text.contains("timeout: 5"));
    let path = dir.join("honeycomb.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `lab run` of `study` into `out` with the failing solver on PATH (`every`: one run in how many
/// fails; `seed`: which).
fn failing_lab(study: &Path, out: &Path, every: u32, seed: u64) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_lab"));
    cmd.arg("run")
        .arg(study)
        .arg("--out")
        .arg(out)
        .args(["--jobs", "2"])
        .env(
            "PATH",
            format!("{}:/usr/bin:/bin", root().join("tests/failing_solver").display()),
        )
        .env("REAL_CRUSHSIM", crushsim_bin::crushsim())
        .env("FAIL_EVERY", every.to_string())
        .env("FAIL_SEED", seed.to_string());
    cmd
}

/// Every committed record in the run store `out`: key → outcome class.
fn records(out: &Path) -> Vec<(String, String)> {
    let mut all = Vec::new();
    for entry in std::fs::read_dir(out.join("results")).unwrap().filter_map(|e| e.ok()) {
        let Ok(bytes) = std::fs::read(entry.path()) else {
            continue;
        };
        let Ok(r) = serde_json::from_slice::<lab::execute::RunRecord>(&bytes) else {
            continue;
        };
        all.push((r.key.clone(), r.outcome.class().key()));
    }
    all
}

/// No word `inf` or `NaN` (any case) in `text`: a figure that could not be computed is said in words.
fn assert_no_non_finite(what: &str, text: &str) {
    let non_finite = |w: &str| ["inf", "nan", "infinity"].iter().any(|n| w.eq_ignore_ascii_case(n));
    let bad = text.lines().find(|l| {
        l.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .any(non_finite)
    });
    assert!(
        bad.is_none(),
        "{what} shows a non-finite figure: {}",
        bad.unwrap_or_default()
    );
}

/// The checks every live run behind the failing solver must pass, whether or not it reached a
/// verdict: every failed record named on stderr, no panic, no non-finite figure; with results, the
/// failed runs counted per stage and class and listed per batch. Returns the failed keys.
fn check_failures(o: &Output, out: &Path) -> BTreeSet<String> {
    let (stdout, stderr) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(!stderr.contains("panicked") && o.status.code() != Some(101), "{stderr}");
    assert_eq!(o.status.code(), Some(1), "runs failed: exit 1\n{stderr}");
    let failed: BTreeSet<String> = records(out)
        .into_iter()
        .filter(|(_, class)| class != "success")
        .map(|(k, _)| k)
        .collect();
    assert!(!failed.is_empty(), "the failing solver failed no run");
    for key in &failed {
        assert!(
            stderr
                .lines()
                .any(|l| l.starts_with("failed: ") && l.contains(key.as_str())),
            "failed run {key} not reported\n{stderr}"
        );
    }
    assert_no_non_finite("stderr", &stderr);
    assert_no_non_finite("stdout", &stdout);
    let Ok(text) = std::fs::read_to_string(out.join("results.json")) else {
        assert!(stderr.contains("error: "), "no results and no error\n{stderr}");
        return failed;
    };
    assert_no_non_finite("results.json", &text);
    assert_no_non_finite(
        "report.html",
        &std::fs::read_to_string(out.join("report.html")).unwrap(),
    );
    let results: Value = serde_json::from_str(&text).unwrap();
    let runs = &results["runs"];
    let per_stage: u64 = (runs["outcomes"].as_object().unwrap().values())
        .flat_map(|classes| classes.as_object().unwrap().values())
        .map(|n| n.as_u64().unwrap())
        .sum();
    assert_eq!(per_stage, runs["planned"].as_u64().unwrap(), "{runs}");
    let listed: BTreeSet<String> = (results["sampling"]["sequence"].as_array().unwrap().iter())
        .flat_map(|b| b["failed"].as_array().unwrap().iter())
        .map(|f| f["key"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(listed, failed, "sampling.sequence[].failed lists every failed run");
    assert_eq!(runs["failed"].as_u64().unwrap() as usize, failed.len(), "{runs}");
    // Failed probes are tried again elsewhere, up to three times: each further probes batch has as
    // many runs as the one before it failed, and the tries stop once none fails.
    let probes: Vec<&Value> = (results["sampling"]["sequence"].as_array().unwrap().iter())
        .filter(|b| b["stage"] == "probes")
        .collect();
    let failed_in = |b: &Value| b["failed"].as_array().unwrap().len();
    assert!((1..=4).contains(&probes.len()), "{probes:?}");
    for pair in probes.windows(2) {
        assert_eq!(
            pair[1]["runs"].as_u64().unwrap() as usize,
            failed_in(pair[0]),
            "{probes:?}"
        );
    }
    let last = probes[probes.len() - 1];
    assert!(failed_in(last) == 0 || probes.len() == 4, "{probes:?}");
    assert!(stdout.contains(&format!("{} failed", failed.len())), "{stdout}");
    failed
}

#[test]
fn a_failing_solver_is_planned_around_and_every_failure_reported() {
    let mut rng = ChaCha8Rng::seed_from_u64(54);
    let dir = tempfile::tempdir().unwrap();
    let study = failing_study(dir.path());
    for every in [10, 3] {
        let seed: u64 = rng.random_range(0..1_000_000);
        let out = dir.path().join(format!("one-in-{every}"));
        let o = failing_lab(&study, &out, every, seed).output().unwrap();
        eprintln!("1 in {every}: seed {seed}");
        let failed = check_failures(&o, &out);
        let stdout = String::from_utf8_lossy(&o.stdout);
        let stderr = String::from_utf8_lossy(&o.stderr);
        eprintln!("1 in {every} (seed {seed}): {} failed run(s)", failed.len());
        if every == 10 {
            assert!(
                stdout.contains("diagnosis: "),
                "1 in 10: no verdict\n{stdout}\n{stderr}"
            );
        } else {
            assert!(
                stdout.contains("diagnosis: ") || stderr.contains("failed"),
                "1 in 3: neither a verdict nor a reason\n{stderr}"
            );
        }
        if stdout.contains("diagnosis: ") {
            assert!(
                stdout.contains("caution: ") && stdout.contains("rest on the"),
                "{stdout}"
            );
        }
    }
}

#[test]
fn a_sequence_killed_in_a_batch_with_failed_runs_resumes_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let study = failing_study(dir.path());
    let (every, seed) = (10, 5_404);
    let whole = dir.path().join("whole");
    let o = failing_lab(&study, &whole, every, seed).output().unwrap();
    check_failures(&o, &whole);
    // Killed once a batch after the first is in flight and a run has failed, then run again.
    let cut = dir.path().join("cut");
    let mut child = failing_lab(&study, &cut, every, seed)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let in_flight = |out: &Path| -> bool {
        let Ok(text) = std::fs::read_to_string(out.join("sequence.json")) else {
            return false;
        };
        let Ok(s) = serde_json::from_str::<Value>(&text) else {
            return false;
        };
        let batches = s["sequence"].as_array().cloned().unwrap_or_default();
        let failed = batches
            .iter()
            .any(|b| !b["failed"].as_array().is_none_or(|f| f.is_empty()));
        failed
            && batches
                .last()
                .is_some_and(|b| b["state"] == "in flight" && b["batch"].as_u64() > Some(1))
    };
    while !in_flight(&cut) {
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before a batch with failures was cut"
        );
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "no batch in flight after failures"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(["status"])
        .arg(&study)
        .arg("--out")
        .arg(&cut)
        .output()
        .unwrap();
    let shown = String::from_utf8_lossy(&status.stdout);
    assert!(shown.contains("failed by stage: screening"), "lab status: {shown}");
    let o = failing_lab(&study, &cut, every, seed).output().unwrap();
    check_failures(&o, &cut);
    let batches = |out: &Path| -> Vec<Value> {
        let results: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
        let mut all = results["sampling"]["sequence"].as_array().unwrap().clone();
        for b in &mut all {
            b.as_object_mut().unwrap().remove("planning_seconds");
        }
        all
    };
    assert_eq!(
        batches(&cut),
        batches(&whole),
        "the resumed sequence differs from the uninterrupted one"
    );
}

#[test]
fn a_solver_that_always_fails_stops_the_study_naming_its_runs() {
    let dir = tempfile::tempdir().unwrap();
    let study = failing_study(dir.path());
    let out = dir.path().join("out");
    let o = failing_lab(&study, &out, 1, 7).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("screening: every one of its 12 run(s) failed, so there is nothing to fit"),
        "{stderr}"
    );
    assert_eq!(
        stderr.lines().filter(|l| l.starts_with("failed: ")).count(),
        12,
        "{stderr}"
    );
    assert_no_non_finite("stderr", &stderr);
}
