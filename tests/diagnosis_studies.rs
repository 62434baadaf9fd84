//! Every study in `studies/` through the `lab` binary: its diagnosis's verdict follows from the
//! evidence recorded beside it, the summary starts with the verdict, and a next test is given.
//! Studies whose solver is not installed (CalculiX) are left to their live tests; the honeycomb
//! studies replay their recordings, the curves study in tests/honeycomb_diagnosis.rs, with the
//! same checks.

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
        if study.ends_with("honeycomb-diagnosis-curves.yaml") {
            continue; // tests/honeycomb_diagnosis.rs replays it (two minutes) with the same checks
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
        eprintln!("{}: {}", study.display(), r["diagnosis"]["headline"]);
        verdict_common::assert_study_reads_its_verdict(&study.display().to_string(), &stdout, out.path(), &r);
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} studies checked");
}

/// The check itself: the caption the issue found ("p = 0.39: a significant trend") fails it, the
/// same sentence with the test that decided passes.
#[test]
#[should_panic(expected = "calls a p-value of 0.39 significant")]
fn a_significant_word_above_alpha_is_caught() {
    verdict_common::significance_is_backed("caption", "Rank correlation 0.39 (p = 0.39): a significant trend.");
}

#[test]
fn a_significant_word_backed_by_its_test_passes() {
    verdict_common::significance_is_backed(
        "caption",
        "Rank correlation 0.39 (p = 0.39; linear trend p = 0.0027): a significant trend at α = 0.01.",
    );
    verdict_common::significance_is_backed(
        "caption",
        "Rank correlation 0.2 (p = 0.5): no significant trend at α = 0.01.",
    );
}
