//! Model-extension hypotheses (`diagnosis.hypotheses[].extension`): the paper's cantilever through
//! the `lab` binary, with an Euler-Bernoulli solver whose template's `shear` variable adds the
//! Timoshenko shear term, against Timoshenko tests; the plan and keys of extension runs; and the
//! study errors, each at the offending node.

use std::path::{Path, PathBuf};
use std::process::Command;

use lab::error::InputError;
use lab::execute::sweep;
use lab::plan::{Plan, RunRole};
use lab::study::{self, Simulation};
use serde_json::Value;

const STUDY: &str = "cantilever-extension.yaml";

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The study, its template, the solver and the tests CSV in a fresh directory.
fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for rel in [
        STUDY,
        "cantilever-tests.csv",
        "cantilever-extension/beam.txt.tera",
        "solvers/beam.py",
    ] {
        let to = dir.path().join(rel);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(repo().join("studies").join(rel), to).unwrap();
    }
    dir
}

fn lab(dir: &Path, args: &[&str], log: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(args)
        .current_dir(dir)
        .env("LAB_TEST_SOLVER_LOG", log)
        .env("LAB_TEST_SOLVER_SLEEP", "0")
        .output()
        .unwrap()
}

fn starts(log: &Path) -> usize {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .filter(|l| l.starts_with("start "))
        .count()
}

/// 7 designs × (8 samples + 2 checks) baseline runs, plus 7 × 8 runs with shear = 1, then the
/// confirmation runs: the uncorrected simulation and the shear model at their fitted parameters at
/// the 7 designs.
const PLANNED: usize = 7 * 10 + 7 * 8 + 7 * 2;

