//! The main job's deck written out once as a plain deck and run through `simulation.solver.deck`
//! (issue 56): `studies/honeycomb.yaml`'s template rendered with its constants and placeholder
//! values into `model.k` — its tunable values in `*PARAMETER` cards (SIGY, ETAN, TWALL, CELL),
//! the ribbon walls' double thickness as `*PARAMETER_EXPRESSION TRIB = TWALL*2` as an engineer
//! would write it, and `*INCLUDE mesh.k` — and one mesh include per tested design (`meshes/C3T8.k`
//! …, made by the same mesher), named by `per_design`. Both studies are run live by the stand-in
//! solver (`crushsim`, built with the tests): the deck study makes the same runs and reaches the
//! same results and verdict, `results.json` equal key for key but for wall and planner times.

use crate::readers;

use std::path::{Path, PathBuf};
use std::process::Command;

use lab::base::template::{Renderer, Template};
use lab::render::mesh::{self, TubeSpec};
use lab::study::{self, Simulation};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The directory holding the `crushsim` the tests built (the workspace's target dir).
fn crushsim_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_lab")).parent().unwrap().to_path_buf()
}

/// Writes `model.k` and `meshes/<design>.k` into `dir` from the main job's template and mesher.
fn write_plain_deck(dir: &Path) {
    let study = study::load(&repo().join("studies/honeycomb.yaml")).unwrap();
    let Simulation::Solver(sim) = &study.simulation else {
        unreachable!()
    };
    let template = &sim.inputs.templates[0];
    let renderer = Renderer::new(std::slice::from_ref(template as &Template)).unwrap();
    // Placeholder values: every one of them is set again by each run.
    let design = &study.experiments.designs[0];
    let mut context = study.context("", &design.values, &[185.0]);
    context.insert("mesh_file", "mesh.k");
    let text = String::from_utf8(renderer.render(&context).unwrap().remove(0).1).unwrap();
    let trib = text.lines().find(|l| l.starts_with("R TWALL")).unwrap();
    let pair = &trib[20..40];
    assert!(pair.starts_with("R TRIB"), "{trib}");
    let plain = text
        .replacen(trib, &trib.replacen(pair, &" ".repeat(20), 1), 1)
        .replacen(
            "*CONTROL_TERMINATION",
            "*PARAMETER_EXPRESSION\nR TRIB    TWALL*2.0\n*CONTROL_TERMINATION",
            1,
        )
        .replacen("honeycomb tube crush ", "honeycomb tube crush, plain deck", 1);
    std::fs::write(dir.join("model.k"), plain).unwrap();
    let spec = sim.inputs.mesh.as_ref().unwrap();
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    for d in &study.experiments.designs {
        let tube = TubeSpec {
            cell: d.values[spec.cell_variable],
            diameter: spec.diameter,
            length: spec.length,
            element: spec.element_size,
        };
        let (text, _) = mesh::include(&tube).unwrap();
        std::fs::write(dir.join("meshes").join(format!("{}.k", d.name)), text).unwrap();
    }
}

