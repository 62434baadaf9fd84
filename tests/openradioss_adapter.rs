//! The `openradioss` adapter on broken outputs, without a solver: copies of one recorded run of
//! `studies/honeycomb-openradioss.yaml` (fixtures/honeycomb-openradioss), each broken one way, are
//! judged as a replay judges them (the run's rendered deck beside the outputs). Each must give the
//! outcome a real failure of that kind gives, naming the file — never a success, never a panic:
//!
//! | broken how | outcome |
//! |---|---|
//! | none | success, the recorded response bit for bit |
//! | T01 cut inside a time step | incomplete_output (mainT01, "cut short") |
//! | T01 ending early at a step boundary | incomplete_output ("short of the termination time") |
//! | one step taken out of the middle | incomplete_output ("gap in the history") |
//! | T01 missing / garbage | bad_response (missing / unparseable) |
//! | engine listing without NORMAL TERMINATION | bad_response (missing) |
//! | engine listing saying the run stopped early | failure_text (main_0001.out) |
//! | engine listing with ERROR TERMINATION | failure_text (main_0001.out) |
//! | starter listing counting an error | failure_text (main_0000.out) |

use std::path::{Path, PathBuf};

use lab::execute::{Adapter, Outcome};
use lab::extract::adapters::openradioss::OpenRadiossAdapter;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn adapter() -> OpenRadiossAdapter {
    let study = lab::study::load(&repo().join("studies/honeycomb-openradioss.yaml")).unwrap();
    let lab::study::Simulation::Solver(sim) = &study.simulation else {
        panic!("a solver study")
    };
    lab::extract::adapters::openradioss(sim).unwrap()
}

/// The first recording (by key) and the record lab made of it.
fn recording() -> (PathBuf, serde_json::Value) {
    let dir = repo().join("fixtures/honeycomb-openradioss");
    let mut keys: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("manifest.json").is_file())
        .collect();
    keys.sort();
    let at = keys
        .into_iter()
        .next()
        .expect("recordings in fixtures/honeycomb-openradioss");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(at.join("manifest.json")).unwrap()).unwrap();
    (at, manifest)
}

/// A judging directory: the recording's outputs and its deck (from the manifest), then `edit`.
fn judged(edit: &dyn Fn(&Path)) -> Result<lab::execute::Judged, Outcome> {
    let (rec, manifest) = recording();
    let tmp = tempfile::tempdir().unwrap();
    for e in std::fs::read_dir(&rec).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, tmp.path().join(p.file_name().unwrap())).unwrap();
    }
    let deck = manifest["inputs"]["main.k"]["text"]
        .as_str()
        .expect("the deck's text in the manifest");
    std::fs::write(tmp.path().join("main.k"), deck).unwrap();
    edit(tmp.path());
    let a = adapter();
    match a.find_failure(tmp.path()) {
        Some(f) => Err(f),
        None => a.judge(tmp.path()),
    }
}

/// Byte offsets of the T01's records: (start, end) of each.
fn records(t01: &[u8]) -> Vec<(usize, usize)> {
    let mut r = radioss_th::record::Records::new(t01);
    let mut out = Vec::new();
    while !r.at_end() {
        let rec = r.next_record("test").unwrap();
        out.push((rec.offset, r.offset()));
    }
    out
}

/// Records per time step of the fixture's T01 (time, globals, parts, interface group, node group).
const PER_STEP: usize = 5;

/// A new T01 from the old one's bytes and its records' offsets.
type Edit = dyn Fn(&[u8], &[(usize, usize)]) -> Vec<u8>;

fn edit_t01(dir: &Path, f: &Edit) {
    let path = dir.join("mainT01");
    let bytes = std::fs::read(&path).unwrap();
    let recs = records(&bytes);
    std::fs::write(&path, f(&bytes, &recs)).unwrap();
}

fn append(dir: &Path, name: &str, text: &str) {
    let path = dir.join(name);
    let mut s = std::fs::read_to_string(&path).unwrap();
    s.push_str(text);
    std::fs::write(path, s).unwrap();
}

