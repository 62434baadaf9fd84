//! The main job through binout: `studies/honeycomb.yaml` run live with crushsim twice, its decks
//! rendered with BINARY = 1 (the ASCII files, as the study is) and with BINARY = 2 (every history
//! into binout only: the template constant `binary: 2`), both recorded. The two must give the same
//! `results.json` numbers, run by run the same response and quality figures, and the binout runs
//! must have written no ASCII history. Then the corruption experiment on the binout recordings:
//! drawn damage (cuts at random offsets, flipped header and record bytes, wrong record lengths,
//! missing continuation files) each a failed run naming the binout and the offset, no other run
//! failing, no panic, no hang.
//!
//! Tolerances: binout holds float32 (about 7.2 significant digits) where the ASCII files hold 6,
//! so each force, displacement and energy differs by up to 5e-6 relative between the two; the
//! mean crush forces and the calibrations on them agree to 1e-5, the curve methods (on 121
//! interpolated strokes) to 1e-4, and the solver-in-the-loop extension (a GP emulator fitted
//! through the runs, then a two-parameter calibration) to 1e-3.
//!
//! Independent of the number of runs the study plans: whatever it plans is run both ways. The main
//! job samples sequentially, and its next batch depends on the responses in hand, which differ in
//! the seventh digit between the two formats; the study is therefore run with its former fixed
//! design (`fixed_design::FIXED`), so that both ways run the same decks.

use crate::crushsim_bin;
use crate::fixed_design;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The main study with absolute paths, no replay directory, and `binary` set.
fn study_copy(dir: &Path, binary: u8) -> PathBuf {
    let text = std::fs::read_to_string(root().join("studies/honeycomb.yaml")).unwrap();
    let abs = root().display().to_string();
    let mut out = String::new();
    for line in text.lines() {
        if line.trim_start().starts_with("replay:") {
            continue;
        }
        let line = line
            .replace(fixed_design::SEQUENTIAL, fixed_design::FIXED)
            .replace("../templates", &format!("{abs}/templates"))
            .replace("../fixtures", &format!("{abs}/fixtures"));
        out += &line;
        out += "\n";
        if line.starts_with("constants:") {
            out += &format!("  binary: {binary}\n");
        }
    }
    assert!(
        out.contains(&format!("  binary: {binary}\n")),
        "the study has a constants block"
    );
    let path = dir.join(format!("honeycomb-binary{binary}.yaml"));
    std::fs::write(&path, out).unwrap();
    path
}

/// `lab ARGS` with crushsim on PATH; (exit code, stderr), `None` when it ran past `limit`.
fn lab(args: &[&str], limit: Duration) -> Option<(Option<i32>, String)> {
    let bin = crushsim_bin::crushsim();
    let path = format!("{}:/usr/bin:/bin", bin.parent().unwrap().display());
    let mut child = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(args)
        .env("PATH", path)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let mut stderr = String::new();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            use std::io::Read;
            child.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
            return Some((status.code(), stderr));
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Both live runs, once for the tests of this file: (temp dir, out and recording per binary).
struct Runs {
    _dir: tempfile::TempDir,
    study: [PathBuf; 2],
    out: [PathBuf; 2],
    rec: [PathBuf; 2],
}

fn runs() -> &'static Runs {
    static RUNS: OnceLock<Runs> = OnceLock::new();
    RUNS.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let mut r = Runs {
            study: Default::default(),
            out: Default::default(),
            rec: Default::default(),
            _dir: tempfile::tempdir().unwrap(),
        };
        for (k, binary) in [1u8, 2].into_iter().enumerate() {
            r.study[k] = study_copy(dir.path(), binary);
            r.out[k] = dir.path().join(format!("out{binary}"));
            r.rec[k] = dir.path().join(format!("rec{binary}"));
            let args = [
                "run",
                &r.study[k].to_string_lossy(),
                "--out",
                &r.out[k].to_string_lossy(),
                "--record",
                &r.rec[k].to_string_lossy(),
            ];
            let (code, stderr) = lab(&args, Duration::from_secs(900)).expect("the live run finishes");
            assert_eq!(code, Some(0), "binary {binary}:\n{stderr}");
        }
        r._dir = dir;
        r
    })
}

fn results(out: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap()
}

