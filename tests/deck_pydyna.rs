//! Deck validity checked by an independent reader (issue 12): the honeycomb decks that `lab run`
//! gives the solver — every planned run of studies/honeycomb.yaml (baseline samples and checks)
//! and of studies/honeycomb-diagnosis.yaml (with its model-extension runs: ETAN, SRC/SRP, screening
//! and joint space) — are
//! read by PyDyna (`ansys-dyna-core`), and scripts/check_decks_pydyna.py checks that every keyword
//! parses, that the mesh include expands, and that the *PARAMETER values and the fields referencing
//! them read back equal to what lab planned for the run.
//!
//! The decks are produced as `lab run` produces them: `Plan::new` and `Plan::joint` (the
//! joint-space runs of every ranged extension hypothesis, e.g. ETAN over 0-600 MPa),
//! `sweep::prepare` (render in memory), `sweep::write_meshes` and `RunStore::prepare` (the run
//! directories, byte for byte). The expected values are computed here from the plan — each run's
//! design values, parameters, the study's constants and the extension variables the plan set for
//! the run — and the template's documented defaults, never from the deck text.
//!
//! The reader lives in a virtual environment made by scripts/pydyna-venv.sh (`.ci/run` makes it);
//! `LAB_PYDYNA_PYTHON` names another python. Without it the tests skip, or fail when CI=true.

use crate::readers;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use lab::execute::RunStore;
use lab::execute::sweep;
use lab::plan::{Plan, PlannedRun, RunRole};
use lab::render::mesh::{self, TubeSpec};
use lab::study::{self, Simulation, SolverSimulation, Study};
use serde_json::{Value, json};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// What lab planned for a run, by template variable: design values, parameters, constants, then
/// the model extension's variables the plan set for this run (screening values for an
/// `Extension(k)` run, a point of the joint space for `Joint(k)` / `JointCheck(k)`; they override
/// constants), as `render::run_context` promises.
fn planned_variables(study: &Study, run: &PlannedRun) -> BTreeMap<String, f64> {
    let mut v = BTreeMap::new();
    for (d, x) in study.design.iter().zip(&run.design_values) {
        v.insert(d.name.clone(), *x);
    }
    for (p, x) in study.parameters.iter().zip(&run.theta) {
        v.insert(p.name.clone(), *x);
    }
    for (n, x) in &study.constants {
        v.insert(n.clone(), *x);
    }
    for (n, x) in &run.extension {
        v.insert(n.clone(), *x);
    }
    v
}

/// The checker's expectations for one honeycomb run (templates/honeycomb/main.k.tera): the
/// template's defaults where the plan sets nothing (etan, src, srp 0; ribbon_factor 1;
/// term_time 0.12; dt_out 2e-4; friction 0.15).
fn expectations(vars: &BTreeMap<String, f64>) -> (Value, Value) {
    let get = |name: &str, default: Option<f64>| {
        vars.get(name)
            .copied()
            .or(default)
            .unwrap_or_else(|| panic!("the plan sets no `{name}`"))
    };
    let (sigy, etan, src, srp) = (
        get("sigma_y", None),
        get("etan", Some(0.0)),
        get("src", Some(0.0)),
        get("srp", Some(0.0)),
    );
    let t = get("t", None);
    let trib = t * get("ribbon_factor", Some(1.0));
    let parameters = json!({
        "SIGY": sigy, "ETAN": etan, "SRC": src, "SRP": srp,
        "TWALL": t, "TRIB": trib, "CELL": get("c", None),
        "FRIC": get("friction", Some(0.15)), "TEND": get("term_time", Some(0.12)),
        "DTOUT": get("dt_out", Some(0.0002)),
    });
    let mut fields = Vec::new();
    for (field, reference, value) in [
        ("sigy", "&SIGY", sigy),
        ("etan", "&ETAN", etan),
        ("src", "&SRC", src),
        ("srp", "&SRP", srp),
    ] {
        fields.push(json!({"keyword": "MatPlasticKinematic", "id_field": "mid", "id": 1,
                           "field": field, "ref": reference, "expected": value}));
    }
    for (secid, reference, value) in [(1, "&TWALL", t), (2, "&TRIB", trib)] {
        for field in ["t1", "t2", "t3", "t4"] {
            fields.push(json!({"keyword": "SectionShell", "id_field": "secid", "id": secid,
                               "field": field, "ref": reference, "expected": value}));
        }
    }
    (parameters, Value::Array(fields))
}

