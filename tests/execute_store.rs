//! The run store: atomic commits, resume, input changes, half-done directories.

use crate::solvers;

use std::path::PathBuf;

use lab::execute::store::RESULTS_DIR;
use lab::execute::{Event, Outcome, RunRecord, RunSpec, RunStore};
use solvers::*;

fn record(key: &str, response: f64) -> RunRecord {
    RunRecord {
        key: key.into(),
        outcome: Outcome::Success,
        attempts: 1,
        started_ms: 1,
        ended_ms: 2,
        response: Some(response),
        quality: None,
        warnings: Vec::new(),
    }
}

#[test]
fn commit_is_durable_exact_and_leaves_no_temp_files() {
    let out = tempfile::tempdir().unwrap();
    // Values whose shortest decimal form needs 17 digits or sits near the subnormal range: a
    // round trip through JSON must give back the same bits (results are compared bit for bit).
    let values = [
        0.1 + 0.2,
        1.0 / 3.0,
        5e-324,
        1.7976931348623157e308,
        -2.2250738585072014e-308,
        0.30472,
    ];
    {
        let mut store = RunStore::open(out.path()).unwrap();
        for (i, v) in values.iter().enumerate() {
            store.commit(record(&format!("k{i}"), *v)).unwrap();
        }
    }
    let results = out.path().join(RESULTS_DIR);
    let names: Vec<String> = std::fs::read_dir(&results)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into())
        .collect();
    assert!(
        names.iter().all(|n| n.ends_with(".json") && !n.starts_with('.')),
        "{names:?}"
    );
    let store = RunStore::open(out.path()).unwrap();
    for (i, v) in values.iter().enumerate() {
        let got = store.record(&format!("k{i}")).unwrap().response.unwrap();
        assert_eq!(got.to_bits(), v.to_bits(), "k{i}: {got:e} vs {v:e}");
    }
}

#[test]
fn a_commit_cut_before_its_rename_leaves_the_old_record() {
    let out = tempfile::tempdir().unwrap();
    {
        let mut store = RunStore::open(out.path()).unwrap();
        store.commit(record("k", 1.5)).unwrap();
    }
    // What a crash between "write temp" and "rename" leaves: a torn temp file beside the record.
    let results = out.path().join(RESULTS_DIR);
    std::fs::write(results.join(".k.json.tmp"), b"{\"key\": \"k\", \"outc").unwrap();
    let store = RunStore::open(out.path()).unwrap();
    assert_eq!(store.record("k").unwrap().response, Some(1.5));
    assert!(!results.join(".k.json.tmp").exists(), "leftover temp file not removed");
}

#[test]
fn half_done_run_directories_are_cleaned_finished_ones_kept() {
    let out = tempfile::tempdir().unwrap();
    let (done, half) = {
        let mut store = RunStore::open(out.path()).unwrap();
        let inputs = vec![(PathBuf::from("in.txt"), b"x".to_vec())];
        let done = store.prepare("done", &inputs).unwrap();
        store.commit(record("done", 2.0)).unwrap();
        let half = store.prepare("half", &inputs).unwrap();
        std::fs::write(half.join("partial.out"), b"solver died here").unwrap();
        (done, half)
    };
    let store = RunStore::open(out.path()).unwrap();
    assert_eq!(store.cleaned(), ["half".to_string()]);
    assert!(!half.exists());
    assert!(done.join("in.txt").exists());
    assert!(store.is_finished("done") && !store.is_finished("half"));
}

fn started_keys(events: &[Event]) -> Vec<String> {
    let mut keys: Vec<String> = events
        .iter()
        .filter_map(|e| {
            if let Event::Started { key, .. } = e {
                Some(key.clone())
            } else {
                None
            }
        })
        .collect();
    keys.sort();
    keys
}

/// The runs of one `lab run`: specs for the unfinished ones only, as `lab run` will build them.
fn pending(store: &RunStore, all: &[(&str, &[&str])]) -> (Vec<RunSpec>, Vec<String>) {
    let mut keys = Vec::new();
    let mut todo = Vec::new();
    for (input, mode) in all {
        // Compute the key without touching the directory of a finished run.
        let probe = lab::execute::store::run_key(
            &[(PathBuf::from("input.txt"), input.as_bytes().to_vec())],
            &std::iter::once("python3".to_string())
                .chain(std::iter::once(fake_solver().display().to_string()))
                .chain(mode.iter().map(|s| s.to_string()))
                .collect::<Vec<_>>(),
            &lab::execute::Adapter::identity(adapter().as_ref()),
        );
        keys.push(probe.clone());
        if !store.is_finished(&probe) {
            let s = spec(store, input, mode);
            assert_eq!(s.key, probe);
            todo.push(s);
        }
    }
    (todo, keys)
}

#[tokio::test]
async fn resume_reruns_only_failures_and_changed_inputs() {
    let out = tempfile::tempdir().unwrap();
    let sweep: Vec<(&str, &[&str])> = vec![("a", &["ok", "1"]), ("b", &["ok", "2"]), ("c", &["exit", "4"])];

    // First pass: everything runs; two successes, one failure.
    let (keys, failed_key) = {
        let store = RunStore::open(out.path()).unwrap();
        let (todo, keys) = pending(&store, &sweep);
        assert_eq!(todo.len(), 3);
        let (ex, mut rx) = executor(&store, 2);
        let summary = ex.run(todo).await;
        assert_eq!(summary.records.len(), 3);
        assert_eq!(started_keys(&drain(&mut rx)).len(), 3);
        (keys.clone(), keys[2].clone())
    };

    // Second pass: only the failed run (its record is kept for `status` until replaced).
    {
        let store = RunStore::open(out.path()).unwrap();
        assert_eq!(
            store.record(&failed_key).unwrap().outcome,
            Outcome::NonZeroExit { code: 4 }
        );
        let (todo, _) = pending(&store, &sweep);
        let (ex, mut rx) = executor(&store, 2);
        ex.run(todo).await;
        assert_eq!(started_keys(&drain(&mut rx)), vec![failed_key.clone()]);
    }

    // Third pass with one input edited: exactly that run, under a new key; the old ones stay.
    let edited: Vec<(&str, &[&str])> = vec![("a", &["ok", "1"]), ("b-edited", &["ok", "2"]), ("c", &["exit", "4"])];
    let store = RunStore::open(out.path()).unwrap();
    let (todo, new_keys) = pending(&store, &edited);
    assert_eq!(new_keys[0], keys[0]);
    assert_ne!(new_keys[1], keys[1]);
    let (ex, mut rx) = executor(&store, 2);
    let summary = ex.run(todo).await;
    let mut expected = vec![new_keys[1].clone(), failed_key.clone()];
    expected.sort();
    assert_eq!(started_keys(&drain(&mut rx)), expected);
    let edited_record = summary.records.iter().find(|r| r.key == new_keys[1]).unwrap();
    assert_eq!(edited_record.response, Some(2.0));
    assert!(store.is_finished(&keys[0]) && store.is_finished(&keys[1]));
}
