//! The CalculiX cantilever with a compliant clamp (issue 12, simulation in the loop):
//! `templates/cantilever-ccx/beam-clamp.inp.tera` and `studies/cantilever-ccx-clamp.yaml`.
//!
//! - Without `clamp_E` the clamp template renders the fully clamped deck byte for byte (no ccx).
//! - Live: the clamp layer nests the clamped beam and its compliance scales as 1/clamp_E.
//! - Live: the study, with the real solver in the loop, recovers E and clamp_E from tests that
//!   CalculiX made at a known clamp (scripts/make_cantilever_clamp_tests.sh).
//!
//! Tests that need `ccx` skip with a message when it is missing, except in CI (`CI=true`), where a
//! missing `ccx` is a failure: `.ci/run` installs it.

use crate::ccx_common;
use crate::verdict_common;

use std::path::Path;
use std::process::Command;

use ccx_common::{have_ccx, repo};
use lab::execute::{Adapter, STDOUT_FILE};
use lab::render::{self, Renderer};
use lab::study::{Response, Simulation, Study, Template};

/// The truth of studies/cantilever-ccx-clamp-tests.csv (examples/make_cantilever_clamp_tests.rs).
const E0: f64 = 68_000.0;
const CLAMP_E: f64 = 210_000.0;

fn clamp_study() -> Study {
    lab::study::load(&repo().join("studies/cantilever-ccx-clamp.yaml")).unwrap()
}

fn renderer(file: &str) -> Renderer {
    let path = repo().join("templates/cantilever-ccx").join(file);
    let source = std::fs::read_to_string(&path).unwrap();
    Renderer::new(&[Template {
        file: path,
        output: "beam.inp".into(),
        source,
    }])
    .unwrap()
}

/// The deck of `file` for design `h`, modulus `e`, mesh and (optionally) clamp modulus.
fn deck(file: &str, h: f64, e: f64, mesh: (f64, f64, f64), clamp_e: Option<f64>) -> Vec<u8> {
    let study = clamp_study();
    let mut ctx = render::context(&study, &format!("h{h}"), &[h], &[e]);
    ctx.insert("nx", &mesh.0);
    ctx.insert("ny", &mesh.1);
    ctx.insert("nz", &mesh.2);
    if let Some(c) = clamp_e {
        render::extend(&mut ctx, &[("clamp_E".to_string(), c)]);
    }
    renderer(file).render(&ctx).unwrap().remove(0).1
}

#[test]
fn clamp_template_without_clamp_e_is_the_clamped_deck_byte_for_byte() {
    for (h, e, mesh) in [
        (8.0, 68_000.0, (10.0, 4.0, 1.0)),
        (12.5, 55_123.456, (20.0, 8.0, 2.0)),
        (7.0, 80_000.0, (3.0, 2.0, 3.0)),
    ] {
        let clamped = deck("beam.inp.tera", h, e, mesh, None);
        let clamp = deck("beam-clamp.inp.tera", h, e, mesh, None);
        assert!(clamped == clamp, "h = {h}, E = {e}, mesh {mesh:?}: the decks differ");
        let with = String::from_utf8(deck("beam-clamp.inp.tera", h, e, mesh, Some(2e5))).unwrap();
        assert!(with.contains("ELSET=ECLAMP") && with.len() > clamp.len(), "{with}");
    }
}