fn close(a: &Value, b: &Value, rel: f64, what: &str) {
    let (x, y) = (a.as_f64().unwrap_or_else(|| panic!("{what}: {a}")), b.as_f64().unwrap());
    let scale = x.abs().max(y.abs()).max(1e-12);
    assert!(
        (x - y).abs() <= rel * scale,
        "{what}: ASCII {x}, binout {y} (relative {:.2e} > {rel:.0e})",
        (x - y).abs() / scale
    );
}

/// Every number of the `parameters` objects under `v` (recursively), paired by path.
fn parameters(v: &Value, path: String, out: &mut Vec<(String, Value)>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let p = format!("{path}/{k}");
                if k == "parameters" {
                    if let Value::Object(ps) = x {
                        let numbers = ps.iter().filter(|(_, val)| val.is_number());
                        out.extend(numbers.map(|(n, val)| (format!("{p}/{n}"), val.clone())));
                    }
                } else {
                    parameters(x, p, out);
                }
            }
        }
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| parameters(x, format!("{path}[{i}]"), out)),
        _ => {}
    }
}

#[test]
fn the_main_job_through_binout_gives_the_same_results() {
    let r = runs();
    let (a, b) = (results(&r.out[0]), results(&r.out[1]));
    assert_eq!(a["runs"]["planned"], b["runs"]["planned"]);
    assert_eq!(a["runs"]["succeeded"], b["runs"]["succeeded"]);
    assert_eq!(a["runs"]["suspect"], b["runs"]["suspect"]);
    for key in ["cause", "verdict", "discrepancy_detected"] {
        assert_eq!(a["diagnosis"][key], b["diagnosis"][key], "diagnosis.{key}");
    }
    let (mut pa, mut pb) = (Vec::new(), Vec::new());
    parameters(&a, String::new(), &mut pa);
    parameters(&b, String::new(), &mut pb);
    assert_eq!(
        pa.iter().map(|p| &p.0).collect::<Vec<_>>(),
        pb.iter().map(|p| &p.0).collect::<Vec<_>>()
    );
    assert!(pa.len() >= 12, "{pa:?}");
    for ((path, x), (_, y)) in pa.iter().zip(&pb) {
        let rel = if path.contains("/diagnosis/") {
            1e-3
        } else if path.starts_with("/curve_calibration") {
            1e-4
        } else {
            1e-5
        };
        close(x, y, rel, path);
    }
    for m in ["least_squares", "sensitivity", "bayesian"] {
        for (p, q) in a["calibration"][m]["predictions"]
            .as_array()
            .unwrap()
            .iter()
            .zip(b["calibration"][m]["predictions"].as_array().unwrap())
        {
            assert_eq!(p["measured"], q["measured"]);
            close(
                &p["predicted"],
                &q["predicted"],
                1e-5,
                &format!("{m} prediction at {}", p["design"]),
            );
        }
    }
}

/// The recordings of `rec` by their run (design and rendered deck, its BINARY fields read as 1):
/// their run keys. The confirmation runs are left out: they run at each study's own fitted
/// parameters, which two readings of the same outputs give alike only to their rounding.
fn by_run(rec: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for m in lab::execute::replay::manifests(rec)
        .into_iter()
        .filter(|m| m.role != "confirmation")
    {
        let deck = m.inputs["main.k"].text.clone().expect("the deck's text is kept");
        let deck = deck
            .replace("&DTOUT         2", "&DTOUT         1")
            .replace("&DTPLOT         2", "&DTPLOT         1");
        let run = format!("{} {:?} {}", m.design, m.parameters, deck);
        assert!(
            out.insert(run, m.key.clone()).is_none(),
            "two recordings of one run in {}",
            rec.display()
        );
    }
    out
}

fn record(out: &Path, key: &str) -> lab::execute::RunRecord {
    serde_json::from_slice(&std::fs::read(out.join("results").join(format!("{key}.json"))).unwrap()).unwrap()
}

