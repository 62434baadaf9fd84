//! Solver studies end to end through the `lab` binary, with `studies/solvers/beam.py` as the
//! solver: calibration through surrogates, resume after SIGKILL, template edits, the lock, Ctrl-C,
//! `lab status`, failed runs.
//!
//! The study (`studies/cantilever-compliance.yaml`) calibrates the compliance C = 1/E, in which the
//! beam's deflection is exactly linear: the linear surrogates are exact to rounding, so the
//! calibrated C must match the closed form's. The solver appends `start <run key>` to the file in
//! LAB_TEST_SOLVER_LOG at every start (a file outside `--out`, written only by the test solver), so
//! the tests see which runs were run, and how often. No assertion depends on timing: sleeps only
//! give the solver time to be interrupted in the middle of a sweep.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use serde_json::Value;

const STUDY: &str = "cantilever-compliance.yaml";
/// 3 designs × (4 samples + 2 check runs).
const SAMPLED: usize = 18;
/// Then 3 confirmation runs: the uncorrected simulation at its fitted parameters at each design
/// (no model error: the one model the verdict rests on).
const PLANNED: usize = SAMPLED + 3;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A copy of the study, its template, the solver and the tests CSV in a fresh directory (so that
/// a test may edit the template).
fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for rel in [
        STUDY,
        "cantilever-tests.csv",
        "cantilever-compliance/beam.txt.tera",
        "solvers/beam.py",
    ] {
        let to = dir.path().join(rel);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(repo().join("studies").join(rel), to).unwrap();
    }
    dir
}

fn lab(dir: &Path, args: &[&str], log: Option<&Path>, sleep: f64) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lab"));
    c.args(args)
        .current_dir(dir)
        .env("LAB_TEST_SOLVER_SLEEP", sleep.to_string());
    match log {
        Some(log) => c.env("LAB_TEST_SOLVER_LOG", log),
        None => c.env_remove("LAB_TEST_SOLVER_LOG"),
    };
    c
}

fn run(dir: &Path, out: &str, log: Option<&Path>) -> Output {
    lab(dir, &["run", STUDY, "--out", out, "--jobs", "2"], log, 0.0)
        .output()
        .unwrap()
}

fn spawn(dir: &Path, out: &str, log: Option<&Path>, sleep: f64) -> Child {
    let mut c = lab(dir, &["run", STUDY, "--out", out, "--jobs", "2"], log, sleep);
    c.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The run keys in the log, in order.
fn log_keys(log: &Path) -> Vec<String> {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.strip_prefix("start ").map(str::to_string))
        .collect()
}

/// Committed successful records: key → the record file's bytes.
fn successes(out: &Path) -> BTreeMap<String, Vec<u8>> {
    let Ok(entries) = std::fs::read_dir(out.join("results")) else {
        return BTreeMap::new();
    };
    entries
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let key = name.strip_suffix(".json")?.to_string();
            let bytes = std::fs::read(e.path()).ok()?;
            let record: Value = serde_json::from_slice(&bytes).ok()?;
            (record["outcome"]["class"] == "success").then_some((key, bytes))
        })
        .collect()
}

/// SIGKILLs every process working in a run directory under `out` (the solvers a SIGKILLed lab
/// leaves behind: nothing can stop them from inside lab), and waits until they are gone.
fn kill_orphans(out: &Path) {
    let runs = out.join("runs").canonicalize().unwrap_or(out.join("runs"));
    for _ in 0..100 {
        let mut found = false;
        for entry in std::fs::read_dir("/proc").unwrap().filter_map(|e| e.ok()) {
            let Ok(pid) = entry.file_name().to_string_lossy().parse::<i32>() else {
                continue;
            };
            let Ok(cwd) = std::fs::read_link(entry.path().join("cwd")) else {
                continue;
            };
            if cwd.starts_with(&runs) {
                found = true;
                let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), nix::sys::signal::Signal::SIGKILL);
            }
        }
        if !found {
            return;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    panic!("solver processes under {} would not die", runs.display());
}

