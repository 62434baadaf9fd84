//! `--executor slurm` against a real single-node Slurm (scripts/slurm-up.sh): the cantilever-command
//! and honeycomb studies give the same results as locally (honeycomb live, crushsim on the PATH the
//! jobs inherit); a `lab` killed while its jobs are queued re-attaches on the next `lab run` and
//! every run is executed exactly once (the test solvers, beam.py and crushsim, append one line per
//! start to LAB_TEST_SOLVER_LOG); a journaled job that no Slurm source knows is given up as `lost`
//! after `slurm.lost_after` and its run is submitted again by the next `lab run`. Skips with a
//! message when no Slurm answers, except with CI=true. Ctrl-C: tests/slurm_interrupt.rs.

use crate::slurm_common;

use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

use slurm_common::*;

#[test]
fn slurm_gives_the_local_results() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let study = "studies/cantilever-command.yaml";
    let (slurm, local) = (tmp.path().join("slurm"), tmp.path().join("local"));
    let o = lab(&conf, &repo(), &["run", study, "--executor", "slurm", "--out"])
        .arg(&slurm)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let o = lab(&conf, &repo(), &["run", study, "--jobs", "2", "--out"])
        .arg(&local)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(results(&slurm)["calibration"], results(&local)["calibration"]);
    // The job scripts are kept: one per run directory.
    let runs: Vec<_> = std::fs::read_dir(slurm.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(runs.iter().all(|d| d.join("lab.job.sh").is_file()));
}

/// Kills `child` once `out` holds `n` journal entries (jobs submitted, runs not yet done). Its
/// stderr goes to `out/../lab-killed.stderr`, shown when the entries never appear.
fn kill_when_journaled(child: &mut std::process::Child, out: &Path, n: usize) {
    let submitted = wait_until(Duration::from_secs(60), || {
        journal_files(out).len() >= n || child.try_wait().is_ok_and(|s| s.is_some())
    }) && journal_files(out).len() >= n;
    let _ = child.kill();
    let status = child.wait().unwrap();
    let stderr = std::fs::read_to_string(out.with_file_name("lab-killed.stderr")).unwrap_or_default();
    assert!(submitted, "lab never journaled {n} Slurm jobs ({status}):\n{stderr}");
}

/// `lab` with stderr to the file [`kill_when_journaled`] shows.
fn spawn_to_be_killed(mut cmd: std::process::Command, dir: &Path) -> std::process::Child {
    let stderr = std::fs::File::create(dir.join("lab-killed.stderr")).unwrap();
    cmd.stdout(Stdio::null()).stderr(stderr).spawn().unwrap()
}

#[test]
fn killed_lab_reattaches_and_every_run_executes_once() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    // The compliance study (18 runs and 3 confirmation runs), two runs per job so that jobs queue
    // behind each other.
    compliance_study(tmp.path(), "{runs_per_job: 2}");
    let log = tmp.path().join("solver.log");
    let args = [
        "run",
        "cantilever-compliance.yaml",
        "--executor",
        "slurm",
        "--out",
        "out",
    ];
    let mut cmd = lab(&conf, tmp.path(), &args);
    cmd.env("LAB_TEST_SOLVER_LOG", &log).env("LAB_TEST_SOLVER_SLEEP", "0.3");
    let mut child = spawn_to_be_killed(cmd, tmp.path());
    kill_when_journaled(&mut child, &tmp.path().join("out"), 3);
    let (_, started) = rerun_reattaches(lab(&conf, tmp.path(), &args), &log);
    assert_eq!(started.len(), COMPLIANCE_RUNS);
}

/// The three methods' results of the honeycomb study.
fn assert_honeycomb_calibrated(r: &serde_json::Value) {
    for m in ["least_squares", "sensitivity", "bayesian"] {
        let s = r["calibration"][m]["parameters"]["sigma_y"].as_f64().unwrap();
        // As the replay (tests/honeycomb_study.rs): above the truth 185 by the hidden hardening.
        assert!((188.0..=205.0).contains(&s), "{m}: {s}");
        assert_eq!(r["calibration"][m]["predictions"].as_array().unwrap().len(), 3, "{m}");
    }
    // Live with crushsim, the sequence asks for the runs its replay has recordings of.
    assert_eq!(r["runs"]["succeeded"], main_job_runs() as u64);
}

/// The main job's runs: its recordings in fixtures/honeycomb (the sequence live with crushsim asks
/// for exactly these, tests/honeycomb_study.rs).
fn main_job_runs() -> usize {
    std::fs::read_dir(repo().join("fixtures/honeycomb"))
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("manifest.json").is_file())
        .count()
}