/// The main job's study file with its deck as `deck:` and every path absolute.
fn deck_study(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("studies/honeycomb.yaml")).unwrap();
    let studies = repo().join("studies");
    let text = text
        .replace("../", &format!("{}/", repo().display()))
        .replace(
            "templates: [../templates/honeycomb/main.k.tera]",
            "deck: {file: model.k, names: {sigma_y: SIGY, t: TWALL, c: CELL}, per_design: {mesh.k: \"meshes/{design}.k\"}}",
        )
        .replace(
            &format!("templates: [{}/templates/honeycomb/main.k.tera]", repo().display()),
            "deck: {file: model.k, names: {sigma_y: SIGY, t: TWALL, c: CELL}, per_design: {mesh.k: \"meshes/{design}.k\"}}",
        )
        .replace("i=main.k", "i=model.k");
    let text: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("mesh:") && !l.trim_start().starts_with("replay:"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(text.contains("deck: {file: model.k"), "{text}");
    let _ = studies;
    let path = dir.join("honeycomb-deck.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

fn run(study: &Path, out: &Path) -> serde_json::Value {
    let path = format!("{}:/usr/bin:/bin", crushsim_dir().display());
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args([
            "run",
            study.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            "2",
        ])
        .env("PATH", path)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}: {}",
        study.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap()
}

/// `v` without the keys that carry times or the study's name and output directory.
fn strip(v: &serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .filter(|(k, _)| {
                    !(k.starts_with("wall_time") || k.ends_with("_ms") || k.ends_with("seconds") || *k == "study")
                })
                .map(|(k, x)| (k.clone(), strip(x)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(strip).collect()),
        other => other.clone(),
    }
}

#[test]
fn the_main_job_as_a_plain_deck_gives_the_same_runs_results_and_verdict() {
    let dir = tempfile::tempdir().unwrap();
    write_plain_deck(dir.path());
    let study = deck_study(dir.path());
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(["check", study.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("and 1 included file(s): each run sets CELL (c), TWALL (t), SIGY (sigma_y), ETAN (etan)"),
        "{said}"
    );
    assert!(
        said.contains("left as the deck has them: SRC, SRP, FRIC, MSTRIK, VEL, TEND, DTOUT, DTPLOT, RHO, EMOD, PR"),
        "{said}"
    );
    let template = run(&repo().join("studies/honeycomb.yaml"), &dir.path().join("template-out"));
    let deck = run(&study, &dir.path().join("deck-out"));
    assert_eq!(deck["diagnosis"]["verdict"], "cause_named");
    assert_eq!(deck["runs"]["planned"], template["runs"]["planned"]);
    assert_eq!(
        strip(&deck),
        strip(&template),
        "the deck study's results.json differs from the template study's"
    );
    // Each design's mesh is written once under the output directory, not into every run.
    let meshes = std::fs::read_dir(dir.path().join("deck-out/meshes")).unwrap().count();
    assert_eq!(meshes, 3);
    let runs = dir.path().join("deck-out/runs");
    for entry in std::fs::read_dir(&runs).unwrap() {
        let run = entry.unwrap().path();
        assert!(
            !run.join("mesh.k").exists(),
            "{}: a copy of the mesh in the run directory",
            run.display()
        );
        let deck = std::fs::read_to_string(run.join("model.k")).unwrap();
        assert!(
            deck.contains("\n../../meshes/"),
            "the run's deck names the study's copy of its design's mesh"
        );
    }
    // Editing one design's include reruns exactly that design's runs, to the same numbers.
    let designs = |out: &Path| -> std::collections::BTreeMap<String, String> {
        std::fs::read_dir(out.join("runs"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|run| {
                let deck = std::fs::read_to_string(run.join("model.k")).unwrap();
                let at = deck.find("../../meshes/").unwrap() + "../../meshes/".len();
                let design = deck[at..].split('-').next().unwrap().to_string();
                (run.file_name().unwrap().to_string_lossy().into_owned(), design)
            })
            .collect()
    };
    let out = dir.path().join("deck-out");
    let before = designs(&out);
    let mesh = dir.path().join("meshes/C6T5.k");
    let text = std::fs::read_to_string(&mesh).unwrap();
    std::fs::write(&mesh, format!("$ edited after the first run\n{text}")).unwrap();
    let again = run(&study, &out);
    assert_eq!(
        strip(&again),
        strip(&deck),
        "a comment in an include changed the results"
    );
    let after = designs(&out);
    let new: Vec<&String> = after.keys().filter(|k| !before.contains_key(*k)).collect();
    let c6t5 = before.values().filter(|d| *d == "C6T5").count();
    assert!(c6t5 > 0);
    assert_eq!(new.len(), c6t5, "{} new run(s) for {c6t5} run(s) of C6T5", new.len());
    assert!(
        new.iter().all(|k| after[*k] == "C6T5"),
        "a run of another design ran again"
    );
    eprintln!(
        "plain deck: {} runs, verdict {}, sigma_y {}",
        deck["runs"]["planned"], deck["diagnosis"]["verdict"], deck["diagnosis"]["extended"]["parameters"]["sigma_y"]
    );
}

/// OpenRadioss reads `*PARAMETER` itself: the reduced specimen's deck (`tests/openradioss/mini.yaml`)
/// written out as a plain deck with a yield stress no run uses (999), run live through `deck:`;
/// the starter's listing of each run (its material review, `YIELD STRESS`) echoes the run's own
/// yield stress, never 999. Needs OpenRadioss on PATH (skipped without it, a failure when CI=true).
#[test]
fn openradioss_reads_the_values_the_deck_was_given() {
    if !readers::openradioss() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mini = repo().join("tests/openradioss/mini.yaml");
    let study = study::load(&mini).unwrap();
    let Simulation::Solver(sim) = &study.simulation else {
        unreachable!()
    };
    let renderer = Renderer::new(&sim.inputs.templates).unwrap();
    let design = &study.experiments.designs[0];
    let mut context = study.context(&design.name, &design.values, &[999.0]);
    context.insert("mesh_file", "mesh.k");
    let text = String::from_utf8(renderer.render(&context).unwrap().remove(0).1).unwrap();
    assert!(text.contains("R SIGY         999.0"), "the placeholder is in the deck");
    std::fs::write(dir.path().join("model.k"), text).unwrap();
    let spec = sim.inputs.mesh.as_ref().unwrap();
    let tube = TubeSpec {
        cell: design.values[spec.cell_variable],
        diameter: spec.diameter,
        length: spec.length,
        element: spec.element_size,
    };
    let (mesh_text, _) = mesh::include_with_edge_set(&tube, spec.edge_set.unwrap()).unwrap();
    std::fs::create_dir_all(dir.path().join("meshes")).unwrap();
    std::fs::write(dir.path().join("meshes").join(format!("{}.k", design.name)), mesh_text).unwrap();
    let yaml = std::fs::read_to_string(&mini).unwrap().replace(
        "templates: [../../templates/honeycomb-openradioss/main.k.tera]",
        "deck: {file: model.k, names: {sigma_y: SIGY, t: TWALL}, per_design: {mesh.k: \"meshes/{design}.k\"}}",
    );
    let yaml: String = yaml
        .lines()
        .filter(|l| !l.trim_start().starts_with("mesh:"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::copy(repo().join("tests/openradioss/tests.csv"), dir.path().join("tests.csv")).unwrap();
    let path = dir.path().join("mini-deck.yaml");
    std::fs::write(&path, yaml).unwrap();
    let out = dir.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(["run", path.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        matches!(o.status.code(), Some(0) | Some(1)),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mut checked = 0;
    for entry in std::fs::read_dir(out.join("runs")).unwrap() {
        let run = entry.unwrap().path();
        let deck = std::fs::read_to_string(run.join("model.k")).unwrap();
        let line = deck.lines().find(|l| l.starts_with("R SIGY")).unwrap();
        let sigy: f64 = line[10..20].trim().parse().unwrap();
        assert!((sigy - 999.0).abs() > 1.0, "the run's deck kept the placeholder");
        let listing = std::fs::read_dir(&run)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.to_string_lossy().ends_with("_0000.out"))
            .expect("the starter's listing");
        let text = String::from_utf8_lossy(&std::fs::read(&listing).unwrap()).into_owned();
        // The starter's material review: `YIELD STRESS . . . = 150.0000000000`, per material.
        let shown: Vec<f64> = text
            .lines()
            .filter(|l| l.trim_start().starts_with("YIELD STRESS"))
            .filter_map(|l| l.rsplit('=').next()?.trim().parse().ok())
            .collect();
        assert!(
            !shown.is_empty(),
            "{}: no yield stress in the starter's listing",
            listing.display()
        );
        // This build's starter keeps reals in single precision: equal within half its unit in the
        // last place (2^-24 relative).
        for v in &shown {
            assert!(
                (v - sigy).abs() <= 6.0e-8 * sigy,
                "{}: the starter read {v}, the deck says {sigy}",
                listing.display()
            );
        }
        eprintln!("{}: SIGY = {sigy}, the starter's listing: {shown:?}", run.display());
        checked += 1;
    }
    assert!(checked >= 2, "{checked} runs");
}