#[test]
fn cantilever_shear_extension_is_named_with_gamma_one_and_e0() {
    let dir = setup();
    let log = dir.path().join("solver.log");
    let out = lab(dir.path(), &["run", STUDY, "--out", "out", "--jobs", "4"], &log);
    let text = format!(
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert_eq!(
        starts(&log),
        PLANNED,
        "every planned run, extension runs included, is run once"
    );

    let results: Value = serde_json::from_slice(&std::fs::read(dir.path().join("out/results.json")).unwrap()).unwrap();
    assert_eq!(results["runs"]["planned"], PLANNED, "{}", results["runs"]);
    let d = &results["diagnosis"];
    assert_eq!(d["discrepancy_detected"], true);
    assert_eq!(d["cause"], "shear deformation", "{}", d["summary"]);
    let names: Vec<&str> = d["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(names[0], "shear deformation");
    for h in ["root rotation", "offset"] {
        assert!(names.contains(&h), "{h} not ranked: {names:?}");
    }
    assert_eq!(d["candidates"][0]["extension"]["shear"], 1.0);

    let x = &d["extended"];
    assert_eq!(x["cause"], "shear deformation");
    let gamma = x["amplitude"].as_f64().unwrap();
    let e = x["parameters"]["E"].as_f64().unwrap();
    assert!(
        (gamma - 1.0).abs() < 0.01,
        "γ = {gamma}: the tests are the extension exactly (shear = 1)"
    );
    assert!((e / 68_000.0 - 1.0).abs() < 0.005, "extended E = {e}");
    assert_eq!(x["extension"]["variables"]["shear"], 1.0);
    assert_eq!(x["extension"]["amplitude"].as_f64(), Some(gamma));
    let meaning = x["extension"]["meaning"].as_str().unwrap();
    assert!(meaning.contains("γ × 1") && meaning.contains("linear"), "{meaning}");
    assert!(x["gain"].as_f64().unwrap() > 0.9, "{x}");
    assert!(d["summary"].as_str().unwrap().contains("shear ≈ γ"), "{}", d["summary"]);
    eprintln!("γ = {gamma}, E = {e}");

    // Extension runs are stored like any run: running again reuses all of them.
    let again = lab(dir.path(), &["run", STUDY, "--out", "out", "--jobs", "4"], &log);
    assert_eq!(
        again.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(starts(&log), PLANNED, "nothing is run twice");
    let status = lab(dir.path(), &["status", STUDY, "--out", "out"], &log);
    let status = String::from_utf8_lossy(&status.stdout);
    assert!(
        status.contains(&format!("{PLANNED} planned run(s): done {PLANNED}")),
        "{status}"
    );
}

#[test]
fn extension_runs_repeat_the_samples_with_their_own_keys() {
    let dir = setup();
    let s = study::load(&dir.path().join(STUDY)).unwrap_or_else(|e| panic!("{e}"));
    let Simulation::Solver(sim) = &s.simulation else {
        panic!("a solver study")
    };
    let plan = Plan::new(&s, sim);
    let prepared = sweep::prepare(&s, &lab::extract::adapters::solver(sim).unwrap(), &plan).unwrap();
    let base: Vec<usize> = (0..plan.runs.len())
        .filter(|&i| plan.runs[i].role == RunRole::Sample)
        .collect();
    let ext: Vec<usize> = (0..plan.runs.len())
        .filter(|&i| plan.runs[i].role == RunRole::Extension(0))
        .collect();
    assert_eq!(base.len(), ext.len());
    assert!(
        ext.iter().all(|&i| i >= 70),
        "extension runs come after every baseline run"
    );
    for (&b, &x) in base.iter().zip(&ext) {
        let (rb, rx) = (&plan.runs[b], &plan.runs[x]);
        assert_eq!(
            (&rb.design, &rb.theta),
            (&rx.design, &rx.theta),
            "same design and parameter sample"
        );
        assert_ne!(prepared.keys[b], prepared.keys[x], "different inputs, different key");
        let input = |i: usize| String::from_utf8(prepared.inputs[&prepared.keys[i]][0].1.clone()).unwrap();
        assert!(
            input(b).contains("shear = 0\n") && input(x).contains("shear = 1.0\n"),
            "{}",
            input(x)
        );
    }

    // Without the extension hypothesis the baseline plans (and keys) the same runs.
    let yaml = std::fs::read_to_string(dir.path().join(STUDY)).unwrap();
    let without = yaml.replace("    - name: shear deformation\n      extension: {shear: 1}\n", "");
    assert_ne!(without, yaml);
    std::fs::write(dir.path().join("without.yaml"), without).unwrap();
    let s2 = study::load(&dir.path().join("without.yaml")).unwrap_or_else(|e| panic!("{e}"));
    let Simulation::Solver(sim2) = &s2.simulation else {
        panic!()
    };
    let plan2 = Plan::new(&s2, sim2);
    let keys2 = sweep::prepare(&s2, &lab::extract::adapters::solver(sim2).unwrap(), &plan2)
        .unwrap()
        .keys;
    assert_eq!(keys2[..], prepared.keys[..70]);
}

// --- study errors --------------------------------------------------------------------------------

/// A solver study with an extension hypothesis (line 17); each bad case changes one thing.
const SOLVER: &str = r#"name: beam
constants: {F: 600, L: 20, b: 2}
design:
  h: {unit: mm}
parameters:
  E: {min: 50000, max: 80000}
simulation:
  solver: {adapter: command, templates: [beam.txt.tera], command: [python3, beam.py]}
  response: {file: out.txt, regex: "y = (\\S+)"}
  sampling: {method: lhs, count: 4, seed: 1}
experiments:
  file: tests.csv
  response: deflection
training: [h8, h10]
diagnosis:
  hypotheses:
    - name: shear
      extension: {shear: 1}
"#;

const TEMPLATE: &str = "h = {{ h }}\nE = {{ E }}\nshear = {{ shear | default(value=0) }}\n";
const CSV: &str = "design,h,deflection\nh8,8,0.308\nh10,10,0.167\n";

fn write_case(yaml: &str, template: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("study.yaml");
    std::fs::write(&study, yaml).unwrap();
    std::fs::write(dir.path().join("tests.csv"), CSV).unwrap();
    std::fs::write(dir.path().join("beam.txt.tera"), template).unwrap();
    (dir, study)
}

#[track_caller]
fn error_at(yaml: &str, template: &str, line: usize, needle: &str, phrase: &str) -> InputError {
    let (_dir, path) = write_case(yaml, template);
    let err = study::load(&path)
        .err()
        .unwrap_or_else(|| panic!("expected an error for:\n{yaml}"));
    let shown = err.to_string();
    assert_eq!(err.file, path, "{shown}");
    let span = err.span.as_ref().unwrap_or_else(|| panic!("no line in:\n{shown}"));
    let text = yaml.lines().nth(line - 1).unwrap();
    let column = text[..text.find(needle).unwrap()].chars().count() + 1;
    assert_eq!((span.line, span.column), (line, column), "{shown}");
    assert!(shown.contains(phrase), "`{phrase}` not in:\n{shown}");
    assert!(
        err.excerpt.as_deref().is_some_and(|e| e.contains('^')),
        "no caret in:\n{shown}"
    );
    err
}

#[test]
fn solver_study_with_an_extension_loads() {
    let (_dir, path) = write_case(SOLVER, TEMPLATE);
    let s = study::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        s.diagnosis.hypotheses[0].extension(),
        Some(&[("shear".to_string(), 1.0)][..])
    );
}

#[test]
fn extension_in_a_closed_form_study_is_a_located_error() {
    let yaml = std::fs::read_to_string(repo().join("studies/cantilever-diagnosis.yaml")).unwrap();
    let yaml = yaml.replace("      term: \"1/h\"\n", "      extension: {shear: 1}\n");
    let line = yaml.lines().position(|l| l.contains("extension:")).unwrap() + 1;
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        repo().join("studies/cantilever-tests.csv"),
        dir.path().join("cantilever-tests.csv"),
    )
    .unwrap();
    let path = dir.path().join("study.yaml");
    std::fs::write(&path, &yaml).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_lab"))
        .arg("check")
        .arg(&path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let column = yaml.lines().nth(line - 1).unwrap().find("extension").unwrap() + 1;
    let location = format!("{}:{line}:{column}:", path.display());
    assert!(stderr.contains(&location), "no `{location}` in:\n{stderr}");
    assert!(stderr.contains("closed-form") && stderr.contains("`term:`"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn term_and_extension_together_or_neither() {
    let both = SOLVER.replace(
        "      extension: {shear: 1}\n",
        "      term: \"1/h\"\n      extension: {shear: 1}\n",
    );
    error_at(&both, TEMPLATE, 19, "extension", "both `term` and `extension`");
    let neither = SOLVER.replace("      extension: {shear: 1}\n", "");
    error_at(&neither, TEMPLATE, 17, "shear", "needs `term:`");
}

#[test]
fn extension_variable_no_template_uses_is_an_error() {
    let unused = SOLVER.replace("{shear: 1}", "{shear: 1, kappa: 0.8}");
    error_at(
        &unused,
        TEMPLATE,
        18,
        "kappa",
        "`kappa` does not change what the templates render",
    );
    // Used without a default: the baseline does not render, which `lab check` reports.
    let (_dir, path) = write_case(SOLVER, "h = {{ h }}\nE = {{ E }}\nshear = {{ shear }}\n");
    let s = study::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let Simulation::Solver(sim) = &s.simulation else {
        panic!()
    };
    let e = sweep::prepare(&s, &lab::extract::adapters::solver(sim).unwrap(), &Plan::new(&s, sim))
        .err()
        .expect("baseline runs cannot render `shear`");
    assert!(e.to_string().contains("beam.txt.tera:3:"), "{e}");
}

#[test]
fn extension_cannot_set_a_design_variable_or_parameter_or_nothing() {
    error_at(
        &SOLVER.replace("{shear: 1}", "{shear: 1, E: 70000}"),
        TEMPLATE,
        18,
        "E:",
        "calibration parameter",
    );
    error_at(
        &SOLVER.replace("{shear: 1}", "{h: 9}"),
        TEMPLATE,
        18,
        "h:",
        "design variable",
    );
    error_at(
        &SOLVER.replace("{shear: 1}", "{}"),
        TEMPLATE,
        18,
        "extension",
        "empty `extension`",
    );
}

#[test]
fn extension_range_loads_with_its_probe_and_plans_joint_runs() {
    let ranged = SOLVER.replace("{shear: 1}", "{shear: {min: 0, max: 2, unit: \"-\"}, kappa: 0.8}");
    let template = format!("{TEMPLATE}kappa = {{{{ kappa | default(value=1) }}}}\n");
    let (_dir, path) = write_case(&ranged, &template);
    let s = study::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let h = &s.diagnosis.hypotheses[0];
    // Screened at the middle of the range; the fixed variable at its value.
    assert_eq!(
        h.extension(),
        Some(&[("shear".to_string(), 1.0), ("kappa".to_string(), 0.8)][..])
    );
    assert_eq!(h.ranges().len(), 1);
    assert_eq!((h.ranges()[0].min, h.ranges()[0].max), (0.0, 2.0));
    let Simulation::Solver(sim) = &s.simulation else {
        panic!()
    };
    // The loop's plan: a Latin hypercube over E × shear (linear surrogate in 2 variables: 2 × 3
    // samples) plus the study's 5 check runs, at both tested designs, with kappa held at 0.8.
    let joint = Plan::joint(&s, sim, &[0]);
    assert_eq!(sim.sampling.check_runs, 5);
    assert_eq!(joint.runs.len(), 2 * (6 + 5));
    for r in &joint.runs {
        let shear = r.extension.iter().find(|(n, _)| n == "shear").unwrap().1;
        assert!((0.0..=2.0).contains(&shear) && (50_000.0..=80_000.0).contains(&r.theta[0]));
        assert!(r.extension.contains(&("kappa".to_string(), 0.8)));
        assert!(matches!(r.role, RunRole::Joint(0) | RunRole::JointCheck(0)));
    }
    let shears: std::collections::BTreeSet<u64> = joint.runs.iter().map(|r| r.extension[0].1.to_bits()).collect();
    assert_eq!(
        shears.len(),
        11,
        "each of the 6 samples and the 5 checks at its own shear"
    );
    // Rendered with their values: every joint run has keys of its own, none a screening run's.
    let keys = sweep::prepare(&s, &lab::extract::adapters::solver(sim).unwrap(), &joint)
        .unwrap()
        .keys;
    let screening = sweep::prepare(&s, &lab::extract::adapters::solver(sim).unwrap(), &Plan::new(&s, sim))
        .unwrap()
        .keys;
    assert!(keys.iter().all(|k| !screening.contains(k)));
    // Nothing to extend without ranges.
    let (_dir2, fixed) = write_case(SOLVER, TEMPLATE);
    let f = study::load(&fixed).unwrap();
    let Simulation::Solver(fsim) = &f.simulation else {
        panic!()
    };
    assert!(Plan::joint(&f, fsim, &[0]).runs.is_empty());
}

#[test]
fn extension_range_errors_are_located() {
    let with = |range: &str| SOLVER.replace("{shear: 1}", &format!("{{shear: {range}}}"));
    error_at(
        &with("{min: 2, max: 1}"),
        TEMPLATE,
        18,
        "2, max",
        "min (2) must be less than max (1)",
    );
    error_at(
        &with("{min: 0, max: 1, probe: 3}"),
        TEMPLATE,
        18,
        "3}",
        "probe (3) must lie in [0, 1]",
    );
    let unknown = error_at(
        &with("{min: 0, max: 1, step: 3}"),
        TEMPLATE,
        18,
        "step",
        "unknown field `step`",
    );
    assert!(unknown.to_string().contains("min"), "{unknown}");
    error_at(&with("[0, 1]"), TEMPLATE, 18, "shear", "a number, or a range");
}

/// Whether the baseline is the edge of an extension's joint space is decided once, when the study
/// loads, and it decides what the budget keeps for the solver in the loop: where the baseline's runs
/// are runs of the extended model at the ranges' lower bounds (the template's default is that bound),
/// the loop starts from them and needs only its held-out run per design. The load-time rendering is
/// checked against the run keys the executor computes for a baseline run and a joint run there.
#[test]
fn the_baseline_is_the_edge_when_it_renders_like_the_lower_bounds() {
    let sequential = SOLVER.replace(
        "{method: lhs, count: 4, seed: 1}",
        "{method: sequential, batch: 2, seed: 1}",
    );
    // Tera writes the float 0.0 as `0.0` and the integer default 0 as `0`: the default must be
    // written as the bound is rendered (docs/extensions.md). A fixed variable at a value of its own
    // moves the edge off the baseline (at the template's default it would be refused as unused).
    let with_default = |shear: &str, kappa: &str| {
        format!(
            "h = {{{{ h }}}}\nE = {{{{ E }}}}\nshear = {{{{ shear | default(value={shear}) }}}}\nkappa = {{{{ kappa | default(value={kappa}) }}}}\n"
        )
    };
    let cases = [
        ("{shear: {min: 0, max: 2}}", with_default("0.0", "1.0"), true),
        ("{shear: {min: 0, max: 2}}", with_default("0", "1.0"), false),
        ("{shear: {min: 0.5, max: 2}}", with_default("0.0", "1.0"), false),
        (
            "{shear: {min: 0, max: 2}, kappa: 0.8}",
            with_default("0.0", "1.0"),
            false,
        ),
    ];
    for (extension, template, edge) in cases {
        let (_dir, path) = write_case(&sequential.replace("{shear: 1}", extension), &template);
        let s = study::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let spec = s.diagnosis.hypotheses[0].extension_spec().unwrap();
        assert_eq!(spec.baseline_at_edge, edge, "{extension}");
        let Simulation::Solver(sim) = &s.simulation else {
            panic!()
        };
        let base = Plan::initial(&s, sim).runs[0].clone();
        let lows: Vec<f64> = spec.ranges.iter().map(|r| r.min).collect();
        let joint = lab::plan::sweep::PlannedRun {
            role: RunRole::Joint(0),
            extension: spec.at(&lows),
            ..base.clone()
        };
        let keys = sweep::prepare(
            &s,
            &lab::extract::adapters::solver(sim).unwrap(),
            &Plan {
                runs: vec![base, joint],
            },
        )
        .unwrap()
        .keys;
        assert_eq!(
            keys[0] == keys[1],
            edge,
            "{extension}: the run keys disagree with the load-time rendering"
        );
        // E × shear under a linear surrogate starts from 4 runs per design; the probes give 2 (p + 1),
        // the screening's first batch 3 more where the baseline is the edge. Then one held-out run.
        let floor = lab::plan::sweep::SequenceFloor::of(&s, sim).unwrap();
        assert_eq!((floor.initial, floor.probes), (6, 4), "{extension}");
        assert_eq!(floor.looped, if edge { 2 } else { 2 * (4 - 2 + 1) }, "{extension}");
        // And the confirmation runs: two models at the 2 designs.
        assert_eq!(floor.confirmation, 2 * 2, "{extension}");
        assert_eq!(floor.runs(), 6 + 2 + 4 + floor.looped + 4, "{extension}");
    }
}
