//! The clamped beam both solver-verdict families run (tests/loop_verdict.rs,
//! tests/confirmation.rs): its constants, its closed-form terms (one shared source of the truth
//! the tests are drawn from, independent of lab), the stand-in solver and its template.

use std::path::{Path, PathBuf};
use std::process::Command;

pub const F: f64 = 600.0;
pub const L: f64 = 20.0;
pub const B: f64 = 2.0;
pub const NU: f64 = 0.36;

/// The stand-in solver `clamped_beam` (examples/clamped_beam.rs), built with the tests (`cargo
/// test` compiles the examples).
pub fn solver() -> PathBuf {
    let path = PathBuf::from(env!("CARGO_BIN_EXE_lab"))
        .with_file_name("examples")
        .join("clamped_beam");
    assert!(
        path.is_file(),
        "{} is not built: run `cargo test --release` (it builds the examples)",
        path.display()
    );
    path
}

/// Euler–Bernoulli bending: E times the tip deflection.
pub fn bending(h: f64) -> f64 {
    4.0 * F * L.powi(3) / (B * h.powi(3))
}

/// Timoshenko's shear term: E times its deflection per unit shear factor.
pub fn shear(h: f64) -> f64 {
    F * L * (4.0 + 5.0 * NU) / (2.0 * B * h)
}

/// A compliant clamp's rotation: E times its deflection per unit kr.
pub fn clamp(h: f64) -> f64 {
    4.0 * F * L * L / (B * h * h)
}

/// The closed form of a candidate `lab` may offer, as a shape added to the beam's terms; `None`
/// for a scale error (proportional to the model: absorbed by E, it cannot add).
#[allow(dead_code)] // the oracles of the confirmation and not-excluded families
pub fn closed_form(name: &str) -> Option<fn(f64) -> f64> {
    match name {
        "fixture offset" | "constant offset" => Some(|_| 1.0),
        "linear in h" => Some(|h| h),
        "shear correction" => Some(shear),
        "clamp compliance" => Some(clamp),
        "scale error" => None,
        other => panic!("the oracle does not model '{other}'"),
    }
}

/// The weighted least-squares χ² of `means` at depths `hs` (weights `w`, one over each mean's
/// variance) against the model linear in the closed-form `shapes` of h (E enters as 1/E, so
/// `bending` alone is the baseline and `bending, clamp` the clamped beam, kr/E its second
/// coefficient), solved by nalgebra's SVD.
#[allow(dead_code)] // the oracles of the confirmation and not-excluded families
pub fn wls_chi2(hs: &[f64], means: &[f64], w: &[f64], shapes: &[fn(f64) -> f64]) -> f64 {
    let root: Vec<f64> = w.iter().map(|w| w.sqrt()).collect();
    let a = nalgebra::DMatrix::from_fn(hs.len(), shapes.len(), |i, j| shapes[j](hs[i]) * root[i]);
    let y = nalgebra::DVector::from_fn(hs.len(), |i, _| means[i] * root[i]);
    let beta = a.clone().svd(true, true).solve(&y, 1e-12).expect("an SVD solves");
    (a * beta - y).norm_squared()
}

/// The specimens of a beam study's `dir/tests.csv` (`design,h,deflection`), by design in name
/// order: each design's depth and its specimens' deflections.
#[allow(dead_code)] // not every family reads its tests back
pub fn specimens(dir: &Path) -> Vec<(f64, Vec<f64>)> {
    let text = std::fs::read_to_string(dir.join("tests.csv")).unwrap();
    let mut by_h: std::collections::BTreeMap<String, (f64, Vec<f64>)> = std::collections::BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let e = by_h
            .entry(f[0].to_string())
            .or_insert((f[1].parse().unwrap(), Vec::new()));
        e.1.push(f[2].parse().unwrap());
    }
    by_h.into_values().collect()
}

/// A beam study's lines up to its response: the constants, h over [lo, hi] mm, E over [55,000,
/// 82,000] MPa, the stand-in run on `beam.txt`.
pub fn study_head(name: &str, (lo, hi): (f64, f64)) -> String {
    format!(
        "name: {name}\n\
         constants: {{F: {F}, L: {L}, b: {B}, nu: {NU}}}\n\
         design:\n  h: {{unit: mm, min: {lo}, max: {hi}}}\n\
         parameters:\n  E: {{min: 55000, max: 82000, unit: MPa}}\n\
         simulation:\n  solver:\n    adapter: command\n    templates: [beam.txt.tera]\n    command: [{}, beam.txt]\n\
         \x20 response: {{file: output.txt, regex: \"y = (\\\\S+)\"}}\n",
        solver().display()
    )
}

/// Writes the solver's input template `beam.txt.tera` into `dir`.
pub fn write_template(dir: &Path) {
    std::fs::write(
        dir.join("beam.txt.tera"),
        "h = {{ h }}\nF = {{ F }}\nL = {{ L }}\nb = {{ b }}\nnu = {{ nu }}\nE = {{ E }}\n\
         s = {{ s | default(value=0.0) }}\nkr = {{ kr | default(value=0.0) }}\n",
    )
    .unwrap();
}

/// `lab run STUDY --out OUT --jobs 2`, which must succeed: its stderr and its results.json.
pub fn lab_run(study: &Path, out: &Path) -> (String, serde_json::Value) {
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args([
            "run",
            study.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            "2",
        ])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "lab run failed: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let results = serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    (String::from_utf8_lossy(&o.stderr).into_owned(), results)
}

/// `lab status STUDY --out OUT`: the planned runs it counts ("N planned run(s)").
#[allow(dead_code)] // the confirmation family's alone
pub fn lab_status_planned(study: &Path, out: &Path) -> u64 {
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(["status", study.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let n = text.split(" planned run").next().and_then(|s| s.rsplit(' ').next());
    n.and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("lab status said: {text}"))
}
