//! Every T01 file recorded in the repository read by this crate and by OpenRadioss's own converter
//! `th_to_csv_linux64_gf` (an independent reader: C++, from the OpenRadioss sources) on the same
//! file: the same times, the same column names in the same order, and the same numbers.
//!
//! The converter prints 7 significant digits (`%e`), so a value read here must equal the printed
//! one within half a unit of its 7th digit (relative 5e-7, plus 1e-30 for zeros printed with a
//! sign). Forces are the converter's derivatives of the stored impulses: the same formula in double
//! precision from the same single-precision impulses, so within the print precision of the column's
//! largest value (1e-6 of it: the difference of two nearly equal impulses loses digits, but both
//! sides lose the same ones).
//!
//! Group columns (interfaces, nodes) are named by the converter from the starter's `<file>_TITLES`
//! beside the file; where it was recorded their names are compared too.
//!
//! Files: `*T01` under `fixtures/honeycomb-openradioss/` (or the directory in `RADIOSS_TH_FILES`).
//! The converter: `th_to_csv_linux64_gf` on PATH (`eval "$(../shared/tools/openradioss/install.sh)"`)
//! or the program in `RADIOSS_TH_TO_CSV`. Without it the test says so and passes, except under
//! `CI=true`, where it fails: CI installs OpenRadioss.

use std::path::{Path, PathBuf};
use std::process::Command;

fn files() -> Vec<PathBuf> {
    let root = std::env::var_os("RADIOSS_TH_FILES")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/honeycomb-openradioss"));
    let mut out = Vec::new();
    let mut stack = vec![root];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().is_some_and(|n| n.to_string_lossy().ends_with("T01")) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

fn converter() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("RADIOSS_TH_TO_CSV") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("th_to_csv_linux64_gf"))
        .find(|p| p.is_file())
}

/// The starter's list of group variable names beside a T01 file (`mainT01_TITLES`): the
/// converter names group columns from it (`var <n>` without it).
fn titles_of(t01: &Path) -> PathBuf {
    let mut name = t01.file_name().unwrap().to_os_string();
    name.push("_TITLES");
    t01.with_file_name(name)
}

/// The converter's CSV of `t01`: header names and rows of numbers.
fn convert(exe: &Path, t01: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join(t01.file_name().unwrap());
    std::fs::copy(t01, &copy).unwrap();
    let titles = titles_of(t01);
    if titles.is_file() {
        std::fs::copy(&titles, titles_of(&copy)).unwrap();
    }
    let status = Command::new(exe)
        .arg(copy.file_name().unwrap())
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(status.status.success(), "{} failed on {}", exe.display(), t01.display());
    let csv_path = dir
        .path()
        .join(format!("{}.csv", copy.file_name().unwrap().to_string_lossy()));
    let mut reader = csv::ReaderBuilder::new().from_path(&csv_path).unwrap();
    let header = reader.headers().unwrap().iter().map(str::to_string).collect();
    let rows = reader
        .records()
        .map(|r| r.unwrap().iter().map(|v| v.trim().parse::<f64>().unwrap()).collect())
        .collect();
    (header, rows)
}

/// Column names, group columns only when the starter's `_TITLES` file was there to name them.
fn check_names(th: &radioss_th::TimeHistory, header: &[String], file: &Path) {
    assert_eq!(header.len(), th.columns.len() + 1, "{}: column count", file.display());
    assert_eq!(header[0].trim(), "time");
    let titled = titles_of(file).is_file();
    for (c, name) in th.columns.iter().zip(&header[1..]) {
        let last = name.split_whitespace().last().unwrap_or("");
        let ok = match &c.source {
            radioss_th::Source::Global => name.trim() == c.name,
            radioss_th::Source::Group { .. } if !titled => true,
            _ => last == c.name,
        };
        assert!(ok, "{}: column `{name}` read here as {c:?}", file.display());
        if let radioss_th::Source::Group { element, .. } = c.source {
            assert!(
                name.split_whitespace().any(|w| w == element.to_string()),
                "{name} vs {c:?}"
            );
        }
    }
}

fn check_values(th: &radioss_th::TimeHistory, rows: &[Vec<f64>], file: &Path) {
    assert_eq!(rows.len(), th.times.len(), "{}: steps", file.display());
    let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 5e-7 * b.abs().max(scale) + 1e-30;
    for (s, row) in rows.iter().enumerate() {
        assert!(close(th.times[s], row[0], 0.0), "{}: time {s}", file.display());
    }
    for (c, col) in th.columns.iter().enumerate() {
        let printed: Vec<f64> = rows.iter().map(|r| r[c + 1]).collect();
        let (mine, scale) = match col.source {
            radioss_th::Source::Group { kind, .. } if radioss_th::names::is_impulse(kind) => {
                let f = radioss_th::force_from_impulse(&th.times, &th.series(c));
                let largest = printed.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                (f, 2.0 * largest)
            }
            _ => (th.series(c), 0.0),
        };
        for (s, (a, b)) in mine.iter().zip(&printed).enumerate() {
            assert!(
                close(*a, *b, scale),
                "{}: {col:?} step {s}: read {a}, th_to_csv {b}",
                file.display()
            );
        }
    }
}

#[test]
fn every_recorded_t01_reads_as_th_to_csv_reads_it() {
    let files = files();
    let Some(exe) = converter() else {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true but th_to_csv_linux64_gf is not on PATH (install OpenRadioss)"
        );
        eprintln!(
            "skipped: th_to_csv_linux64_gf not on PATH ({} T01 files not compared)",
            files.len()
        );
        return;
    };
    assert!(!files.is_empty(), "no T01 files found to compare");
    for file in &files {
        let th = radioss_th::read(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let (header, rows) = convert(&exe, file);
        check_names(&th, &header, file);
        check_values(&th, &rows, file);
    }
    eprintln!("{} T01 files equal th_to_csv's reading", files.len());
}