#[test]
fn run_by_run_the_same_response_and_quality_figures() {
    let r = runs();
    let (ascii, bin) = (by_run(&r.rec[0]), by_run(&r.rec[1]));
    assert_eq!(ascii.keys().collect::<Vec<_>>(), bin.keys().collect::<Vec<_>>());
    for (run, key) in &ascii {
        let (x, y) = (record(&r.out[0], key), record(&r.out[1], &bin[run]));
        let (fx, fy) = (x.response.unwrap(), y.response.unwrap());
        assert!((fx - fy).abs() <= 1e-5 * fx.abs(), "{run}: {fx} vs {fy}");
        let (qx, qy) = (x.quality.unwrap(), y.quality.unwrap());
        for (name, u, v) in [
            ("hourglass", qx.hourglass_ratio, qy.hourglass_ratio),
            ("energy", qx.energy_error, qy.energy_error),
            ("added mass", qx.added_mass_ratio, qy.added_mass_ratio),
        ] {
            match (u, v) {
                (Some(u), Some(v)) => assert!((u - v).abs() <= 1e-5, "{run}: {name} {u} vs {v}"),
                (None, None) => {}
                other => panic!("{run}: {name} {other:?}"),
            }
        }
        let rec = r.rec[1].join(&bin[run]);
        assert!(rec.join("binout").is_file(), "{run}: no binout recorded");
        for f in ["rcforc", "nodout", "glstat"] {
            assert!(!rec.join(f).exists(), "{run}: BINARY 2 but {f} recorded");
        }
    }
}

// --- the corruption experiment on binout recordings ---

const REPLAYS: usize = 10;
const PER_REPLAY: usize = 4;
const SEED: u64 = 32;

/// One seeded mutation of a recording's binout: its kind and what was done.
struct Mutation {
    kind: &'static str,
    what: String,
}

/// Offsets of every record of an LSDA file with 8-byte lengths and 1-byte commands (its own
/// little walk, independent of the reader under test): (offset, length, command).
fn records(bytes: &[u8]) -> Vec<(usize, usize, u8)> {
    let mut out = Vec::new();
    let mut at = bytes[0] as usize;
    while at + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
        out.push((at, len, bytes[at + 8]));
        at += len;
    }
    out
}

fn mutate(rng: &mut ChaCha8Rng, dir: &Path) -> Mutation {
    let path = dir.join("binout");
    let bytes = std::fs::read(&path).unwrap();
    let recs = records(&bytes);
    let mut out = bytes.clone();
    let (kind, what) = match rng.random_range(0..5) {
        0 => {
            let at = rng.random_range(bytes.len() / 10..bytes.len() * 9 / 10);
            out.truncate(at);
            ("cut", format!("cut at byte {at} of {}", bytes.len()))
        }
        1 => {
            // Bytes 6 and 7 are unused (zero), as LSTC's reader treats them.
            let at = rng.random_range(0..6);
            out[at] ^= 1 << rng.random_range(0..8);
            ("header byte", format!("file header byte {at} flipped"))
        }
        2 => {
            let (at, _, cmd) = recs[rng.random_range(recs.len() / 10..recs.len() * 9 / 10)];
            let k = at + rng.random_range(0..9);
            out[k] ^= 1 << rng.random_range(0..8);
            (
                "record head",
                format!("a bit of the length/command of the record at {at} (command {cmd}) flipped at byte {k}"),
            )
        }
        3 => {
            let data: Vec<_> = recs.iter().filter(|r| r.2 == 3).collect();
            let (at, len, _) = *data[rng.random_range(data.len() / 10..data.len() * 9 / 10)];
            let wrong = len as i64 + [-4i64, -1, 1, 4, 8][rng.random_range(0..5)];
            out[at..at + 8].copy_from_slice(&wrong.to_le_bytes());
            (
                "wrong length",
                format!("DATA record at {at}: length {len} written as {wrong}"),
            )
        }
        _ => {
            // Split at a record boundary into binout and binout%001, then lose the first part's
            // continuation or the second of two continuations.
            let (at, _, _) = recs[rng.random_range(recs.len() / 3..recs.len() * 2 / 3)];
            out.truncate(at);
            let empty = lsda::Writer::new(lsda::Header::default()).finish().unwrap().remove(0);
            std::fs::write(dir.join("binout%002"), &empty).unwrap();
            (
                "missing continuation",
                format!("binout cut at record {at}, binout%001 missing, binout%002 present"),
            )
        }
    };
    std::fs::write(&path, out).unwrap();
    Mutation { kind, what }
}

