//! Every study in `studies/` through the `lab` binary: its diagnosis's verdict follows from the
//! evidence recorded beside it, the summary starts with the verdict, and a next test is given.
//! Studies whose solver is not installed (CalculiX) are left to their live tests; the honeycomb
//! studies replay their recordings, the curves study in tests/honeycomb_diagnosis.rs, with the
//! same checks.

use crate::verdict_common;

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

/// `lab run` shows the answer and the tables; the diagnosis's statistical headline and its evidence
/// lines come with `--verbose` (and are always in the report), after the same first three lines.
#[test]
fn verbose_adds_the_evidence_after_the_same_answer() {
    let run = |verbose: bool| {
        let out = tempfile::tempdir().unwrap();
        let mut c = Command::new(env!("CARGO_BIN_EXE_lab"));
        c.args(["run", "studies/cantilever-diagnosis.yaml", "--out"])
            .arg(out.path())
            .current_dir(root());
        if verbose {
            c.arg("--verbose");
        }
        let o = c.output().unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.path().join("results.json")).unwrap()).unwrap();
        (String::from_utf8_lossy(&o.stdout).into_owned(), r)
    };
    let (plain, r) = run(false);
    let (verbose, _) = run(true);
    let d = &r["diagnosis"];
    let headline = d["headline"].as_str().unwrap();
    let evidence: Vec<&str> = d["evidence"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap())
        .collect();
    assert!(!evidence.is_empty());
    verdict_common::assert_answer_first("cantilever-diagnosis", &plain, &r);
    verdict_common::assert_answer_first("cantilever-diagnosis --verbose", &verbose, &r);
    assert!(
        !plain.contains(headline),
        "the default screen carries the headline:\n{plain}"
    );
    assert!(
        plain.contains(&format!(
            "({} evidence lines: `lab run --verbose`, or the report)",
            evidence.len() + d["limits"].as_array().unwrap().len()
        )),
        "{plain}"
    );
    assert!(verbose.contains(&format!("diagnosis: {headline}")), "{verbose}");
    for e in evidence {
        assert!(!plain.contains(e), "evidence on the default screen: {e}");
        assert!(verbose.contains(e), "evidence missing under --verbose: {e}");
    }
    // Both end by naming what was written.
    for out in [&plain, &verbose] {
        let last: Vec<&str> = out.lines().rev().take(2).collect();
        assert!(
            last[1].starts_with("wrote ") && last[1].ends_with("results.json"),
            "{last:?}"
        );
        assert!(
            last[0].starts_with("wrote ") && last[0].ends_with("report.html"),
            "{last:?}"
        );
    }
}
