//! OpenRadioss live: short runs of the reduced honeycomb specimen (`tests/openradioss/mini.yaml`,
//! about 5 s of one core each) through the `lab` binary, and runs the solver must fail.
//!
//! - A live run's response is the mean crush force computed independently from OpenRadioss's own
//!   converter (`th_to_csv`) output of the same T01: its forces (differentiated impulses) against
//!   its striker displacement, integrated here by the trapezoidal rule over the window, within
//!   1e-6 relative (both read the same single-precision history; the converter prints 7 digits).
//! - The run's figures: energy balance within 5 %, kinetic/internal energy below 10 %; the starter's
//!   restart file removed, the engine writes none; the starter's warnings (plates set inside their
//!   contact distance: initial penetrations) kept in the record and shown on stderr.
//! - The recording replays to the same response bit for bit, and a second live run (one thread)
//!   writes the same numbers in its T01, bit for bit (its banner holds the date).
//! - A deck the starter rejects (a part naming a material that does not exist) and a run the engine
//!   stops early (an energy-error limit of 0.01 %, after which OpenRadioss still prints
//!   `NORMAL TERMINATION`) are failed runs with failure text naming the listing.
//!
//! Needs OpenRadioss on PATH (`eval "$(../shared/tools/openradioss/install.sh)"`): skipped with a
//! message without it, a failure when CI=true.

use crate::readers;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A copy of the mini study in `dir`, its template too, with `edit` applied to the template and
/// `constants` appended to the study's constants.
fn mini(dir: &Path, edit: &dyn Fn(String) -> String, constants: &str) -> PathBuf {
    let template = std::fs::read_to_string(repo().join("templates/honeycomb-openradioss/main.k.tera")).unwrap();
    std::fs::write(dir.join("main.k.tera"), edit(template)).unwrap();
    let study = std::fs::read_to_string(repo().join("tests/openradioss/mini.yaml"))
        .unwrap()
        .replace("../../templates/honeycomb-openradioss/main.k.tera", "main.k.tera")
        .replace("  hold_edges: 1\n", &format!("  hold_edges: 1\n{constants}"));
    std::fs::copy(repo().join("tests/openradioss/tests.csv"), dir.join("tests.csv")).unwrap();
    let path = dir.join("mini.yaml");
    std::fs::write(&path, study).unwrap();
    path
}

fn lab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lab")).args(args).output().unwrap()
}

fn records(out: &Path) -> Vec<serde_json::Value> {
    let mut v: Vec<(String, serde_json::Value)> = std::fs::read_dir(out.join("results"))
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let text = std::fs::read_to_string(&p).unwrap();
            (p.display().to_string(), serde_json::from_str(&text).unwrap())
        })
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v.into_iter().map(|(_, r)| r).collect()
}

/// th_to_csv's (stroke, force) rows of `t01`: interface 1's FNZ (kN) against node 9000005's DZ
/// (stroke = −DZ).
fn th_to_csv_rows(t01: &Path) -> Vec<(f64, f64)> {
    let tmp = tempfile::tempdir().unwrap();
    for name in ["mainT01", "mainT01_TITLES"] {
        std::fs::copy(t01.with_file_name(name), tmp.path().join(name)).unwrap();
    }
    let ok = Command::new("th_to_csv_linux64_gf")
        .arg("mainT01")
        .current_dir(tmp.path())
        .output()
        .unwrap();
    assert!(ok.status.success());
    let mut reader = csv::Reader::from_path(tmp.path().join("mainT01.csv")).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(|h| h.trim().to_string()).collect();
    let col = |pred: &dyn Fn(&str) -> bool| header.iter().position(|h| pred(h)).unwrap();
    let f = col(&|h| h.starts_with("TH-INTER") && h.split_whitespace().nth(1) == Some("1") && h.ends_with("FNZ"));
    let d = col(&|h| h.contains("9000005") && h.ends_with(" DZ"));
    reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            (
                -r[d].trim().parse::<f64>().unwrap(),
                r[f].trim().parse::<f64>().unwrap() / 1000.0,
            )
        })
        .collect()
}

