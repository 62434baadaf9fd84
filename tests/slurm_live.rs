//! `--executor slurm` against a real single-node Slurm (scripts/slurm-up.sh): the cantilever-command
//! study gives the same results as locally; a `lab` killed while its jobs are queued re-attaches on
//! the next `lab run`, and every run is executed exactly once (the test solver appends one line per
//! start to LAB_TEST_SOLVER_LOG). Skips with a message when no Slurm answers, except with CI=true.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// SLURM_CONF (from the environment, or the one scripts/slurm-up.sh writes) when Slurm answers.
fn slurm_conf() -> Option<String> {
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

fn lab(conf: &str, dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lab"));
    c.args(args)
        .current_dir(dir)
        .env("SLURM_CONF", conf)
        .env_remove("LAB_TEST_SOLVER_LOG");
    c
}

fn results(out: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap()
}

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

#[test]
fn killed_lab_reattaches_and_every_run_executes_once() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    // The compliance study (18 runs), one run per job so that jobs queue behind each other.
    for rel in [
        "cantilever-compliance.yaml",
        "cantilever-tests.csv",
        "cantilever-compliance/beam.txt.tera",
        "solvers/beam.py",
    ] {
        let to = tmp.path().join(rel);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(repo().join("studies").join(rel), to).unwrap();
    }
    let yaml = tmp.path().join("cantilever-compliance.yaml");
    let text = std::fs::read_to_string(&yaml)
        .unwrap()
        .replace("    timeout: 60\n", "    timeout: 60\n    slurm: {runs_per_job: 2}\n");
    std::fs::write(&yaml, text).unwrap();
    let log = tmp.path().join("solver.log");
    let args = [
        "run",
        "cantilever-compliance.yaml",
        "--executor",
        "slurm",
        "--out",
        "out",
    ];
    let mut child = lab(&conf, tmp.path(), &args)
        .env("LAB_TEST_SOLVER_LOG", &log)
        .env("LAB_TEST_SOLVER_SLEEP", "0.3")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Kill lab once it has submitted (journal entries exist) and before the runs are done.
    let journal = tmp.path().join("out/slurm");
    for _ in 0..200 {
        let n = std::fs::read_dir(&journal)
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
                    .count()
            })
            .unwrap_or(0);
        if n >= 3 {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let o = lab(&conf, tmp.path(), &args)
        .env("LAB_TEST_SOLVER_LOG", &log)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("re-attached"), "{err}");
    let starts: Vec<String> = std::fs::read_to_string(&log)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    let distinct: std::collections::BTreeSet<&String> = starts.iter().collect();
    assert_eq!(starts.len(), distinct.len(), "a run was executed twice: {starts:?}");
    assert_eq!(distinct.len(), 18, "{starts:?}");
}