/// One study's decks written under `out` as `lab run` writes them, with the checker's
/// expectations; also the number of runs per role.
struct Rendered {
    decks: Vec<Value>,
    roles: BTreeMap<String, usize>,
}

fn render_study(file: &str, out: &Path) -> Rendered {
    let mut study = study::load(&repo().join(file)).unwrap_or_else(|e| panic!("{e}"));
    let Simulation::Solver(sim) = &mut study.simulation else {
        panic!("{file}: a solver study")
    };
    // A sequential study's runs depend on the results; its decks are rendered the same way as a
    // fixed design's, so the fixed design of its initial size (with probes of every extension and
    // check runs) stands for them here.
    if sim.sampling.sequential.take().is_some() {
        sim.sampling.method = study::SamplingMethod::Lhs;
        sim.sampling.check_runs = 1;
    }
    let study = study;
    let Simulation::Solver(sim) = &study.simulation else {
        unreachable!()
    };
    let mut sim = sim.clone();
    if sim.sampling.count == 0 {
        sim.sampling.count = lab::plan::sweep::initial_samples(&study, &sim, study.parameters.len());
    }
    let sim = &sim;
    let sim: &SolverSimulation = sim;
    let store = RunStore::open(out).unwrap();
    let spec = sim
        .inputs
        .mesh
        .as_ref()
        .expect("the honeycomb studies generate their mesh");
    let deck_name = &sim.inputs.templates[0].output;
    let mut counts: BTreeMap<String, (usize, usize, usize)> = BTreeMap::new();
    let mut by_key: BTreeMap<String, Value> = BTreeMap::new();
    let mut roles = BTreeMap::new();
    // The study's plan, then the joint-space plan (solver in the loop) of every extension
    // hypothesis with ranged variables: `lab run` plans the latter only for the hypothesis its
    // screening chooses, so planning all of them covers whichever it chooses.
    let every_hypothesis: Vec<usize> = (0..study.diagnosis.hypotheses.len()).collect();
    for plan in [Plan::new(&study, sim), Plan::joint(&study, sim, &every_hypothesis)] {
        let prepared = sweep::prepare(&study, &lab::extract::adapters::solver(sim).unwrap(), &plan)
            .unwrap_or_else(|e| panic!("{e}"));
        sweep::write_meshes(out, &prepared).unwrap();
        for (i, run) in plan.runs.iter().enumerate() {
            let role = match run.role {
                RunRole::Extension(k) | RunRole::Joint(k) | RunRole::JointCheck(k) => {
                    format!("{} `{}`", run.role.key(), study.diagnosis.hypotheses[k].name)
                }
                other => other.key().to_string(),
            };
            *roles.entry(role.clone()).or_insert(0) += 1;
            let key = prepared.keys[i].as_str();
            let vars = planned_variables(&study, run);
            let (parameters, fields) = expectations(&vars);
            let mesh_rel = prepared.run_mesh[i].as_ref().expect("a mesh per run");
            let cell = run.design_values[spec.cell_variable];
            let (nodes, single, ribbon) = *counts.entry(run.design.clone()).or_insert_with(|| {
                let tube = TubeSpec {
                    cell,
                    diameter: spec.diameter,
                    length: spec.length,
                    element: spec.element_size,
                };
                let s = mesh::include(&tube).unwrap().1;
                (s.nodes, s.elements_single, s.elements_ribbon)
            });
            let deck = json!({
                "name": format!("{file} {} {role} {} ({key})", run.design, study.parameter_values(&run.theta)
                    .iter().map(|(n, v)| (n.as_str(), *v)).chain(run.extension.iter().map(|(n, v)| (n.as_str(), *v)))
                    .map(|(n, v)| format!("{n}={v}")).collect::<Vec<_>>().join(" ")),
                "deck": store.run_dir(key).join(deck_name),
                "title": format!("honeycomb tube crush {}", run.design),
                "parameters": parameters,
                "fields": fields,
                "include": {"file": format!("../../{}", mesh_rel.display()), "nodes": nodes,
                            "elements": {"1": single, "2": ribbon}},
            });
            match by_key.get(key) {
                None => {
                    store.prepare(key, &prepared.inputs[key]).unwrap();
                    by_key.insert(key.to_string(), deck);
                }
                // Planned runs with equal inputs share a key: they must expect the same deck.
                Some(first) => assert_eq!(
                    (&first["parameters"], &first["fields"]),
                    (&deck["parameters"], &deck["fields"]),
                    "runs sharing key {key} plan different values"
                ),
            }
        }
    }
    Rendered {
        decks: by_key.into_values().collect(),
        roles,
    }
}