#[track_caller]
fn incomplete(r: Result<lab::execute::Judged, Outcome>, phrase: &str) {
    match r {
        Err(Outcome::IncompleteOutput { file, detail, .. }) => {
            assert_eq!(file, "mainT01");
            assert!(detail.contains(phrase), "{detail}");
        }
        other => panic!("expected incomplete output ({phrase}), got {other:?}"),
    }
}

#[track_caller]
fn failure_text(r: Result<lab::execute::Judged, Outcome>, listing: &str, phrase: &str) {
    match r {
        Err(Outcome::FailureText { file, line }) => {
            assert_eq!(file, listing);
            assert!(line.contains(phrase), "{line}");
        }
        other => panic!("expected failure text in {listing}, got {other:?}"),
    }
}

#[test]
fn an_intact_recording_gives_its_recorded_response() {
    let (rec, _) = recording();
    let key = rec.file_name().unwrap().to_string_lossy().into_owned();
    let j = judged(&|_| {}).unwrap();
    // The response the fixtures' replay commits (tests/openradioss_study.rs replays the study).
    let th = radioss_th::read(&rec.join("mainT01")).unwrap();
    assert!(th.times.len() > 50, "{key}: {} steps", th.times.len());
    assert!(j.response > 0.0 && j.quality.is_some(), "{j:?}");
}

#[test]
fn a_cut_or_short_history_is_incomplete() {
    // Cut inside the last step's interface record.
    incomplete(
        judged(&|d| edit_t01(d, &|b, r| b[..r[r.len() - 2].0 + 10].to_vec())),
        "cut short",
    );
    // Ends cleanly 10 steps early: a run that stopped writing.
    incomplete(
        judged(&|d| edit_t01(d, &|b, r| b[..r[r.len() - 10 * PER_STEP].0].to_vec())),
        "short of the termination time",
    );
    // Step 40 taken out.
    incomplete(
        judged(&|d| {
            edit_t01(d, &|b, r| {
                let steps = radioss_th::parse(b).unwrap().times.len();
                let first_step = r.len() - PER_STEP * steps;
                let (a, z) = (r[first_step + 40 * PER_STEP].0, r[first_step + 41 * PER_STEP].0);
                [&b[..a], &b[z..]].concat()
            })
        }),
        "gap in the history",
    );
}

#[test]
fn a_missing_or_garbage_history_is_a_bad_response() {
    match judged(&|d| std::fs::remove_file(d.join("mainT01")).unwrap()) {
        Err(Outcome::BadResponse { problem, detail }) => {
            assert_eq!(problem, lab::execute::ResponseProblem::Missing, "{detail}");
        }
        other => panic!("{other:?}"),
    }
    for garbage in [vec![0u8; 0], vec![0xff; 4000], b"not a time history\n".repeat(50)] {
        match judged(&|d| std::fs::write(d.join("mainT01"), &garbage).unwrap()) {
            Err(Outcome::BadResponse { .. } | Outcome::IncompleteOutput { .. }) => {}
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn listings_that_report_trouble_fail_the_run() {
    match judged(&|d| {
        let path = d.join("main_0001.out");
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("NORMAL TERMINATION", "");
        std::fs::write(path, text).unwrap();
    }) {
        Err(Outcome::BadResponse { detail, .. }) => assert!(detail.contains("NORMAL TERMINATION"), "{detail}"),
        other => panic!("{other:?}"),
    }
    failure_text(
        judged(&|d| append(d, "main_0001.out", " ** RUN STOPPED: ENERGY ERROR LIMIT REACHED\n")),
        "main_0001.out",
        "stopped early",
    );
    failure_text(
        judged(&|d| append(d, "main_0001.out", "\n     ERROR TERMINATION\n")),
        "main_0001.out",
        "ERROR TERMINATION",
    );
    failure_text(
        judged(&|d| {
            let path = d.join("main_0000.out");
            let text = std::fs::read_to_string(&path)
                .unwrap()
                .replace(" 0 ERROR(S)", " 1 ERROR(S)");
            std::fs::write(path, text).unwrap();
        }),
        "main_0000.out",
        "1 ERROR(S)",
    );
}
