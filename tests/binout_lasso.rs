//! lab's binout reading and writing against the independent reader: lasso-python 2.0.4
//! (`lasso.dyna.Binout`) and LSTC's own `lsda` module it bundles, run by
//! `scripts/check_binout_lasso.py` in the venv `scripts/lasso-venv.sh` makes
//! (`target/lasso-venv`; `LAB_LASSO_PYTHON` names another python). Without it the tests skip, or
//! fail when CI=true.
//!
//! - the three binout files LS-DYNA R7.1.2, R9.3.1 and R12.2.1 wrote (`fixtures/lsdyna-real/`):
//!   every variable lasso-python reads, read equal by `lab::extract::lsdyna::binout` (integers
//!   exactly, reals bit for bit: lasso widens the stored float32 to float64 as lab does), and the
//!   list of what it reads equal to `lasso-python-reads.txt`;
//! - binout written by crushsim (through the `lsda` crate's writer): read equal by lasso-python;
//! - files written by the `lsda` writer in both byte orders with 4- and 8-byte lengths and offsets,
//!   read equal by LSTC's reader; a file LSTC's writer wrote (relative directory changes, every
//!   type, several symbol tables, a continuation file) read equal by the `lsda` reader.

use crate::crushsim_bin;

use std::path::{Path, PathBuf};
use std::process::Command;

use lab::extract::lsdyna::binout::{self, SeriesValues};
use lab::render::lsdyna;
use lab::render::mesh::{self, TubeSpec};
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The venv's python, or `None` (skip) when it is missing outside CI; in CI its absence fails.
fn lasso_python() -> Option<PathBuf> {
    let python = std::env::var_os("LAB_LASSO_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/lasso-venv/bin/python"));
    let ok = Command::new(&python)
        .args(["-c", "from lasso.dyna import Binout"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "lasso-python is missing in CI: {} cannot import it; .ci/run must run scripts/lasso-venv.sh",
            python.display()
        );
        eprintln!(
            "SKIPPED: no lasso venv at {} (run scripts/lasso-venv.sh); set CI=true to make this fail",
            python.display()
        );
    }
    ok.then_some(python)
}