/// Runs the checker on `decks`; returns (exit code, stdout, the report).
fn check(python: &Path, dir: &Path, decks: &[Value]) -> (Option<i32>, String, Value) {
    let manifest = dir.join("manifest.json");
    let report = dir.join("report.json");
    std::fs::write(&manifest, serde_json::to_vec_pretty(&json!({"decks": decks})).unwrap()).unwrap();
    let out = Command::new(python)
        .arg(repo().join("scripts/check_decks_pydyna.py"))
        .arg(&manifest)
        .arg(&report)
        .output()
        .expect("python runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let report: Value = std::fs::read(&report)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_else(|| panic!("no report from the checker:\n{stdout}\n{stderr}"));
    (out.status.code(), stdout, report)
}

#[test]
fn pydyna_reads_every_planned_honeycomb_deck_as_lab_planned_it() {
    let Some(python) = readers::pydyna_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut decks = Vec::new();
    for (file, sub) in [
        ("studies/honeycomb.yaml", "honeycomb"),
        ("studies/honeycomb-diagnosis.yaml", "diagnosis"),
    ] {
        let r = render_study(file, &dir.path().join(sub));
        eprintln!(
            "{file}: {} distinct decks; planned runs by role {:?}",
            r.decks.len(),
            r.roles
        );
        if sub == "diagnosis" {
            // The extended decks are what this test is about as much as the baseline ones.
            for role in ["extension", "joint", "joint_check"] {
                for h in ["strain hardening", "strain rate"] {
                    let role = format!("{role} `{h}`");
                    assert!(r.roles.contains_key(&role), "no {role} runs: {:?}", r.roles);
                }
            }
            // ETAN and SRC vary over the joint space: many values, the baseline's 0 among them.
            for name in ["ETAN", "SRC"] {
                let mut values: Vec<f64> = r.decks.iter().filter_map(|d| d["parameters"][name].as_f64()).collect();
                values.sort_by(f64::total_cmp);
                values.dedup();
                assert!(values.len() > 5 && values[0] == 0.0, "{name}: {values:?}");
            }
        }
        decks.extend(r.decks);
    }
    let started = Instant::now();
    let (code, stdout, report) = check(&python, dir.path(), &decks);
    let failed: Vec<&Value> = report["decks"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| !d["problems"].as_array().unwrap().is_empty())
        .collect();
    assert!(code == Some(0) && failed.is_empty(), "checker exit {code:?}:\n{stdout}");
    assert_eq!(report["decks"].as_array().unwrap().len(), decks.len());
    eprintln!(
        "ansys-dyna-core {}: {} decks checked in {:.1} s (import {:.1} s, {} include expansions)",
        report["version"].as_str().unwrap_or("?"),
        decks.len(),
        started.elapsed().as_secs_f64(),
        report["import_seconds"].as_f64().unwrap_or(f64::NAN),
        report["includes_expanded"]
    );
}

/// The checker is not a rubber stamp: deliberately corrupted copies of one extended deck (a
/// strain-hardening run, ETAN > 0), each written beside the real one so its include path
/// still resolves, are rejected with the right finding; the untouched deck passes.
#[test]
fn corrupted_decks_are_rejected() {
    let Some(python) = readers::pydyna_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let r = render_study("studies/honeycomb-diagnosis.yaml", &out);
    let good = r
        .decks
        .iter()
        .find(|d| d["parameters"]["ETAN"].as_f64() > Some(0.0) && d["parameters"]["CELL"].as_f64() == Some(6.0))
        .expect("a strain-hardening deck (ETAN > 0) of a 6 mm cell design")
        .clone();
    let text = std::fs::read_to_string(good["deck"].as_str().unwrap()).unwrap();
    let include = good["include"]["file"].as_str().unwrap().to_string();
    let run_dir = Path::new(good["deck"].as_str().unwrap())
        .parent()
        .unwrap()
        .to_path_buf();

    // A mesh with its first 50 nodes dropped (their shells then reference missing nodes).
    let mesh_text = std::fs::read_to_string(run_dir.join(&include)).unwrap();
    let node_at = mesh_text.find("*NODE\n").unwrap();
    let mut lines: Vec<&str> = mesh_text[node_at..].lines().collect();
    let first_data = lines
        .iter()
        .position(|l| !l.starts_with('*') && !l.starts_with('$'))
        .unwrap();
    lines.drain(first_data..first_data + 50);
    let truncated = format!("{}{}\n", &mesh_text[..node_at], lines.join("\n"));
    std::fs::write(out.join("meshes/truncated.k"), truncated).unwrap();

    let replace = |from: &str, to: &str| {
        assert_eq!(text.matches(from).count(), 1, "`{from}` once in the deck");
        text.replace(from, to)
    };
    let mat_line = text.lines().find(|l| l.contains("&SIGY     &ETAN")).unwrap();
    // The *PARAMETER card's ETAN: its 10-character value field, set to a value never planned.
    let etan_at = text.find("R ETAN    ").unwrap() + 10;
    let wrong_parameter = format!("{}    1234.5{}", &text[..etan_at], &text[etan_at + 10..]);
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        ("untouched", text.clone(), vec![]),
        (
            "ETAN field a literal 1234.5",
            replace(mat_line, &mat_line.replace("     &ETAN", "    1234.5")),
            vec![
                "MatPlasticKinematic mid=1 etan reads 1234.5",
                "reference(s) &ETAN planned",
            ],
        ),
        (
            "*PARAMETER ETAN 1234.5",
            wrong_parameter,
            vec!["*PARAMETER ETAN reads '1234.5'", "etan reads 1234.5"],
        ),
        (
            "include names a missing file",
            replace(&format!("{include}\n"), "../../meshes/missing.k\n"),
            vec!["no such file"],
        ),
        (
            "include truncated",
            replace(&format!("{include}\n"), "../../meshes/truncated.k\n"),
            vec!["nodes read, planned", "shell node(s) not defined"],
        ),
        (
            "undefined reference &ETAM",
            replace(mat_line, &mat_line.replace("&ETAN", "&ETAM")),
            vec!["undefined parameter reference(s): &ETAM", "etan reads nan"],
        ),
        (
            "unreadable field",
            replace(mat_line, &mat_line.replace("     &ETAN", "       abc")),
            vec!["*MAT_PLASTIC_KINEMATIC", "not parsed"],
        ),
    ];
    let mut decks = Vec::new();
    for (i, (name, deck_text, _)) in cases.iter().enumerate() {
        let d = out.join("runs").join(format!("corrupt-{i}"));
        std::fs::create_dir_all(&d).unwrap();
        let path = d.join("main.k");
        std::fs::write(&path, deck_text).unwrap();
        let mut spec = good.clone();
        spec["name"] = json!(name);
        spec["deck"] = json!(path);
        decks.push(spec);
    }
    let (code, stdout, report) = check(&python, dir.path(), &decks);
    assert_eq!(code, Some(1), "the checker must fail:\n{stdout}");
    for ((name, _, wanted), got) in cases.iter().zip(report["decks"].as_array().unwrap()) {
        let problems: Vec<&str> = got["problems"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p.as_str().unwrap())
            .collect();
        if wanted.is_empty() {
            assert!(problems.is_empty(), "{name}: {problems:?}\n{stdout}");
        }
        for w in wanted {
            assert!(
                problems.iter().any(|p| p.contains(w)),
                "{name}: no problem mentions `{w}`: {problems:?}\n{stdout}"
            );
        }
    }
}