/// The mean force (kN) over `[s0, s1]` of th_to_csv's rows, trapezoids with both ends interpolated.
fn mean_from_th_to_csv(t01: &Path, s0: f64, s1: f64) -> f64 {
    let rows = th_to_csv_rows(t01);
    let at = |s: f64| {
        let k = rows.windows(2).position(|w| w[0].0 <= s && s <= w[1].0).unwrap();
        let ((a, fa), (b, fb)) = (rows[k], rows[k + 1]);
        fa + (s - a) / (b - a) * (fb - fa)
    };
    let mut points = vec![(s0, at(s0))];
    points.extend(rows.iter().copied().filter(|(s, _)| *s > s0 && *s < s1));
    points.push((s1, at(s1)));
    let area: f64 = points
        .windows(2)
        .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
        .sum();
    area / (s1 - s0)
}

#[test]
fn a_live_run_is_judged_from_its_listings_and_time_history_and_replays_bit_for_bit() {
    if !readers::openradioss() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    // gap 0.05: the plates start inside their contact distance, so the starter warns.
    let study = mini(tmp.path(), &|t| t, "  gap: 0.05\n");
    let (out, rec) = (tmp.path().join("out"), tmp.path().join("rec"));
    let o = lab(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        "1",
        "--record",
        rec.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let runs = records(&out);
    // The two sampled runs, and the solver at the fitted σy at the one tested design.
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(results["runs"]["confirmation"], 1, "{}", results["runs"]);
    assert_eq!(runs.len(), 3);
    for r in &runs {
        let key = r["key"].as_str().unwrap();
        assert_eq!(r["outcome"]["class"], "success", "{r}");
        let dir = out.join("runs").join(key);
        let mean = mean_from_th_to_csv(&dir.join("mainT01"), 0.4, 0.9);
        let response = r["response"].as_f64().unwrap();
        assert!(
            (response - mean).abs() <= 1e-6 * mean,
            "{key}: lab {response}, th_to_csv {mean}"
        );
        // Every force, the first (contact from the start: the plates sit inside their contact
        // distance) and the last included, is th_to_csv's derivative of the impulse.
        let th = radioss_th::read(&dir.join("mainT01")).unwrap();
        let mine = th.interface_force(1, "FNZ").unwrap();
        let theirs = th_to_csv_rows(&dir.join("mainT01"));
        let largest = theirs.iter().fold(0.0f64, |m, r| m.max(r.1.abs()));
        assert!(theirs[0].1 != 0.0, "{key}: no contact force over the first interval");
        for (k, (a, b)) in mine.iter().zip(&theirs).enumerate() {
            assert!(
                (a / 1000.0 - b.1).abs() <= 1e-6 * largest,
                "{key} step {k}: {a} N, th_to_csv {} kN",
                b.1
            );
        }
        let q = &r["quality"];
        assert!(q["energy_error"].as_f64().unwrap().abs() < 0.05, "{r}");
        assert!(q["kinetic_ratio"].as_f64().unwrap() < 0.10, "{r}");
        assert!(!dir.join("main_0000_0001.rst").exists() && !dir.join("main_0001_0001.rst").exists());
        let warnings: Vec<&str> = r["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap())
            .collect();
        assert!(
            warnings
                .iter()
                .any(|w| w.starts_with("starter: ") && w.contains("INITIAL PENETRATIONS")),
            "{warnings:?}"
        );
        assert!(stderr.contains(warnings[0]), "warnings not shown:\n{stderr}");
        for name in ["main_0000.out", "main_0001.out", "mainT01", "mainT01_TITLES"] {
            assert!(rec.join(key).join(name).is_file(), "{key}/{name} not recorded");
        }
    }
    let replayed = tmp.path().join("replayed");
    let o = lab(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        replayed.to_str().unwrap(),
        "--replay",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (a, b) in runs.iter().zip(records(&replayed)) {
        assert_eq!(
            a["response"].as_f64().unwrap().to_bits(),
            b["response"].as_f64().unwrap().to_bits()
        );
        assert_eq!(a["quality"], b["quality"]);
        assert_eq!(a["warnings"], b["warnings"]);
    }
    let again = tmp.path().join("again");
    let o = lab(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
        "--jobs",
        "1",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The T01's banner holds the date; every number in it must repeat.
    for (r, a) in runs.iter().zip(records(&again)) {
        let key = r["key"].as_str().unwrap();
        let t01 = |o: &Path| radioss_th::read(&o.join("runs").join(key).join("mainT01")).unwrap();
        let (first, second) = (t01(&out), t01(&again));
        assert_eq!(first.times, second.times, "{key}");
        let bits = |th: &radioss_th::TimeHistory| th.values.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
        assert!(
            bits(&first) == bits(&second),
            "{key}: a second run on one thread wrote other numbers"
        );
        assert_eq!(
            r["response"].as_f64().unwrap().to_bits(),
            a["response"].as_f64().unwrap().to_bits()
        );
    }
}

/// Runs the mini study on a template edited by `edit`; every run must fail with failure text in
/// `listing` containing `phrase`.
fn fails(edit: &dyn Fn(String) -> String, listing: &str, phrase: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let study = mini(tmp.path(), edit, "");
    let out = tmp.path().join("out");
    let o = lab(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    for r in records(&out) {
        assert_eq!(r["outcome"]["class"], "failure_text", "{r}");
        assert_eq!(r["outcome"]["file"], listing, "{r}");
        assert!(r["outcome"]["line"].as_str().unwrap().contains(phrase), "{r}");
    }
}

#[test]
fn a_rejected_deck_and_a_run_stopped_early_are_failures() {
    if !readers::openradioss() {
        return;
    }
    let part = "tube single walls\n$      pid     secid       mid     eosid      hgid\n         1         1         1";
    fails(
        &|t| {
            assert!(t.contains(part));
            t.replace(
                part,
                &part.replace("         1         1         1", "         1         1        99"),
            )
        },
        "main_0000.out",
        "ERROR(S)",
    );
    let term = "     &TEND         0       0.0       0.0       0.0";
    fails(
        &|t| {
            assert!(t.contains(term));
            t.replace(term, "     &TEND         0       0.0    0.0001       0.0")
        },
        "main_0001.out",
        "ENERGY ERROR",
    );
}

/// The starter needs RAD_CFG_PATH (its keyword definitions): removed from lab's environment, runs
/// fail; named in `openradioss.environment`, they succeed.
#[test]
fn the_solver_environment_comes_from_the_study_or_lab() {
    if !readers::openradioss() {
        return;
    }
    let Ok(cfg) = std::env::var("RAD_CFG_PATH") else {
        panic!("OpenRadioss is on PATH but RAD_CFG_PATH is not set (install.sh prints it)");
    };
    let run = |environment: &str| {
        let tmp = tempfile::tempdir().unwrap();
        let study = mini(tmp.path(), &|t| t, "");
        let text = std::fs::read_to_string(&study).unwrap().replace(
            "openradioss: {threads: 1, noise: {amplitude: 0.005, seed: 0.5}}",
            &format!("openradioss: {{threads: 1, noise: {{amplitude: 0.005, seed: 0.5}}{environment}}}"),
        );
        std::fs::write(&study, text).unwrap();
        let out = tmp.path().join("out");
        let o = Command::new(env!("CARGO_BIN_EXE_lab"))
            .args([
                "run",
                study.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--jobs",
                "1",
            ])
            .env_remove("RAD_CFG_PATH")
            .output()
            .unwrap();
        (o.status.code(), records(&out))
    };
    let (code, without) = run("");
    assert_eq!(code, Some(1));
    assert!(
        without.iter().all(|r| r["outcome"]["class"] != "success"),
        "{without:?}"
    );
    let (code, with) = run(&format!(", environment: {{RAD_CFG_PATH: {cfg}}}"));
    assert_eq!(code, Some(0), "{with:?}");
    assert!(with.iter().all(|r| r["outcome"]["class"] == "success"), "{with:?}");
}