/// The runs submitted, summed over stderr's "submitted N run(s) in M Slurm job(s)" lines (one per
/// batch of the sequence), and the number of lines.
fn submitted(stderr: &str) -> (usize, usize) {
    let counts: Vec<usize> = stderr
        .lines()
        .filter_map(|l| l.split("submitted ").nth(1))
        .filter(|rest| rest.contains(" run(s) in ") && rest.contains("Slurm job(s)"))
        .map(|rest| rest.split(' ').next().unwrap().parse().unwrap())
        .collect();
    (counts.iter().sum(), counts.len())
}

#[test]
fn honeycomb_through_slurm_gives_the_local_live_results() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let (slurm, local) = (tmp.path().join("slurm"), tmp.path().join("local"));
    let study = "studies/honeycomb.yaml";
    let o = lab(&conf, &repo(), &["run", study, "--executor", "slurm", "--out"])
        .arg(&slurm)
        .env("PATH", path_with_crushsim())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        !err.contains("replaying"),
        "crushsim is on PATH: the runs are live\n{err}"
    );
    // One submission per batch of the sequence, every run submitted once.
    let (runs, batches) = submitted(&err);
    assert_eq!(runs, main_job_runs(), "{err}");
    assert!(batches >= 3, "{err}");
    // Every run was executed by crushsim inside a job: the job's worker reports each run's
    // outcome in the job's output, and the run's own stdout carries crushsim's banner (the job
    // found crushsim on the PATH it inherited from sbatch's default --export=ALL).
    let mut reported = std::collections::BTreeSet::new();
    for e in std::fs::read_dir(slurm.join("slurm")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "out") {
            for line in std::fs::read_to_string(&p).unwrap().lines() {
                let (key, outcome) = line.split_once(' ').unwrap();
                assert_eq!(outcome, "success", "{}: {line}", p.display());
                reported.insert(key.to_string());
            }
        }
    }
    assert_eq!(reported.len(), main_job_runs());
    for key in &reported {
        let stdout = std::fs::read_to_string(slurm.join("runs").join(key).join("lab.stdout")).unwrap();
        assert!(stdout.contains("crushsim: a STAND-IN for LS-DYNA"), "{key}: {stdout}");
    }
    let o = lab(&conf, &repo(), &["run", study, "--jobs", "2", "--out"])
        .arg(&local)
        .env("PATH", path_with_crushsim())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(!err.contains("replaying"), "{err}");
    let (s, l) = (results(&slurm), results(&local));
    assert_honeycomb_calibrated(&s);
    assert_eq!(s["calibration"], l["calibration"]);
    assert_eq!(s["splits"], l["splits"]);
    assert_eq!(s["surrogates"], l["surrogates"]);
}

/// studies/honeycomb.yaml in `to`, its relative paths made absolute, with `slurm` settings.
fn honeycomb_study(to: &Path, slurm: &str) {
    let root = repo();
    let abs = |rel: &str| root.join(rel).display().to_string();
    copy_study(
        to,
        &["honeycomb.yaml"],
        "honeycomb.yaml",
        &[
            (
                "../templates/honeycomb/main.k.tera",
                &abs("templates/honeycomb/main.k.tera"),
            ),
            (
                "replay: ../fixtures/honeycomb",
                &format!("replay: {}", abs("fixtures/honeycomb")),
            ),
            (
                "../fixtures/honeycomb/tests/experiments.csv",
                &abs("fixtures/honeycomb/tests/experiments.csv"),
            ),
            (
                "../fixtures/honeycomb/tests/{design}-*.csv",
                &abs("fixtures/honeycomb/tests/{design}-*.csv"),
            ),
            ("    timeout: 600\n", &format!("    timeout: 600\n    slurm: {slurm}\n")),
        ],
    );
}

#[test]
fn honeycomb_killed_lab_reattaches_and_every_run_executes_once() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    // The sequence's batches, 3 runs per job: jobs queue behind each other on the node's 2 CPUs.
    honeycomb_study(tmp.path(), "{runs_per_job: 3}");
    let (log, out) = (tmp.path().join("crushsim.log"), tmp.path().join("out"));
    let args = ["run", "honeycomb.yaml", "--executor", "slurm", "--out", "out"];
    let mut cmd = lab(&conf, tmp.path(), &args);
    cmd.env("PATH", path_with_crushsim()).env("LAB_TEST_SOLVER_LOG", &log);
    let mut child = spawn_to_be_killed(cmd, tmp.path());
    kill_when_journaled(&mut child, &out, 3);
    // Killed while jobs were queued: entries remain and runs are unfinished.
    assert!(!journal_files(&out).is_empty());
    assert!(keys_with(&out, "success").len() < main_job_runs());
    let mut rerun = lab(&conf, tmp.path(), &args);
    rerun.env("PATH", path_with_crushsim());
    let (err, started) = rerun_reattaches(rerun, &log);
    assert!(!err.contains("replaying"), "{err}");
    assert_eq!(started.len(), main_job_runs());
    assert_eq!(
        started,
        keys_with(&out, "success"),
        "the runs started are the runs recorded"
    );
    assert!(journal_files(&out).is_empty());
    assert_honeycomb_calibrated(&results(&out));
}

