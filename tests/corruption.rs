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
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod crushsim_bin;
mod fixed_design;

const REPLAYS: usize = 12;
const PER_REPLAY: usize = 4;
const SEED: u64 = 16;
const TIME_LIMIT: Duration = Duration::from_secs(120);

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn copy_recordings(from: &Path, keys: &[String], to: &Path) {
    for k in keys {
        std::fs::create_dir(to.join(k)).unwrap();
        for f in std::fs::read_dir(from.join(k)).unwrap().filter_map(|e| e.ok()) {
            std::fs::copy(f.path(), to.join(k).join(f.file_name())).unwrap();
        }
    }
}

/// One seeded mutation: what was done, to which file.
struct Mutation {
    kind: &'static str,
    file: &'static str,
    what: String,
}

fn mutate(rng: &mut ChaCha8Rng, dir: &Path) -> Mutation {
    let roll = rng.random_range(0..6);
    let (kind, file) = match roll {
        0..=2 => ("delete", ["rcforc", "nodout"][rng.random_range(0..2)]),
        3 | 4 => ("truncate", ["rcforc", "nodout", "glstat"][rng.random_range(0..3)]),
        _ => ("garbage", ["rcforc", "nodout", "glstat"][rng.random_range(0..3)]),
    };
    let path = dir.join(file);
    let bytes = std::fs::read(&path).unwrap();
    let (out, what) = match kind {
        "delete" => delete_lines(rng, &bytes),
        "truncate" => {
            let at = rng.random_range(bytes.len() / 10..bytes.len() * 9 / 10);
            (bytes[..at].to_vec(), format!("cut at byte {at} of {}", bytes.len()))
        }
        _ => inject(rng, &bytes),
    };
    std::fs::write(&path, out).unwrap();
    Mutation { kind, file, what }
}

/// Deletes 1–30 lines from the middle 80 % of the file, starting at a line that is not blank.
fn delete_lines(rng: &mut ChaCha8Rng, bytes: &[u8]) -> (Vec<u8>, String) {
    let text = String::from_utf8(bytes.to_vec()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let n = lines.len();
    let mut start = rng.random_range(n / 10..n * 9 / 10);
    while lines[start].trim().is_empty() {
        start += 1;
    }
    let count = rng.random_range(1..=30).min(n - start);
    let kept: String = lines
        .iter()
        .enumerate()
        .filter(|(i, _)| !(start..start + count).contains(i))
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    (
        kept.into_bytes(),
        format!("deleted lines {}..={}", start + 1, start + count),
    )
}

/// Inserts a garbage line at a line break in the middle 80 % of the file.
fn inject(rng: &mut ChaCha8Rng, bytes: &[u8]) -> (Vec<u8>, String) {
    let breaks: Vec<usize> = (bytes.len() / 10..bytes.len() * 9 / 10)
        .filter(|&i| bytes[i] == b'\n')
        .collect();
    let at = breaks[rng.random_range(0..breaks.len())] + 1;
    let len = rng.random_range(8..80);
    let garbage: Vec<u8> = if rng.random_bool(0.5) {
        (0..len)
            .map(|_| rng.random_range(0..=255u8))
            .filter(|b| *b != b'\n')
            .collect()
    } else {
        const CHARS: &[u8] = b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 .-+E=#*";
        let mut g: Vec<u8> = (0..len).map(|_| CHARS[rng.random_range(0..CHARS.len())]).collect();
        g[0] = b'x'; // not a blank line
        g
    };
    let mut out = bytes[..at].to_vec();
    out.extend_from_slice(&garbage);
    out.push(b'\n');
    out.extend_from_slice(&bytes[at..]);
    (out, format!("{} garbage bytes inserted at byte {at}", garbage.len()))
}

/// `lab run` with a time limit; `None` when it hung and was killed.
fn run_lab(study: &Path, copy: &Path, out: &Path) -> Option<(Option<i32>, String)> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lab"))
        .arg("run")
        .arg(study)
        .arg("--replay")
        .arg(copy)
        .arg("--out")
        .arg(out)
        .current_dir(root())
        .env("PATH", "/usr/bin:/bin")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            use std::io::Read;
            child.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
            return Some((status.code(), stderr));
        }
        if started.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

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
