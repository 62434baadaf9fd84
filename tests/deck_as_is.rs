//! A deck used as it is (`simulation.solver.deck`, issue 56), on the real LS-DYNA input
//! `sph_test.k` of the three versions in `fixtures/lsdyna-real/`:
//! - as it is, a study naming a parameter of it is refused by `lab check` (exit 2, the deck has no
//!   `*PARAMETER` card);
//! - with a `*PARAMETER` card added to a copy (and the yield stress of its first material made a
//!   reference to it), every planned run's deck carries the run's values: read back by PyDyna
//!   (`ansys-dyna-core`, an independent keyword reader) from the decks `lab` renders, and
//!   everything but the values byte for byte the copy;
//! - bad input: a missing include, a study variable the deck does not define, a value too wide
//!   for its field, a parameter defined twice (in an include): exit 2 with the file and line, and
//!   nothing written.

use crate::readers;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lab::execute::sweep;
use lab::plan::Plan;
use lab::study::{self, Simulation};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

const VERSIONS: [&str; 3] = ["R7_1_2", "R9_3_1", "R12_2_1"];

fn sph(version: &str) -> String {
    std::fs::read_to_string(repo().join("fixtures/lsdyna-real").join(version).join("sph_test.k")).unwrap()
}

/// A study of the deck `model.k` in `dir`: design variable `v` (the deck's VEL), parameter `sigy`.
fn study(dir: &Path, extra: &str) -> PathBuf {
    std::fs::write(dir.join("tests.csv"), "design,v,force\nd1,1000,1.0\nd2,2000,2.0\n").unwrap();
    let text = format!(
        "name: sph-deck\n\
         design:\n  v: {{unit: mm/s}}\n\
         parameters:\n  sigy: {{min: 100, max: 300, unit: MPa}}\n\
         simulation:\n  solver:\n    adapter: lsdyna\n    deck: {{file: model.k, names: {{v: VEL}}}}\n    timeout: 60\n\
         \x20 response: {{kind: crush_force, window: [0, 1], interface: 1, side: master, axis: z, node: 1, force_to_kn: 0.001}}\n\
         \x20 sampling: {{method: lhs, count: 4, seed: 1}}\n\
         \x20 surrogate: linear\n\
         experiments:\n  file: tests.csv\n  response: force\n\
         training: [d1, d2]\n{extra}"
    );
    let path = dir.join("study.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

fn lab(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// The copy with its parameters: a `*PARAMETER` card after `*KEYWORD`, the first material's yield
/// stress (`*MAT_PLASTIC_KINEMATIC`, card 1, field 5: MID, RO, E, PR, SIGY) as `&SIGY`.
fn with_parameters(deck: &str) -> String {
    let deck = deck.replacen(
        "*KEYWORD\n",
        "*KEYWORD\n*PARAMETER\nR SIGY         200.0R VEL         1000.0\n",
        1,
    );
    let at = deck.find("*MAT_PLASTIC_KINEMATIC").unwrap();
    let card = deck[at..].lines().skip(1).find(|l| !l.starts_with('$')).unwrap();
    let edited = format!("{}     &SIGY{}", &card[..40], &card[50..]);
    deck.replacen(card, &edited, 1)
}

#[test]
fn the_real_deck_without_a_parameter_card_is_refused() {
    for version in VERSIONS {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("model.k"), sph(version)).unwrap();
        let path = study(dir.path(), "");
        let o = lab(&["check", path.to_str().unwrap()], dir.path());
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{version}: {stderr}");
        assert!(
            stderr.contains("study.yaml:") && stderr.contains("has no `*PARAMETER`") && stderr.contains("model.k"),
            "{version}: {stderr}"
        );
    }
}

/// Each deck's `*PARAMETER` values and the first `*MAT_PLASTIC_KINEMATIC`'s yield stress as PyDyna
/// reads them: `[{"SIGY": .., "VEL": .., "mat_sigy": ..}, ...]`.
const READ: &str = r#"
import json, sys, warnings
from ansys.dyna.core import Deck
out = []
for path in sys.argv[1:]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = Deck()
        d.loads(open(path).read())
    values = {n: float(d.parameters.get(n)) for n in ("SIGY", "VEL")}
    mats = [k for k in d.keywords if type(k).__name__ == "MatPlasticKinematic"]
    values["mat_sigy"] = float(mats[0].sigy)
    out.append(values)
print(json.dumps(out))
"#;

#[test]
fn each_run_deck_carries_its_values_read_back_by_pydyna() {
    for version in VERSIONS {
        let dir = tempfile::tempdir().unwrap();
        let copy = with_parameters(&sph(version));
        std::fs::write(dir.path().join("model.k"), &copy).unwrap();
        let path = study(dir.path(), "");
        let o = lab(&["check", path.to_str().unwrap()], dir.path());
        assert_eq!(
            o.status.code(),
            Some(0),
            "{version}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let study = study::load(&path).unwrap();
        let Simulation::Solver(sim) = &study.simulation else {
            unreachable!()
        };
        let plan = Plan::new(&study, sim);
        let prepared = sweep::prepare(&study, &lab::extract::adapters::solver(sim).unwrap(), &plan).unwrap();
        let mut decks = Vec::new();
        for (i, (run, key)) in plan.runs.iter().zip(&prepared.keys).enumerate() {
            let inputs = &prepared.inputs[key];
            let (name, bytes) = inputs
                .iter()
                .find(|(n, _)| n == Path::new("model.k"))
                .expect("the deck is an input");
            let text = String::from_utf8(bytes.clone()).unwrap();
            // Only the two values' fields differ from the copy.
            let changed: Vec<(usize, &str)> = text
                .lines()
                .zip(copy.lines())
                .enumerate()
                .filter(|(_, (a, b))| a != b)
                .map(|(k, (a, _))| (k, a))
                .collect();
            assert!(
                changed.len() <= 1 && changed.iter().all(|(k, _)| *k == 2),
                "{version}: {changed:?}"
            );
            assert_eq!(text.lines().count(), copy.lines().count());
            let file = dir.path().join(format!("run-{i}.k"));
            std::fs::write(&file, &text).unwrap();
            decks.push((file, run.theta[0], run.design_values[0]));
            let _ = name;
        }
        let Some(python) = readers::pydyna_python() else { return };
        let o = Command::new(&python)
            .arg("-c")
            .arg(READ)
            .args(decks.iter().map(|d| &d.0))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let read: Vec<serde_json::Value> = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(read.len(), plan.runs.len());
        for ((_, sigy, v), got) in decks.iter().zip(&read) {
            let close = |a: f64, b: f64| (a - b).abs() <= 5e-8 * b.abs();
            assert!(
                close(got["SIGY"].as_f64().unwrap(), *sigy),
                "{version}: {got} vs sigy {sigy}"
            );
            assert!(close(got["VEL"].as_f64().unwrap(), *v), "{version}: {got} vs v {v}");
            assert!(
                close(got["mat_sigy"].as_f64().unwrap(), *sigy),
                "{version}: the material reads {got}"
            );
        }
        eprintln!("{version}: {} run decks read back by PyDyna", read.len());
    }
}

/// `lab check` on `deck` (with `include` written as `part.k` and `tests` as the tests' CSV when
/// given): exit 2, the message and the place; nothing written beside the study.
fn refused(deck: &str, include: Option<&str>, tests: Option<&str>) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("model.k"), deck).unwrap();
    if let Some(text) = include {
        std::fs::write(dir.path().join("part.k"), text).unwrap();
    }
    let path = study(dir.path(), "");
    if let Some(csv) = tests {
        std::fs::write(dir.path().join("tests.csv"), csv).unwrap();
    }
    let before: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    let o = lab(&["check", path.to_str().unwrap()], dir.path());
    let after: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(before.len(), after.len(), "lab check wrote something");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn bad_decks_are_refused_at_their_file_and_line() {
    let good = "*KEYWORD\n*PARAMETER\nR SIGY         200.0R VEL         1000.0\n*INCLUDE\npart.k\n*END\n";
    let missing = refused(good, None, None);
    assert!(
        missing.contains("model.k:5:") && missing.contains("*INCLUDE `part.k`: no such file"),
        "{missing}"
    );
    let twice = refused(good, Some("*KEYWORD\n*PARAMETER\nR SIGY         100.0\n*END\n"), None);
    assert!(
        twice.contains("part.k:3:") && twice.contains("parameter SIGY is defined twice (first at"),
        "{twice}"
    );
    let absent = refused(
        "*KEYWORD\n*PARAMETER\nR SIGMA        200.0R VEL         1000.0\n*END\n",
        None,
        None,
    );
    assert!(
        absent.contains("study.yaml:") && absent.contains("`sigy` has no `*PARAMETER` SIGY"),
        "{absent}"
    );
    // An integer field cannot take a sampled yield stress: found when lab check renders the runs.
    let integer = refused(
        "*KEYWORD\n*PARAMETER\nI SIGY           200R VEL         1000.0\n*END\n",
        None,
        None,
    );
    assert!(
        integer.contains("model.k:3:") && integer.contains("parameter SIGY is an integer"),
        "{integer}"
    );
    let outside = refused(
        "*KEYWORD\n*PARAMETER\nR SIGY         200.0R VEL         1000.0\n*INCLUDE\n../part.k\n*END\n",
        None,
        None,
    );
    assert!(
        outside.contains("model.k:5:") && outside.contains("outside the deck's directory"),
        "{outside}"
    );
    // A design value with more digits than its 10 columns hold: never truncated.
    let wide = refused(
        good.replace("*INCLUDE\npart.k\n", "").as_str(),
        None,
        Some("design,v,force\nd1,1000.123456789,1.0\nd2,2000,2.0\n"),
    );
    assert!(
        wide.contains("model.k:3:") && wide.contains("parameter VEL") && wide.contains("10-character field"),
        "{wide}"
    );
}

/// An include no run changes is written once per study (under the output directory's `meshes/`,
/// named by its content) and named on the including line; an include holding a value the runs set
/// goes into every run with the value set.
#[test]
fn an_include_no_run_changes_is_shared_one_that_sets_a_value_is_per_run() {
    let dir = tempfile::tempdir().unwrap();
    let main = "*KEYWORD\n*PARAMETER\nR VEL         1000.0\n*INCLUDE\nmesh.k\nsub/material.k\n*END\n";
    std::fs::write(dir.path().join("model.k"), main).unwrap();
    std::fs::write(
        dir.path().join("mesh.k"),
        "*KEYWORD\n*NODE\n       1             0.0             0.0             0.0\n*END\n",
    )
    .unwrap();
    std::fs::create_dir_all(dir.path().join("sub")).unwrap();
    std::fs::write(
        dir.path().join("sub/material.k"),
        "*KEYWORD\n*PARAMETER\nR SIGY         200.0\n*END\n",
    )
    .unwrap();
    let path = study(dir.path(), "");
    let study = study::load(&path).unwrap();
    let Simulation::Solver(sim) = &study.simulation else {
        unreachable!()
    };
    let plan = Plan::new(&study, sim);
    let prepared = sweep::prepare(&study, &lab::extract::adapters::solver(sim).unwrap(), &plan).unwrap();
    let shared: Vec<&PathBuf> = prepared.meshes.keys().collect();
    assert_eq!(shared.len(), 1, "{shared:?}");
    let name = shared[0].to_string_lossy().into_owned();
    assert!(name.starts_with("meshes/") && name.ends_with("-mesh.k"), "{name}");
    for (run, key) in plan.runs.iter().zip(&prepared.keys) {
        let inputs = &prepared.inputs[key];
        let names: Vec<String> = inputs.iter().map(|(n, _)| n.display().to_string()).collect();
        assert_eq!(
            names,
            ["model.k", "sub/material.k"],
            "the shared mesh is not copied into the run"
        );
        let deck = String::from_utf8(inputs[0].1.clone()).unwrap();
        assert!(
            deck.contains(&format!("*INCLUDE\n../../{name}\nsub/material.k\n")),
            "{deck}"
        );
        let material = String::from_utf8(inputs[1].1.clone()).unwrap();
        let sigy: f64 = material.lines().find(|l| l.starts_with("R SIGY")).unwrap()[10..20]
            .trim()
            .parse()
            .unwrap();
        assert_eq!(sigy, run.theta[0], "the include's value is the run's");
    }
}

/// LS-OPT's marks: a deck with `<<sigy:10>>` in a fixed field and `<<vel>>` (the study names `v` VEL) in a
/// free-format card is run with each mark replaced by the run's value, in its width.
#[test]
fn ls_opt_marks_take_the_runs_values() {
    let dir = tempfile::tempdir().unwrap();
    let deck = "*KEYWORD\n*MAT_PLASTIC_KINEMATIC\n         1   2.7e-09   70000.0      0.33<<sigy:10>>\n*INITIAL_VELOCITY\n1,0.0,0.0,<<vel>>\n*END\n";
    std::fs::write(dir.path().join("model.k"), deck).unwrap();
    let path = study(dir.path(), "");
    let o = lab(&["check", path.to_str().unwrap()], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let study = study::load(&path).unwrap();
    let Simulation::Solver(sim) = &study.simulation else {
        unreachable!()
    };
    let plan = Plan::new(&study, sim);
    let prepared = sweep::prepare(&study, &lab::extract::adapters::solver(sim).unwrap(), &plan).unwrap();
    for (run, key) in plan.runs.iter().zip(&prepared.keys) {
        let text = String::from_utf8(prepared.inputs[key][0].1.clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let field = &lines[2][40..];
        assert_eq!(field.len(), 10, "{text}");
        assert_eq!(field.trim().parse::<f64>().unwrap(), run.theta[0], "{text}");
        let v: f64 = lines[4].rsplit(',').next().unwrap().parse().unwrap();
        assert_eq!(v, run.design_values[0], "{text}");
    }
}