#[test]
fn a_job_no_slurm_source_knows_is_lost_and_its_run_resubmitted() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    compliance_study(tmp.path(), "{runs_per_job: 6, lost_after: 2}");
    let (log, out) = (tmp.path().join("solver.log"), tmp.path().join("out"));
    let args = [
        "run",
        "cantilever-compliance.yaml",
        "--executor",
        "slurm",
        "--out",
        "out",
    ];
    let o = lab(&conf, tmp.path(), &args).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    // One run's job vanishes: its record is gone and its journal entry names an id that
    // squeue, scontrol and the jobcomp record do not know (ids here are far below it).
    let before = keys_with(&out, "success");
    let key = before.iter().next().unwrap().clone();
    std::fs::remove_file(out.join("results").join(format!("{key}.json"))).unwrap();
    let entry = lab::execute::slurm::JobEntry {
        token: "vanished0000".into(),
        job_id: Some("9999999".into()),
        keys: vec![key.clone()],
        submitted_ms: 1,
    };
    std::fs::write(out.join("slurm/vanished0000.json"), serde_json::to_vec(&entry).unwrap()).unwrap();
    let t = std::time::Instant::now();
    let o = lab(&conf, tmp.path(), &args)
        .env("LAB_TEST_SOLVER_LOG", &log)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "the lost run is a failed run\n{err}");
    assert!(err.contains("re-attached to Slurm job 9999999"), "{err}");
    assert!(t.elapsed() >= Duration::from_secs(2), "given up before lost_after");
    let records = records(&out);
    let (_, class, record) = records.iter().find(|(k, _, _)| *k == key).unwrap();
    assert_eq!(class, "lost");
    assert_eq!(record["outcome"]["job"], "9999999");
    let detail = record["outcome"]["detail"].as_str().unwrap();
    assert!(detail.contains("squeue, scontrol and the jobcomp record"), "{detail}");
    assert!(err.contains("lost: Slurm job 9999999"), "{err}");
    assert!(journal_files(&out).is_empty());
    // Nothing that had finished ran again; what ran is the solver at the parameters fitted
    // without the lost run (the confirmation runs, [`lab::pipeline`]).
    let started = starts(&log);
    assert!(started.iter().all(|k| !before.contains(k)), "{started:?}");
    // The next run submits the lost run, and only it: with it the fit is the first one again,
    // whose confirmation runs are done.
    let log = tmp.path().join("solver-again.log");
    let o = lab(&conf, tmp.path(), &args)
        .env("LAB_TEST_SOLVER_LOG", &log)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("submitted 1 run(s) in 1 Slurm job(s)"), "{err}");
    assert_eq!(starts(&log), vec![key]);
    assert!(before.is_subset(&keys_with(&out, "success")));
}

/// The solver in the loop through Slurm: studies/honeycomb-diagnosis.yaml live (crushsim inside
/// the jobs, sampled sequentially) submits the screening's batches, its probes, then, once the
/// screening has named strain hardening, the loop's batches over sigma_y × etan, one submission per
/// batch and every run once; the diagnosis equals the one replayed from the recordings (made
/// locally), submitted in as many submissions as the replay has batches.
#[test]
fn the_loops_runs_go_through_slurm_and_give_the_recorded_diagnosis() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let (slurm, replayed) = (tmp.path().join("slurm"), tmp.path().join("replayed"));
    let study = "studies/honeycomb-diagnosis.yaml";
    let o = lab(&conf, &repo(), &["run", study, "--executor", "slurm", "--out"])
        .arg(&slurm)
        .env("PATH", path_with_crushsim())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        !err.contains("replaying"),
        "crushsim is on PATH: the runs are live\n{err}"
    );
    let (runs, batches) = submitted(&err);
    let o = lab(
        &conf,
        &repo(),
        &["run", study, "--replay", "fixtures/honeycomb-diagnosis", "--out"],
    )
    .arg(&replayed)
    .output()
    .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let (s, r) = (results(&slurm), results(&replayed));
    assert_eq!(runs as u64, r["sampling"]["runs"].as_u64().unwrap(), "{err}");
    assert_eq!(batches, r["sampling"]["sequence"].as_array().unwrap().len(), "{err}");
    let in_the_loop = r["runs"]["in_the_loop"].as_u64().unwrap();
    assert!(in_the_loop > 0);
    assert_eq!(s["diagnosis"]["extensions"][0]["runs"]["succeeded"], in_the_loop);
    assert_eq!(s["diagnosis"], r["diagnosis"]);
}