/// Runs ccx on `inp` (the deck of job `beam`) in a temporary directory; the mean tip deflection.
fn tip(inp: &[u8]) -> f64 {
    let Simulation::Solver(sim) = &clamp_study().simulation else {
        panic!("a solver study")
    };
    let Response::Dat(study_adapter) = &sim.response else {
        panic!("a CalculiX study")
    };
    let adapter = lab::extract::adapters::calculix::CalculixAdapter::new("beam", study_adapter.response.clone());
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("beam.inp"), inp).unwrap();
    let out = Command::new("ccx")
        .args(["-i", "beam"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    std::fs::write(dir.path().join(STDOUT_FILE), &out.stdout).unwrap();
    assert!(out.status.success(), "{out:?}");
    assert!(adapter.find_failure(dir.path()).is_none());
    adapter.extract(dir.path()).unwrap()
}

/// The clamp layer is a compliance in series with the clamped beam: a very stiff layer gives the
/// clamped tip back (it nests the baseline), and doubling clamp_E about halves what it adds.
#[test]
fn live_clamp_layer_nests_the_clamped_beam_and_scales_as_its_compliance() {
    if !have_ccx() {
        return;
    }
    let coarse = (10.0, 4.0, 1.0);
    let clamped = tip(&deck("beam.inp.tera", 10.0, E0, coarse, None));
    let rigid = tip(&deck("beam-clamp.inp.tera", 10.0, E0, coarse, Some(1e12)));
    let soft = tip(&deck("beam-clamp.inp.tera", 10.0, E0, coarse, Some(CLAMP_E)));
    let stiffer = tip(&deck("beam-clamp.inp.tera", 10.0, E0, coarse, Some(2.0 * CLAMP_E)));
    let report = format!(
        "clamped {clamped}, clamp_E 1e12 {rigid}, {CLAMP_E} {soft}, {} {stiffer}",
        2.0 * CLAMP_E
    );
    // 1e12 MPa: the layer adds ~1e-7 of the tip deflection; 1e-6 leaves room for the solver's round-off.
    assert!(((rigid - clamped) / clamped).abs() < 1e-6, "{report}");
    // Series compliance: exact up to the coupling of the layer with the root section's deformation.
    let ratio = (soft - clamped) / (stiffer - clamped);
    assert!(soft > clamped && (1.9..2.1).contains(&ratio), "ratio {ratio}: {report}");
}

/// The study with the real solver in the loop, sampled sequentially: the screening's batches, the
/// probes at clamp_E = 250,000, then the loop's batches over E x clamp_E, all by ccx, with one
/// emulator across the designs; at most a quarter of the 238 runs the former fixed design made (84
/// screening + 154 in the loop).
#[test]
fn live_clamp_extension_recovers_e_and_clamp_e_with_the_solver_in_the_loop() {
    if !have_ccx() {
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(["run", "studies/cantilever-ccx-clamp.yaml", "--jobs", "2", "--out"])
        .arg(out.path())
        .current_dir(repo())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.path().join("results.json")).unwrap()).unwrap();
    let d = &results["diagnosis"];
    println!("{}", d["summary"]);
    verdict_common::assert_verdict_follows_evidence(d);

    // The clamp leads the ranking. Named, or (what these tests give, see the study's comment)
    // undecided against 'shear deformation' (1/h): over h = 7..13, once E absorbs the bending
    // (1/h^3), what is left of 1/h^2 and of 1/h differs by about the tests' noise, so the
    // encompassing test of the clamp against that rival has little power. Either way the clamp
    // is among the two leading explanations, which is what sends it into the loop.
    assert_eq!(d["candidates"][0]["name"], "compliant clamp", "{d}");
    let named = d["cause"] == "compliant clamp";
    let undecided = d["verdict"] == "cannot_tell_apart" && d["leading"][0] == "compliant clamp";
    assert!(named || undecided, "{}", d["summary"]);

    let x = &d["extensions"][0];
    assert_eq!(x["hypothesis"], "compliant clamp", "{x}");
    let value = |name: &str| x["parameters"][name].as_f64().unwrap();
    let interval = |name: &str| {
        let i = &x["interval95"][name];
        (i[0].as_f64().unwrap(), i[1].as_f64().unwrap())
    };
    let (e, clamp_e) = (value("E"), value("clamp_E"));
    let report = format!(
        "E = {e} {:?}, clamp_E = {clamp_e} {:?}",
        interval("E"),
        interval("clamp_E")
    );
    // E within 1 %: its standard error from 5 specimens x 7 designs at 0.25 % scatter is about
    // 0.35 % (E and clamp_E correlate at -0.98, which inflates it), and the tests come from a finer
    // mesh (40 x 16 x 4) than the study's (20 x 8 x 2), about 0.15 % stiffer; 1 % is ~3 standard errors.
    assert!(((e - E0) / E0).abs() < 0.01, "{report}");
    // clamp_E within 5 %: the clamp's effect is 15-35 % of the tip deflection, so its modulus is
    // known about 4x less precisely than E (standard error about 1.3 %), plus the mesh difference
    // of the clamp layer itself; 5 % is ~3-4 standard errors.
    assert!(((clamp_e - CLAMP_E) / CLAMP_E).abs() < 0.05, "{report}");
    // The interval reaches the truth within the mesh difference (0.15 %, rounded up to 0.2 %): the
    // calibration knows E of the study's mesh, not of the tests'.
    let (lo, hi) = interval("E");
    assert!(lo <= E0 * 1.002 && E0 * 0.998 <= hi, "{report}");
    let (lo, hi) = interval("clamp_E");
    assert!(lo <= CLAMP_E && CLAMP_E <= hi, "{report}");
    // The joint surrogates (GP over E x clamp_E) reproduce their check runs: the recovered values
    // are the solver's, not the emulator's.
    let check = x["runs"]["surrogate_check_error"].as_f64().unwrap();
    assert!(check < 0.005, "check-run error {check}");

    // The runs really ran through ccx: the loop's and the screening's, as many run directories as
    // the sequence made runs, and at most a quarter of the fixed design's 238 runs (47 measured with
    // one emulator across the designs; 100 with one per design).
    let total = results["sampling"]["runs"].as_u64().unwrap();
    let in_loop = results["runs"]["in_the_loop"].as_u64().unwrap();
    assert_eq!(x["runs"]["planned"].as_u64(), Some(in_loop), "{x}");
    assert_eq!(x["runs"]["succeeded"].as_u64(), Some(in_loop), "{x}");
    assert_eq!(
        results["runs"]["succeeded"].as_u64(),
        Some(total),
        "{}",
        results["runs"]
    );
    assert!(total * 4 <= 238, "{total} ccx runs");
    let runs: Vec<_> = std::fs::read_dir(out.path().join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(runs.len() as u64, total);
    let by_ccx = |dir: &Path| {
        let stdout = std::fs::read_to_string(dir.join(STDOUT_FILE)).unwrap_or_default();
        stdout.contains("CalculiX Version") && stdout.contains("Job finished") && dir.join("beam-clamp.dat").is_file()
    };
    let clamp_runs: Vec<_> = runs
        .iter()
        .filter(|dir| std::fs::read_to_string(dir.join("beam-clamp.inp")).is_ok_and(|inp| inp.contains("ELSET=ECLAMP")))
        .collect();
    // The probes and the loop's runs have a clamp layer; the screening's do not.
    let probes: u64 = results["sampling"]["stopped"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["stage"] == "probes")
        .map(|s| s["runs"].as_u64().unwrap())
        .sum();
    assert_eq!(clamp_runs.len() as u64, probes + in_loop);
    assert!(runs.iter().all(|dir| by_ccx(dir)), "a run not made by ccx");
}