/// Waits up to `limit` for `cond`.
fn wait_until(limit: Duration, mut cond: impl FnMut() -> bool) -> bool {
    let start = Instant::now();
    while start.elapsed() < limit {
        if cond() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    cond()
}

fn param(results: &Value, method: &str, name: &str) -> f64 {
    results["calibration"][method]["parameters"][name]
        .as_f64()
        .unwrap_or_else(|| panic!("{method}.{name}"))
}

#[test]
fn solver_study_calibrates_like_its_closed_form() {
    let dir = setup();
    let o = run(dir.path(), "out", None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let r: Value = serde_json::from_slice(&std::fs::read(dir.path().join("out/results.json")).unwrap()).unwrap();

    // The same study with the closed form in place of the solver.
    let closed = std::fs::read_to_string(dir.path().join(STUDY)).unwrap();
    let start = closed.find("  solver:").unwrap();
    let end = closed.find("experiments:").unwrap();
    let closed = format!(
        "{}  expression: \"4*F*L^3*C/(b*h^3)\"\n{}",
        &closed[..start],
        &closed[end..]
    )
    .replace("name: cantilever-compliance", "name: closed");
    std::fs::write(dir.path().join("closed.yaml"), closed).unwrap();
    let o = lab(dir.path(), &["run", "closed.yaml", "--out", "closed-out"], None, 0.0)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let c: Value = serde_json::from_slice(&std::fs::read(dir.path().join("closed-out/results.json")).unwrap()).unwrap();

    for method in ["least_squares", "sensitivity"] {
        let (via_runs, exact) = (param(&r, method, "C"), param(&c, method, "C"));
        // The surrogate equals the closed form to ~1e-16 relative; the optimisers stop within their
        // tolerances (≈1e-8 relative) of the same optimum.
        assert!(
            (via_runs / exact - 1.0).abs() < 1e-6,
            "{method}: C = {via_runs} vs closed form {exact}"
        );
    }
    // The paper's numbers (facts.md): E = 60,200 (least squares), 64,914 (sensitivity), ±1 MPa.
    assert!((1.0 / param(&r, "least_squares", "C") - 60_200.8).abs() < 1.0);
    assert!((1.0 / param(&r, "sensitivity", "C") - 64_913.9).abs() < 1.0);
    for design in ["h8", "h10", "h13"] {
        let s = &r["surrogates"][design];
        assert_eq!(s["kind"], "linear");
        assert_eq!((s["samples"].as_u64(), s["check_runs"].as_u64()), (Some(4), Some(2)));
        // Linear in C: the check error is rounding only.
        let e = s["check_max_relative_error"].as_f64().unwrap();
        assert!(e < 1e-12, "{design}: check error {e}");
    }
    assert_eq!(r["runs"]["planned"].as_u64(), Some(PLANNED as u64));
    assert_eq!(r["runs"]["succeeded"].as_u64(), Some(PLANNED as u64));
}

#[test]
fn killed_sweeps_resume_without_rerunning_or_losing_runs() {
    let dir = setup();
    let o = run(dir.path(), "straight", None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));

    let (out, log) = (dir.path().join("killed"), dir.path().join("solver.log"));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    // Per kill: the runs committed by then and how much of the log existed.
    let mut snapshots: Vec<(BTreeMap<String, Vec<u8>>, usize)> = Vec::new();
    let mut interrupted = 0;
    for _ in 0..4 {
        let mut child = spawn(dir.path(), "killed", Some(&log), 0.1);
        std::thread::sleep(Duration::from_millis(rng.random_range(300..1500)));
        if child.try_wait().unwrap().is_none() {
            interrupted += 1;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        kill_orphans(&out);
        snapshots.push((successes(&out), log_keys(&log).len()));
    }
    assert!(interrupted >= 1, "no kill hit a running sweep: the test proves nothing");
    let o = run(dir.path(), "killed", Some(&log));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));

    let keys = log_keys(&log);
    let last = successes(&out);
    assert_eq!(last.len(), PLANNED, "every planned run has its result");
    for (i, (finished, seen)) in snapshots.iter().enumerate() {
        let rerun: BTreeSet<&String> = keys[*seen..].iter().filter(|k| finished.contains_key(*k)).collect();
        assert!(
            rerun.is_empty(),
            "after kill {i}, finished runs were run again: {rerun:?}"
        );
        for (key, bytes) in finished {
            assert_eq!(
                last.get(key),
                Some(bytes),
                "after kill {i}, the record of {key} was lost or rewritten"
            );
        }
    }
    let straight = std::fs::read(dir.path().join("straight/results.json")).unwrap();
    let resumed = std::fs::read(out.join("results.json")).unwrap();
    assert!(
        straight == resumed,
        "results.json differs between the killed-and-resumed and the straight sweep"
    );
}

