//! Every study in `studies/` through the `lab` binary: its diagnosis's verdict follows from the
//! evidence recorded beside it, the summary starts with the verdict, and a next test is given.
//! Studies whose solver is not installed (CalculiX) are left to their live tests; the honeycomb
//! studies replay their recordings.

mod verdict_common;

use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn every_study_verdict_follows_its_evidence() {
    let mut studies: Vec<PathBuf> = std::fs::read_dir(root().join("studies"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .collect();
    studies.sort();
    let mut checked = 0;
    for study in studies {
        let text = std::fs::read_to_string(&study).unwrap();
        if text.contains("adapter: calculix") {
            continue; // tests/calculix_live.rs runs these with the solver
        }
        let out = tempfile::tempdir().unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_lab"))
            .arg("run")
            .arg(&study)
            .arg("--out")
            .arg(out.path())
            .current_dir(root())
            .env("PATH", "/usr/bin:/bin")
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}: {}",
            study.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.path().join("results.json")).unwrap()).unwrap();
        let d = &r["diagnosis"];
        eprintln!("{}: {}", study.display(), d["headline"]);
        verdict_common::assert_verdict_follows_evidence(d);
        let headline = d["headline"].as_str().unwrap();
        assert!(
            stdout.contains(&format!("diagnosis: {headline}")),
            "{}: the terminal does not lead with the verdict",
            study.display()
        );
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} studies checked");
}
