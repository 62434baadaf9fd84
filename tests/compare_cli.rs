//! `lab compare` as a user runs it: the table and the JSON on good input, and on bad input exit 2
//! with the file (and line, where there is one) named; it writes nothing.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const HEADER: &str = "displacement [mm],force [kN]\n";

struct Files {
    dir: tempfile::TempDir,
}

impl Files {
    fn new() -> Self {
        Files {
            dir: tempfile::tempdir().unwrap(),
        }
    }

    /// A CSV from `(stroke, force)` rows, after the usual header.
    fn curve(&self, name: &str, rows: &[(f64, f64)]) -> PathBuf {
        let mut text = HEADER.to_string();
        for (s, f) in rows {
            text += &format!("{s:.4},{f:.4}\n");
        }
        self.text(name, &text)
    }

    fn text(&self, name: &str, text: &str) -> PathBuf {
        let p = self.dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// `lab compare` run inside the directory.
    fn compare(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_lab"))
            .current_dir(self.dir.path())
            .arg("compare")
            .args(args)
            .output()
            .unwrap()
    }

    fn listing(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(self.dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

/// A crush-like curve over 0..`to` mm in `n` points, force scaled by `k`.
fn crush(n: usize, to: f64, k: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let s = to * i as f64 / (n - 1) as f64;
            (s, k * (20.0 + 30.0 * (-s).exp() + 3.0 * (s * 1.1).sin()))
        })
        .collect()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[track_caller]
fn assert_bad_input(o: &Output, file: &Path, line: Option<usize>, phrase: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let name = file.file_name().unwrap().to_str().unwrap();
    let at = match line {
        Some(l) => format!("{name}:{l}:"),
        None => format!("{name}: "),
    };
    assert!(err.contains(&at), "`{at}` not in:\n{err}");
    assert!(err.contains(phrase), "`{phrase}` not in:\n{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn prints_every_metric_with_units_and_writes_nothing() {
    let f = Files::new();
    f.curve("a.csv", &crush(80, 60.0, 1.0));
    f.curve("b.csv", &crush(133, 55.0, 1.1));
    let before = f.listing();
    let o = f.compare(&["a.csv", "b.csv"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    for (name, unit) in [
        ("mse", "-"),
        ("pcm", "-"),
        ("frechet", "mm|kN"),
        ("dtw", "mm|kN"),
        ("area", "mm*kN"),
    ] {
        let row = out
            .lines()
            .find(|l| l.starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name} row:\n{out}"));
        assert!(row.contains(unit) && !row.contains("undefined"), "{row}");
    }
    assert!(out.contains("over 0:55 mm (the strokes' overlap)"), "{out}");
    assert_eq!(f.listing(), before, "lab compare wrote something");

    let o = f.compare(&["a.csv", "b.csv", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in ["pcm", "frechet", "dtw", "area", "mse"] {
        assert!(v[key].as_f64().is_some_and(|x| x > 0.0), "{key}: {v}");
    }
    assert_eq!(v["on"], "raw");
    assert_eq!(v["grid"]["points"], 200);

    // With a window, every metric is on the grid: the same curve twice gives zeros (the area's
    // degenerate quadrilaterals to the shoelace formula's rounding, 1e-9 mm*kN).
    let o = f.compare(&["a.csv", "a.csv", "--window", "5:50", "--points", "50", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in ["pcm", "frechet", "dtw", "mse"] {
        assert_eq!(v[key].as_f64(), Some(0.0), "{key}: {v}");
    }
    assert!(v["area"].as_f64().is_some_and(|x| x.abs() < 1e-9), "{v}");
    assert_eq!((v["on"].as_str(), v["grid"]["s1"].as_f64()), (Some("grid"), Some(50.0)));
    assert_eq!(f.listing(), before, "lab compare wrote something");
}

#[test]
fn mse_is_null_with_a_note_when_the_strokes_do_not_overlap() {
    let f = Files::new();
    f.curve("a.csv", &crush(30, 10.0, 1.0));
    let late: Vec<(f64, f64)> = crush(30, 10.0, 1.0).into_iter().map(|(s, y)| (s + 20.0, y)).collect();
    f.curve("b.csv", &late);
    let o = f.compare(&["a.csv", "b.csv", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["mse"].is_null() && v["grid"].is_null(), "{v}");
    assert!(v["note"].as_str().unwrap().contains("common stroke range"), "{v}");
    assert!(
        v["pcm"].as_f64().is_some(),
        "the raw-point metrics are still there: {v}"
    );
}

#[test]
fn a_window_outside_a_curve_names_the_file_and_the_limiting_line() {
    let f = Files::new();
    let a = f.curve("a.csv", &crush(40, 60.0, 1.0));
    let b = f.curve("b.csv", &crush(25, 30.0, 1.0));
    // B ends at 30 mm, on its 25th data row: line 26.
    let o = f.compare(&["a.csv", "b.csv", "--window", "5:50"]);
    assert_bad_input(&o, &b, Some(26), "does not cover the window 5:50 mm");
    // A starts at 0 mm, after the window's start: line 2.
    let o = f.compare(&["a.csv", "b.csv", "--window=-1:20"]);
    assert_bad_input(&o, &a, Some(2), "does not cover");
}

#[test]
fn a_stroke_that_goes_back_inside_the_window_names_its_line() {
    let f = Files::new();
    f.curve("a.csv", &crush(40, 60.0, 1.0));
    let mut rows = crush(40, 60.0, 1.0);
    rows[20].0 = rows[18].0; // data row 21 (line 22) goes back
    let b = f.curve("b.csv", &rows);
    let o = f.compare(&["a.csv", "b.csv", "--window", "5:50"]);
    assert_bad_input(&o, &b, Some(22), "must increase strictly");
    // Outside the window it does not matter; without a window only mse is lost.
    assert!(f.compare(&["a.csv", "b.csv", "--window", "35:50"]).status.success());
    let o = f.compare(&["a.csv", "b.csv", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        v["mse"].is_null() && v["note"].as_str().unwrap().contains("increase strictly"),
        "{v}"
    );
}

#[test]
fn unreadable_files_and_bad_options_exit_2() {
    let f = Files::new();
    f.curve("a.csv", &crush(10, 10.0, 1.0));
    let bad = f.text("bad.csv", &format!("{HEADER}0,1\n1,x2\n"));
    assert_bad_input(&f.compare(&["a.csv", "bad.csv"]), &bad, Some(3), "expected a number");
    let missing = f.dir.path().join("missing.csv");
    assert_bad_input(&f.compare(&["a.csv", "missing.csv"]), &missing, None, "cannot read");
    let short = f.text("short.csv", &format!("{HEADER}0,1\n"));
    assert_bad_input(&f.compare(&["short.csv", "a.csv"]), &short, None, "at least two");
    for args in [
        &["a.csv", "a.csv", "--window", "5-60"][..],
        &["a.csv", "a.csv", "--window", "60:5"],
        &["a.csv", "a.csv", "--window", "5:nan"],
        &["a.csv", "a.csv", "--window", "1:5", "--points", "1"],
        &["a.csv"],
    ] {
        let o = f.compare(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{args:?}");
    }
}