#[test]
fn editing_a_template_reruns_exactly_the_affected_runs() {
    let dir = setup();
    let log = dir.path().join("solver.log");
    let o = run(dir.path(), "out", Some(&log));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(log_keys(&log).len(), PLANNED);
    let before = successes(&dir.path().join("out"));
    let results_before = std::fs::read(dir.path().join("out/results.json")).unwrap();

    // A comment that only design h13's inputs get: its 6 runs change key, the others do not.
    let template = dir.path().join("cantilever-compliance/beam.txt.tera");
    let text = std::fs::read_to_string(&template).unwrap();
    std::fs::write(
        &template,
        format!("{text}{{% if design_name == \"h13\" %}}# edited\n{{% endif %}}"),
    )
    .unwrap();
    let o = run(dir.path(), "out", Some(&log));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));

    let rerun: BTreeSet<String> = log_keys(&log)[PLANNED..].iter().cloned().collect();
    let after = successes(&dir.path().join("out"));
    let new: BTreeSet<String> = after.keys().filter(|k| !before.contains_key(*k)).cloned().collect();
    assert_eq!(
        rerun.len(),
        7,
        "exactly h13's 4 samples, 2 check runs and its confirmation run rerun: {rerun:?}"
    );
    assert_eq!(rerun, new, "the rerun runs are exactly the runs with new keys");
    for rec in new.iter().map(|k| dir.path().join("out/runs").join(k).join("beam.txt")) {
        assert!(
            std::fs::read_to_string(&rec).unwrap().contains("# edited"),
            "{}",
            rec.display()
        );
    }
    // A comment does not change any response.
    assert!(results_before == std::fs::read(dir.path().join("out/results.json")).unwrap());
}

#[test]
fn second_run_on_the_same_out_is_refused_naming_the_holder() {
    let dir = setup();
    let mut first = spawn(dir.path(), "out", None, 0.5);
    let lock = dir.path().join("out/lock");
    let pid = first.id();
    let named = wait_until(Duration::from_secs(30), || {
        std::fs::read_to_string(&lock).is_ok_and(|t| t.contains(&format!("\"pid\":{pid}")))
    });
    assert!(named, "the first lab never took the lock");
    let o = run(dir.path(), "out", None);
    let message = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{message}");
    assert!(message.contains("another lab is running"), "{message}");
    assert!(
        message.contains(&format!("pid {pid}")),
        "the holder is not named: {message}"
    );
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid as i32), nix::sys::signal::Signal::SIGINT).unwrap();
    assert_eq!(first.wait().unwrap().code(), Some(130));
}

#[test]
fn ctrl_c_exits_130_keeps_finished_runs_and_status_counts_them() {
    let dir = setup();
    let (out, log) = (dir.path().join("out"), dir.path().join("solver.log"));
    let mut child = spawn(dir.path(), "out", Some(&log), 0.3);
    assert!(
        wait_until(Duration::from_secs(60), || successes(&out).len() >= 2),
        "no run finished"
    );

    // While it runs, status sees the live holder (the lock is held until lab exits).
    let o = lab(dir.path(), &["status", STUDY, "--out", "out"], None, 0.0)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(text.contains("a lab is running"), "{text}");

    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGINT,
    )
    .unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let kept = successes(&out);
    assert!(kept.len() >= 2 && kept.len() < PLANNED, "{} runs kept", kept.len());
    assert!(
        !out.join("results.json").exists(),
        "an interrupted sweep calibrates nothing"
    );

    let o = lab(dir.path(), &["status", STUDY, "--out", "out"], None, 0.0)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(o.status.code(), Some(0));
    // Interrupted in the sampling: the confirmation runs are not planned yet.
    let pending = SAMPLED - kept.len();
    let expected = format!("done {}, failed 0, running 0, pending {pending}", kept.len());
    assert!(text.contains(&expected), "`{expected}` not in: {text}");

    let seen = log_keys(&log).len();
    let o = run(dir.path(), "out", Some(&log));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let again: Vec<String> = log_keys(&log)[seen..]
        .iter()
        .filter(|k| kept.contains_key(*k))
        .cloned()
        .collect();
    assert!(again.is_empty(), "finished runs were run again: {again:?}");
    let o = lab(dir.path(), &["status", STUDY, "--out", "out"], None, 0.0)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains(&format!("done {PLANNED}, failed 0, running 0, pending 0")),
        "{text}"
    );
}