/// Copies every recording; returns the keys of those a damage may hit: the sampled runs, not the
/// confirmation runs (those run at the fitted parameters, which a damaged sample moves: the replay
/// then plans others, and the damaged one is not asked for).
fn copy_recordings(from: &Path, to: &Path) -> Vec<String> {
    let confirmation: BTreeSet<String> = lab::execute::replay::manifests(from)
        .into_iter()
        .filter(|m| m.role == "confirmation")
        .map(|m| m.key)
        .collect();
    let mut keys = Vec::new();
    for e in std::fs::read_dir(from).unwrap().filter_map(|e| e.ok()) {
        let key = e.file_name().to_string_lossy().into_owned();
        std::fs::create_dir(to.join(&key)).unwrap();
        for f in std::fs::read_dir(e.path()).unwrap().filter_map(|e| e.ok()) {
            std::fs::copy(f.path(), to.join(&key).join(f.file_name())).unwrap();
        }
        if !confirmation.contains(&key) {
            keys.push(key);
        }
    }
    keys.sort();
    keys
}

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
fn every_damaged_binout_fails_its_run_naming_the_file_and_offset() {
    let r = runs();
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let (mut accepted, mut panics, mut hangs, mut false_alarms, mut unnamed, mut kept) = (0, 0, 0, 0, 0, 0);
    let mut tally: BTreeMap<(String, String), usize> = BTreeMap::new();
    for replay in 0..REPLAYS {
        let copy = tempfile::tempdir().unwrap();
        let keys = copy_recordings(&r.rec[1], copy.path());
        let mut chosen: Vec<usize> = Vec::new();
        while chosen.len() < PER_REPLAY {
            let k = rng.random_range(0..keys.len());
            if !chosen.contains(&k) {
                chosen.push(k);
            }
        }
        let mutations: Vec<(String, Mutation)> = chosen
            .iter()
            .map(|&k| (keys[k].clone(), mutate(&mut rng, &copy.path().join(&keys[k]))))
            .collect();
        let out = tempfile::tempdir().unwrap();
        let args = [
            "run",
            &r.study[1].to_string_lossy(),
            "--replay",
            &copy.path().to_string_lossy(),
            "--out",
            &out.path().to_string_lossy(),
        ];
        let Some((code, stderr)) = lab(&args, Duration::from_secs(120)) else {
            hangs += 1;
            continue;
        };
        if code == Some(101) || code.is_none() || stderr.contains("panicked") {
            panics += 1;
            eprintln!("replay {replay}: panic or signal (exit {code:?}):\n{stderr}");
            continue;
        }
        for (key, m) in &mutations {
            let (class, words) = outcome(out.path(), key)
                .unwrap_or_else(|| panic!("replay {replay}: no record for {key}: {}\n{stderr}", m.what));
            if class == "success" {
                accepted += 1;
                eprintln!("replay {replay}: ACCEPTED {key}: {}", m.what);
            } else if !(words.contains("binout") && (words.contains("offset") || m.kind == "missing continuation")) {
                unnamed += 1;
                eprintln!(
                    "replay {replay}: {key} ({}) failed without naming the binout and offset: {words}",
                    m.what
                );
            }
            eprintln!("  {:<22} {class:<18} {words}", m.kind);
            *tally.entry((m.kind.to_string(), class)).or_default() += 1;
        }
        for key in keys.iter().filter(|k| !mutations.iter().any(|(c, _)| c == *k)) {
            match outcome(out.path(), key) {
                Some((class, _)) if class == "success" => kept += 1,
                other => {
                    false_alarms += 1;
                    eprintln!("replay {replay}: untouched {key} not a success: {other:?}");
                }
            }
        }
    }
    eprintln!("\nbinout corruption: {REPLAYS} replays x {PER_REPLAY} damaged recordings (seed {SEED})");
    for ((kind, class), n) in &tally {
        eprintln!("{kind:<22} {class:<20} {n:>5}");
    }
    assert_eq!((accepted, panics, hangs, false_alarms, unnamed), (0, 0, 0, 0, 0));
    assert!(kept > 0);
    let n: usize = tally.values().sum();
    assert!(n >= 30, "{n} damaged files");
    for kind in [
        "cut",
        "header byte",
        "record head",
        "wrong length",
        "missing continuation",
    ] {
        assert!(tally.keys().any(|(k, _)| k == kind), "no `{kind}` drawn");
    }
}