fn check_script(python: &Path, mode: &str, arg: &Path) -> Value {
    let o = Command::new(python)
        .arg(root().join("scripts/check_binout_lasso.py"))
        .arg(mode)
        .arg(arg)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// Compares everything lasso read from `file` with lab's reading; returns the paths compared.
fn compare_with_lasso(b: &binout::Binout, lasso: &Value) -> Vec<String> {
    let mut compared = Vec::new();
    for (path, e) in lasso["entries"].as_object().unwrap() {
        match e["kind"].as_str().unwrap() {
            "list" => {
                let ours: Vec<&str> = b.db.variables(&format!("/{path}")).unwrap().map(|(n, _)| n).collect();
                let theirs: Vec<&str> = e["names"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|n| n.as_str().unwrap())
                    .collect();
                assert_eq!(ours, theirs, "{path}");
            }
            "text" => match b.series(path).unwrap().values {
                SeriesValues::Text(t) => assert_eq!(t, e["value"].as_str().unwrap(), "{path}"),
                other => panic!("{path}: lasso reads text, lab {other:?}"),
            },
            _ => {
                let s = b.series(path).unwrap();
                let shape: Vec<usize> = e["shape"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_u64().unwrap() as usize)
                    .collect();
                let theirs = floats(&e["values"]);
                let ours: Vec<f64> = match (&s.values, shape.len()) {
                    (SeriesValues::Scalar(v), 1) => v.clone(),
                    (SeriesValues::PerId(per_id), 2) => {
                        assert_eq!(per_id.len(), shape[1], "{path}: ids");
                        (0..shape[0])
                            .flat_map(|step| per_id.iter().map(move |id| id[step]))
                            .collect()
                    }
                    other => panic!("{path}: lasso shape {shape:?}, lab {other:?}"),
                };
                assert_eq!(bits(&ours), bits(&theirs), "{path}");
                if e["dtype"] == "int64" {
                    assert!(ours.iter().all(|x| x.fract() == 0.0), "{path}");
                }
            }
        }
        compared.push(path.clone());
    }
    compared
}

/// The paths `lasso-python-reads.txt` lists for one version.
fn reads_txt(version: &str) -> Vec<String> {
    let text = std::fs::read_to_string(root().join("fixtures/lsdyna-real/lasso-python-reads.txt")).unwrap();
    let section = text.split("## ").find(|s| s.starts_with(version)).unwrap();
    let mut paths: Vec<String> = section
        .lines()
        .skip(1)
        .filter_map(|l| l.split_once(": "))
        .map(|(p, _)| p.to_string())
        .collect();
    paths.sort();
    paths
}

#[test]
fn the_real_files_read_equal_to_lasso_python() {
    let Some(python) = lasso_python() else { return };
    for version in ["R7_1_2", "R9_3_1", "R12_2_1"] {
        let file = root().join(format!("fixtures/lsdyna-real/{version}/binout"));
        let lasso = check_script(&python, "dump", &file);
        let b = binout::open(&file).unwrap();
        assert!(b.notes().is_empty());
        let mut compared = compare_with_lasso(&b, &lasso);
        compared.sort();
        assert_eq!(
            compared,
            reads_txt(version),
            "{version}: what lasso reads now vs lasso-python-reads.txt"
        );
        let arrays = lasso["entries"]
            .as_object()
            .unwrap()
            .values()
            .filter(|e| e["kind"] == "array")
            .count();
        eprintln!("{version}: {} paths equal ({arrays} arrays)", compared.len());
    }
}

/// crushsim run in a fresh directory on the honeycomb deck (C6T5, 185 MPa) with BINARY = 3.
fn crushsim_binout() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut tera = tera::Tera::new();
    lsdyna::register(&mut tera);
    tera.add_raw_template("main.k.tera", include_str!("../templates/honeycomb/main.k.tera"))
        .unwrap();
    let mut ctx = tera::Context::new();
    for (k, v) in [
        ("c", 6.0),
        ("t", 0.05),
        ("sigma_y", 185.0),
        ("term_time", 0.061),
        ("dt_out", 0.0005),
    ] {
        ctx.insert(k, &v);
    }
    ctx.insert("design_name", "C6T5");
    ctx.insert("ribbon_factor", &2);
    ctx.insert("binary", &3);
    std::fs::write(dir.path().join("main.k"), tera.render("main.k.tera", &ctx).unwrap()).unwrap();
    let (include, _) = mesh::include(&TubeSpec::paper(6.0, 2.0)).unwrap();
    std::fs::write(dir.path().join("mesh.k"), include).unwrap();
    let o = Command::new(crushsim_bin::crushsim())
        .args(["i=main.k", "ncpu=1"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    dir
}

#[test]
fn crushsims_binout_reads_equal_in_lasso_python() {
    let Some(python) = lasso_python() else { return };
    let run = crushsim_binout();
    let file = run.path().join("binout");
    let lasso = check_script(&python, "dump", &file);
    assert_eq!(lasso["top"], serde_json::json!(["glstat", "nodout", "rcforc"]));
    let b = binout::open(&file).unwrap();
    let compared = compare_with_lasso(&b, &lasso);
    for must in [
        "rcforc/z_force",
        "rcforc/ids",
        "rcforc/side",
        "nodout/z_displacement",
        "glstat/kinetic_energy",
        "glstat/title",
    ] {
        assert!(compared.iter().any(|p| p == must), "{must} not compared: {compared:?}");
    }
    // The force lasso reads is the contact force of the run (interface 1 master, N), not zeros.
    let z = &lasso["entries"]["rcforc/z_force"];
    assert_eq!(z["shape"][1], 6, "three contacts, slave and master each");
    let peak = floats(&z["values"]).iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(peak > 1000.0, "peak contact force {peak} N");
}

#[test]
fn lsda_writers_files_read_equal_by_lstcs_reader_and_back() {
    let Some(python) = lasso_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let values = [
        lsda::Values::I1(vec![-128, 0, 127]),
        lsda::Values::I2(vec![-32768, 32767]),
        lsda::Values::I4(vec![i32::MIN, 1002285]),
        lsda::Values::I8(vec![i64::MIN, 1 << 53]),
        lsda::Values::U1(vec![255]),
        lsda::Values::U2(vec![65535]),
        lsda::Values::U4(vec![u32::MAX]),
        lsda::Values::U8(vec![1 << 53]),
        lsda::Values::R4(vec![0.1, -2.25e-7, 3.4e38, 1e-45]),
        lsda::Values::R8(vec![0.1, -1e-310, f64::MAX]),
    ];
    for endian in [lsda::Endian::Little, lsda::Endian::Big] {
        for (length_size, offset_size) in [(8, 8), (4, 4)] {
            let h = lsda::Header {
                endian,
                length_size,
                offset_size,
                ..lsda::Header::default()
            };
            let mut w = lsda::Writer::new(h);
            for (k, v) in values.iter().enumerate() {
                w.cd(&format!("/t/d{:06}", k % 3 + 1));
                w.write(&format!("v{k}"), v).unwrap();
                if k % 4 == 3 {
                    w.flush().unwrap();
                }
            }
            let path = dir.path().join(format!("{endian:?}-{length_size}-{offset_size}"));
            w.save(&path).unwrap();
            let lstc = check_script(&python, "raw", &path);
            assert_eq!(lstc.as_object().unwrap().len(), values.len(), "{}", path.display());
            for (k, v) in values.iter().enumerate() {
                let e = &lstc[format!("/t/d{:06}/v{k}", k % 3 + 1)];
                assert_eq!(e["type"], v.type_id().code(), "{endian:?} v{k}");
                assert_eq!(
                    bits(&floats(&e["values"])),
                    bits(&v.to_f64()),
                    "{endian:?} {length_size}/{offset_size} v{k}"
                );
            }
        }
    }
    // And the other way: LSTC's writer, read by the lsda crate.
    let path = dir.path().join("by-lstc");
    let written = check_script(&python, "write", &path);
    let db = lsda::Database::open(&path).unwrap();
    assert_eq!(db.files().count(), 2, "the file and its continuation");
    assert!(db.notes().is_empty(), "{:?}", db.notes());
    for (p, e) in written.as_object().unwrap() {
        let v = db.variable(p).unwrap_or_else(|| panic!("{p}"));
        assert_eq!(v.type_id().code() as u64, e["type"].as_u64().unwrap(), "{p}");
        assert_eq!(bits(&v.to_f64()), bits(&floats(&e["values"])), "{p}");
    }
    assert_eq!(written.as_object().unwrap().len(), 14);
}