#[test]
fn failed_runs_exit_1_with_the_outcome_table_after_writing_results() {
    let dir = setup();
    // Runs with C above 1.9e-5 fail (exit 3); LHS with 4 samples has at most one per design there,
    // leaving 3 (≥ 2, enough for a linear surrogate) per design.
    let template = dir.path().join("cantilever-compliance/beam.txt.tera");
    let text = std::fs::read_to_string(&template).unwrap();
    std::fs::write(
        &template,
        format!("{text}fail = {{% if C * 100000 > 1.9 %}}1{{% else %}}0{{% endif %}}\n"),
    )
    .unwrap();
    let o = run(dir.path(), "out", None);
    let message = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{message}");
    assert!(message.contains("non_zero_exit"), "no outcome table: {message}");
    assert!(message.contains("exit code 3"), "failed runs not listed: {message}");
    let r: Value = serde_json::from_slice(&std::fs::read(dir.path().join("out/results.json")).unwrap()).unwrap();
    let failed = r["runs"]["failed"].as_u64().unwrap();
    assert!(failed >= 1, "the template should have failed some runs");
    let o = lab(dir.path(), &["status", STUDY, "--out", "out"], None, 0.0)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains(&format!("failed {failed}, running 0, pending 0")),
        "{text}"
    );
}

#[test]
fn example_study_bayesian_is_fed_the_runs_and_matches_the_paper() {
    // studies/cantilever-command.yaml: E itself, GP surrogates, all three methods; the Bayesian
    // emulator is fitted to the 36 sample runs of the three designs.
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(["run", "studies/cantilever-command.yaml", "--jobs", "2", "--out"])
        .arg(out.path())
        .current_dir(repo())
        .env_remove("LAB_TEST_SOLVER_LOG")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let r: Value = serde_json::from_slice(&std::fs::read(out.path().join("results.json")).unwrap()).unwrap();
    // Same tolerances as tests/cantilever.rs: ±1 MPa least squares, ±2 MPa sensitivity (GP surrogate
    // error ~3e-6 relative, measured at the check runs), 1.5 % Bayesian (emulator-induced shift).
    assert!((param(&r, "least_squares", "E") - 60_200.8).abs() <= 1.0);
    assert!((param(&r, "sensitivity", "E") - 64_913.9).abs() <= 2.0);
    let bayes = param(&r, "bayesian", "E");
    assert!((bayes / 64_911.0 - 1.0).abs() <= 0.015, "bayesian E = {bayes}");
    // The paper's check: each surrogate within 5 % at 5 check runs.
    for design in ["h8", "h10", "h13"] {
        let e = r["surrogates"][design]["check_max_relative_error"].as_f64().unwrap();
        assert!(e < 0.05, "{design}: {e}");
        assert_eq!(r["surrogates"][design]["check_runs"].as_u64(), Some(5));
    }
    // Its tests have no replicates and no stated uncertainty: the noise comes from the residuals,
    // so no model is said to fit, not even where the solver confirms it at its fitted point.
    let d = &r["diagnosis"];
    assert_eq!(d["noise"]["kind"], "from_residuals");
    assert_eq!(d["verdict"], "too_few_tests");
    let summary = d["summary"].as_str().unwrap();
    assert!(!summary.contains("fits the tests"), "{summary}");
    let confirmed = summary
        .lines()
        .find(|l| l.contains("Solver runs at the fitted parameters"));
    assert!(
        confirmed.is_some_and(|l| l.contains("which is no test of fit: the tests have no replicates")),
        "{summary}"
    );
}

/// `studies/cantilever-extension.yaml` with the shear extension given a range (`shear: {min: 0,
/// max: 2}`, screened at 1): the loop calibrates it through 7 designs × (20 + 2) new runs (GP over
/// E × shear). Copied into `dir` as `ranged.yaml`.
fn setup_ranged() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for rel in [
        "cantilever-extension.yaml",
        "cantilever-tests.csv",
        "cantilever-extension/beam.txt.tera",
        "solvers/beam.py",
    ] {
        let to = dir.path().join(rel);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(repo().join("studies").join(rel), to).unwrap();
    }
    let study = std::fs::read_to_string(dir.path().join("cantilever-extension.yaml")).unwrap();
    let ranged = study.replace("extension: {shear: 1}", "extension: {shear: {min: 0, max: 2}}");
    assert_ne!(ranged, study, "the study's shear extension moved");
    std::fs::write(dir.path().join("ranged.yaml"), ranged).unwrap();
    dir
}

