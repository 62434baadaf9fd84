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
        let page = std::fs::read_to_string(out.path().join("report.html")).unwrap();
        for text in [d["summary"].as_str().unwrap().to_string(), page_text(&page)] {
            significance_is_backed(&study.display().to_string(), &text);
        }
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} studies checked");
}

/// The report's text without tags (entities for <, > and & decoded).
fn page_text(html: &str) -> String {
    let tags = regex::Regex::new(r"<[^>]*>").unwrap();
    tags.replace_all(html, "\n")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
        .replace("&#39;", "'")
        .replace("&quot;", "\"")
}

/// Every sentence that calls something significant (not "no significant …") quotes a p-value below
/// the diagnosis's α = 0.01: the words come from the same test and level as the decision.
fn significance_is_backed(what: &str, text: &str) {
    let p_value = regex::Regex::new(r"p (=|<) ?([0-9.]+(e-?[0-9]+)?)").unwrap();
    let negated = regex::Regex::new(r"(?i)\b(no|not|nothing|without)( \w+)? significant").unwrap();
    for sentence in text.split(['\n']).flat_map(|l| l.split(". ")) {
        if !sentence.contains("significant") || negated.is_match(sentence) {
            continue;
        }
        let ps: Vec<f64> = p_value
            .captures_iter(sentence)
            .filter_map(|c| c[2].trim_end_matches('.').parse::<f64>().ok())
            .collect();
        if ps.is_empty() {
            continue; // a definition ("explains misfit (p < α/K)"), not a finding
        }
        let smallest = ps.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(
            smallest < 0.01,
            "{what}: {sentence:?} calls a p-value of {smallest} significant"
        );
    }
}

/// The check itself: the caption the issue found ("p = 0.39: a significant trend") fails it, the
/// same sentence with the test that decided passes.
#[test]
#[should_panic(expected = "calls a p-value of 0.39 significant")]
fn a_significant_word_above_alpha_is_caught() {
    significance_is_backed("caption", "Rank correlation 0.39 (p = 0.39): a significant trend.");
}

#[test]
fn a_significant_word_backed_by_its_test_passes() {
    significance_is_backed(
        "caption",
        "Rank correlation 0.39 (p = 0.39; linear trend p = 0.0027): a significant trend at α = 0.01.",
    );
    significance_is_backed(
        "caption",
        "Rank correlation 0.2 (p = 0.5): no significant trend at α = 0.01.",
    );
}
