//! The corruption experiment of issue 16, as a test: 12 replays of the main job from copies of its
//! recordings, four recordings corrupted in each by a seeded mutation. The main job samples
//! sequentially, so a failed run changes the runs it asks for next; the experiment therefore uses
//! the main job with its former fixed design (`fixed_design`: LHS, 24 samples and 5 check runs per
//! design, 252 runs with its confirmation runs), recorded live with crushsim at the start of the test, so that every replay
//! asks for the same runs:
//!
//! - **delete**: 1–30 whole lines deleted from the middle of rcforc or nodout (the first deleted
//!   line is not blank, so data is lost: a gap in the history, or unpaired rows);
//! - **truncate**: rcforc, nodout or glstat cut at a byte in its middle 80 %;
//! - **garbage**: a line of random bytes, or of random printable words and numbers, inserted at a
//!   line break in the middle 80 % of rcforc, nodout or glstat.
//!
//! Every corrupted run must be reported as failed with an outcome naming the corrupted file, every
//! other run must succeed (no false alarm), and `lab` must neither panic nor hang (120 s each).
//! Run with `--nocapture` to see the tally.

use std::collections::BTreeMap;
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::damage;
use crate::fixed_design;

use damage::{Mutation, copy_recordings, mutate, run_lab};

const REPLAYS: usize = 12;
const PER_REPLAY: usize = 4;
const SEED: u64 = 16;

/// The committed record of `key` in the run store `out`: (outcome class, outcome in words).
fn outcome(out: &Path, key: &str) -> Option<(String, String)> {
    let bytes = std::fs::read(out.join("results").join(format!("{key}.json"))).ok()?;
    let r: lab::execute::RunRecord = serde_json::from_slice(&bytes).unwrap();
    let class = serde_json::to_value(r.outcome.class())
        .unwrap()
        .as_str()
        .unwrap()
        .to_string();
    Some((class, r.outcome.to_string()))
}

#[test]
fn every_corrupted_recording_is_reported_and_no_other() {
    let work = tempfile::tempdir().unwrap();
    let study = fixed_design::study(work.path(), "");
    let recorded = fixed_design::recordings();
    let keys = fixed_design::keys(recorded);
    // 159 screening runs (24 samples + 5 checks + 24 probes of the hardening extension at 3 designs),
    // the loop's 87 (3 designs x (24 + 5)) and 6 confirmation runs (the uncorrected simulation and
    // the hardening model at their fitted parameters, at 3 designs).
    assert_eq!(keys.len(), 252);
    // A damage hits a sampled run, not a confirmation run: those run at the fitted parameters,
    // which a damaged sample moves, so the replay plans others and never asks for the damaged one.
    let confirmation: Vec<String> = lab::execute::replay::manifests(recorded)
        .into_iter()
        .filter(|m| m.role == "confirmation")
        .map(|m| m.key)
        .collect();
    assert_eq!(confirmation.len(), 6);
    let damageable: Vec<String> = keys.iter().filter(|k| !confirmation.contains(k)).cloned().collect();
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let (mut accepted, mut panics, mut hangs, mut false_alarms, mut unnamed) = (0, 0, 0, 0, 0);
    let mut tally: BTreeMap<(String, String), usize> = BTreeMap::new();
    for replay in 0..REPLAYS {
        let copy = tempfile::tempdir().unwrap();
        copy_recordings(recorded, &keys, copy.path());
        let mut chosen: Vec<usize> = Vec::new();
        while chosen.len() < PER_REPLAY {
            let k = rng.random_range(0..damageable.len());
            if !chosen.contains(&k) {
                chosen.push(k);
            }
        }
        let mutations: Vec<(String, Mutation)> = chosen
            .iter()
            .map(|&k| {
                (
                    damageable[k].clone(),
                    mutate(&mut rng, &copy.path().join(&damageable[k])),
                )
            })
            .collect();
        let out = tempfile::tempdir().unwrap();
        let Some((code, stderr)) = run_lab(&study, copy.path(), out.path()) else {
            hangs += 1;
            eprintln!("replay {replay}: hung");
            continue;
        };
        if code == Some(101) || code.is_none() || stderr.contains("panicked") {
            panics += 1;
            eprintln!("replay {replay}: panic or signal (exit {code:?}):\n{stderr}");
            continue;
        }
        for (key, m) in &mutations {
            let Some((class, words)) = outcome(out.path(), key) else {
                panic!(
                    "replay {replay}: no record for {key} ({} {}: {})\n{stderr}",
                    m.kind, m.file, m.what
                );
            };
            if class == "success" {
                accepted += 1;
                eprintln!("replay {replay}: ACCEPTED {key}: {} {}: {}", m.kind, m.file, m.what);
            } else if !words.contains(m.file) {
                unnamed += 1;
                eprintln!("replay {replay}: {key} failed without naming {}: {words}", m.file);
            }
            *tally.entry((format!("{} {}", m.kind, m.file), class)).or_default() += 1;
        }
        // Every untouched sampled run replays as a success (the confirmation runs are asked for
        // at the parameters the replay fitted, which the damage moved: not these recordings).
        for key in damageable.iter().filter(|k| !mutations.iter().any(|(c, _)| c == *k)) {
            match outcome(out.path(), key) {
                Some((class, _)) if class == "success" => {}
                other => {
                    false_alarms += 1;
                    eprintln!("replay {replay}: untouched {key} not a success: {other:?}");
                }
            }
        }
    }
    eprintln!("\ncorruption experiment: {REPLAYS} replays x {PER_REPLAY} corrupted recordings (seed {SEED})");
    eprintln!("{:<20} {:<20} {:>5}", "mutation", "reported as", "runs");
    for ((mutation, class), n) in &tally {
        eprintln!("{mutation:<20} {class:<20} {n:>5}");
    }
    eprintln!(
        "accepted as success {accepted}, panics {panics}, hangs {hangs}, false alarms {false_alarms}, \
         failures not naming the file {unnamed}"
    );
    assert_eq!((accepted, panics, hangs, false_alarms, unnamed), (0, 0, 0, 0, 0));
    let deletions: usize = tally
        .iter()
        .filter(|((m, _), _)| m.starts_with("delete"))
        .map(|(_, n)| n)
        .sum();
    assert!(
        deletions >= 12,
        "line deletions must be well represented: {deletions} of 48"
    );
    for kind in ["truncate", "garbage"] {
        assert!(
            tally.keys().any(|(m, _)| m.starts_with(kind)),
            "no {kind} mutation drawn"
        );
    }
}