/// 7 designs × (8 samples + 2 checks) + 7 × 8 screening runs, then the loop's 7 × (20 + 2).
const RANGED_SCREENING: usize = 7 * 10 + 7 * 8;
const RANGED_LOOP: usize = 7 * 22;
/// The confirmation runs: the uncorrected simulation and the shear model at their fitted
/// parameters, at the 7 designs.
const RANGED_CONFIRM: usize = 7 * 2;
const RANGED_ALL: usize = RANGED_SCREENING + RANGED_LOOP + RANGED_CONFIRM;

fn ranged_lab(dir: &Path, out: &str, log: &Path, sleep: f64) -> Command {
    lab(
        dir,
        &["run", "ranged.yaml", "--out", out, "--jobs", "2"],
        Some(log),
        sleep,
    )
}

#[test]
fn killed_in_the_loop_resumes_without_rerunning_and_recovers_the_shear_term() {
    let dir = setup_ranged();
    let straight_log = dir.path().join("straight.log");
    let o = ranged_lab(dir.path(), "straight", &straight_log, 0.0).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(log_keys(&straight_log).len(), RANGED_ALL);
    let r: Value = serde_json::from_slice(&std::fs::read(dir.path().join("straight/results.json")).unwrap()).unwrap();
    let d = &r["diagnosis"];
    assert_eq!(d["cause"], "shear deformation", "{}", d["summary"]);
    let x = &d["extensions"][0];
    assert_eq!(x["runs"]["planned"].as_u64(), Some(RANGED_LOOP as u64));
    // The tests are the Timoshenko beam exactly (shear = 1, E0 = 68,000): the GP over E × shear
    // reproduces the beam to about 1e-4 relative, so both come back within 0.5 %.
    for (name, truth) in [("E", 68_000.0), ("shear", 1.0)] {
        let v = x["parameters"][name].as_f64().unwrap();
        assert!((v / truth - 1.0).abs() < 0.005, "{name} = {v}: {x}");
    }

    // Killed (SIGKILL) while the loop's runs are under way, then run again.
    let (out, log) = (dir.path().join("killed"), dir.path().join("killed.log"));
    let mut child = ranged_lab(dir.path(), "killed", &log, 0.05)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let in_loop = wait_until(Duration::from_secs(120), || {
        out.join("extension-plan.json").exists() && log_keys(&log).len() >= RANGED_SCREENING + 10
    });
    child.kill().unwrap();
    child.wait().unwrap();
    kill_orphans(&out);
    assert!(in_loop, "the kill did not land during the loop's runs");
    let (finished, seen) = (successes(&out), log_keys(&log).len());
    assert!(
        seen < RANGED_SCREENING + RANGED_LOOP,
        "the loop had ended before the kill"
    );
    let o = ranged_lab(dir.path(), "killed", &log, 0.0).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let keys = log_keys(&log);
    let rerun: BTreeSet<&String> = keys[seen..].iter().filter(|k| finished.contains_key(*k)).collect();
    assert!(rerun.is_empty(), "finished runs were run again: {rerun:?}");
    let distinct: BTreeSet<&String> = keys.iter().collect();
    assert_eq!(distinct.len(), RANGED_ALL);
    // Started twice: only runs started before the kill without a committed record then — in flight
    // (--jobs 2), or exited and being judged (the executor gives a slot back before it judges and
    // commits, so under load more than two) — and each of those once.
    let mut starts: BTreeMap<&String, usize> = BTreeMap::new();
    for k in &keys {
        *starts.entry(k).or_default() += 1;
    }
    let before: BTreeSet<&String> = keys[..seen].iter().collect();
    for (k, n) in &starts {
        assert!(*n <= 2, "{k} started {n} times");
        assert!(
            *n == 1 || before.contains(*k) && !finished.contains_key(*k),
            "{k} started twice without having been cut off by the kill"
        );
    }
    let status = lab(dir.path(), &["status", "ranged.yaml", "--out", "killed"], None, 0.0)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&status.stdout);
    let all = RANGED_ALL;
    assert!(text.contains(&format!("{all} planned run(s): done {all}")), "{text}");
    let straight = std::fs::read(dir.path().join("straight/results.json")).unwrap();
    let resumed = std::fs::read(out.join("results.json")).unwrap();
    assert!(
        straight == resumed,
        "results.json differs between the killed-and-resumed and the straight run"
    );
}
