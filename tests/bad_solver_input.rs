//! Strict loading of solver studies: each malformed `simulation.solver` / `response` / `sampling` /
//! `surrogate` gives an `InputError` at the offending node (or, for templates, at the template's
//! file and line); nothing panics.

use std::path::{Path, PathBuf};

use crate::common;

use common::{assert_located, column_of};
use lab::study::{self, Simulation};

/// A valid solver study; each bad case changes one thing. Line numbers are referred to below.
const STUDY: &str = r#"name: beam
constants: {F: 600, L: 20, b: 2}
design:
  h: {unit: mm}
parameters:
  E: {min: 50000, max: 80000}
simulation:
  solver:
    adapter: command
    templates: [beam.txt.tera]
    command: [python3, beam.py]
    timeout: 30
    retries: {max_attempts: 2, backoff: 0.5, on: [non_zero_exit]}
  response: {file: out.txt, regex: "y = (\\S+)"}
  sampling: {method: lhs, count: 4, seed: 1}
  surrogate: quadratic
experiments:
  file: tests.csv
  response: deflection
training: [h8, h10]
calibration: {methods: [least_squares]}
"#;

const TEMPLATE: &str = "h = {{ h }}\nE = {{ E }}\n";
const CSV: &str = "design,h,deflection\nh8,8,0.308\nh10,10,0.167\n";

struct Case {
    dir: tempfile::TempDir,
    study: PathBuf,
}

fn case(yaml: &str, template: &str) -> Case {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("study.yaml");
    std::fs::write(&study, yaml).unwrap();
    std::fs::write(dir.path().join("tests.csv"), CSV).unwrap();
    std::fs::write(dir.path().join("beam.txt.tera"), template).unwrap();
    Case { dir, study }
}

fn with(old: &str, new: &str) -> String {
    assert!(STUDY.contains(old), "test bug: `{old}` not in the base study");
    STUDY.replacen(old, new, 1)
}

#[track_caller]
fn study_error(yaml: &str, line: usize, needle: Option<&str>, phrase: &str) {
    let c = case(yaml, TEMPLATE);
    let err = study::load(&c.study)
        .err()
        .unwrap_or_else(|| panic!("expected an error for:\n{yaml}"));
    let column = needle.map(|n| column_of(yaml, line, n));
    assert_located(&err, &c.study, line, column, phrase);
}

#[test]
fn base_solver_study_loads() {
    let c = case(STUDY, TEMPLATE);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let Simulation::Solver(sim) = &s.simulation else {
        panic!("not a solver study")
    };
    assert_eq!(sim.execution.command, ["python3", "beam.py"]);
    assert_eq!(sim.inputs.templates[0].output, Path::new("beam.txt"));
    assert_eq!(sim.execution.retry.max_attempts, 2);
    assert_eq!(sim.sampling.check_runs, 5, "the paper's 5 check runs by default");
}

#[test]
fn unknown_adapter() {
    study_error(
        &with("adapter: command", "adapter: abaqus"),
        9,
        Some("abaqus"),
        "unknown adapter `abaqus`",
    );
}

#[test]
fn calculix_keys_are_checked_where_they_are() {
    // `calculix` takes its response from `response.dat`, not a file and a regex.
    let yaml = with("adapter: command", "adapter: calculix");
    study_error(&yaml, 14, Some("out.txt"), "does not go with `adapter: calculix`");
    let dat = r#"response: {dat: {block: displacements, set: NTIP, component: fy}}"#;
    let yaml =
        with(r#"response: {file: out.txt, regex: "y = (\\S+)"}"#, dat).replace("adapter: command", "adapter: calculix");
    // No .inp input: the job cannot be named.
    study_error(&yaml, 8, None, "`.inp` input");
    let yaml = yaml.replace(
        "    templates: [beam.txt.tera]\n",
        "    templates: [beam.txt.tera]\n    job: beam\n",
    );
    study_error(&yaml, 11, Some("beam"), "no template or file gives `beam.inp`");
    // `dat` with the command adapter.
    let yaml = with(r#"response: {file: out.txt, regex: "y = (\\S+)"}"#, dat);
    study_error(
        &yaml,
        14,
        Some("{block"),
        "`response.dat` goes with `adapter: calculix`",
    );
}

#[test]
fn lsdyna_response_keys_are_checked_where_written() {
    // The command adapter's {file, regex} response does not suit lsdyna.
    study_error(
        &with("adapter: command", "adapter: lsdyna"),
        14,
        Some("out.txt"),
        "reads its solver's histories itself",
    );
    let lsdyna = with("adapter: command", "adapter: lsdyna");
    let bad_window = with_in(
        &lsdyna,
        r#"response: {file: out.txt, regex: "y = (\\S+)"}"#,
        "response: {kind: crush_force, window: [60, 5], node: 9000005}",
    );
    study_error(&bad_window, 14, Some("[60"), "0 <= s0 < s1");
    let bad_kind = with_in(
        &lsdyna,
        r#"response: {file: out.txt, regex: "y = (\\S+)"}"#,
        "response: {kind: peak, window: [5, 60], node: 9000005}",
    );
    study_error(&bad_kind, 14, Some("peak"), "unknown response kind `peak`");
    let bad_axis = with_in(
        &lsdyna,
        r#"response: {file: out.txt, regex: "y = (\\S+)"}"#,
        "response: {kind: crush_force, window: [5, 60], node: 9000005, axis: w}",
    );
    study_error(&bad_axis, 14, Some("w}"), "axis `w`");
    let ok = with_in(
        &lsdyna,
        r#"response: {file: out.txt, regex: "y = (\\S+)"}"#,
        "response: {kind: crush_force, window: [5, 60], node: 9000005}",
    );
    let bad_mesh = with_in(
        &ok,
        "  surrogate: quadratic",
        "  surrogate: quadratic\n  mesh: {kind: honeycomb_tube, element_size: 2, cell: d}",
    );
    study_error(&bad_mesh, 17, Some("d}"), "design variable `d`");
}

fn with_in(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

#[test]
fn empty_command() {
    study_error(
        &with("command: [python3, beam.py]", "command: []"),
        11,
        Some("["),
        "empty `solver.command`",
    );
}

#[test]
fn missing_template_file() {
    study_error(
        &with("[beam.txt.tera]", "[nope.tera]"),
        10,
        Some("nope"),
        "template `nope.tera` does not exist",
    );
}

#[test]
fn bad_regex_and_regex_without_capture_group() {
    let yaml = with(r#"regex: "y = (\\S+)""#, r#"regex: "y = (\\S+""#);
    study_error(&yaml, 14, Some("\"y ="), "response regex");
    let yaml = with(r#"regex: "y = (\\S+)""#, r#"regex: "y = \\S+""#);
    study_error(&yaml, 14, Some("\"y ="), "no capture group");
}

#[test]
fn too_few_samples_for_the_surrogate() {
    // A quadratic in one parameter has 3 coefficients.
    let yaml = with("count: 4", "count: 2");
    study_error(&yaml, 15, Some("2,"), "too few for a quadratic surrogate");
}

#[test]
fn grid_count_must_be_a_power() {
    let yaml = with(
        "parameters:\n  E: {min: 50000, max: 80000}\n",
        "parameters:\n  E: {min: 50000, max: 80000}\n  L0: {min: 1, max: 2}\n",
    )
    .replace("method: lhs, count: 4", "method: grid, count: 8")
    .replace("surrogate: quadratic", "surrogate: linear");
    study_error(&yaml, 16, Some("8,"), "2-th power");
}

/// A sequential solver study's simulation and the fixed design its `sampling.replaces` names.
fn replaced(s: &study::Study) -> (&study::SolverSimulation, &study::solver::Sampling) {
    let Simulation::Solver(sim) = &s.simulation else {
        panic!("not a solver study")
    };
    let fixed = sim.sampling.sequential.as_ref().and_then(|q| q.replaces.as_deref());
    (sim, fixed.expect("replaces"))
}

/// `sampling.replaces` names the fixed design a sequence replaces: only a sequence takes it, and it
/// is itself a fixed design checked as one (at its own nodes).
#[test]
fn replaces_belongs_to_a_sequence_and_is_a_fixed_design() {
    study_error(
        &with(
            "count: 4, seed: 1}",
            "count: 4, seed: 1, replaces: {method: lhs, count: 4}}",
        ),
        15,
        Some("lhs"),
        "`sampling.replaces` belongs to `method: sequential`",
    );
    let sequence = |replaces: &str| {
        with(
            "{method: lhs, count: 4, seed: 1}",
            &format!("{{method: sequential, replaces: {replaces}}}"),
        )
    };
    study_error(
        &sequence("{method: sequential}"),
        15,
        Some("{method: sequential}}"),
        "names a fixed design",
    );
    study_error(
        &sequence("{method: lhs, count: 2}"),
        15,
        Some("2}"),
        "too few for a quadratic surrogate",
    );
    let c = case(&sequence("{method: lhs, count: 6, check_runs: 2}"), TEMPLATE);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let (_, fixed) = replaced(&s);
    assert_eq!((fixed.count, fixed.check_runs), (6, 2));
    assert_eq!(fixed.surrogate, None, "the study's surrogate");
    // The replaced design may name the surrogate it was fitted with: then it is checked as one of
    // those (2 samples are enough for a linear one over E, not for the study's quadratic).
    let c = case(
        &sequence("{method: lhs, count: 2, check_runs: 1, surrogate: linear}"),
        TEMPLATE,
    );
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let (sim, fixed) = replaced(&s);
    assert_eq!(fixed.surrogate, Some(lab::study::SurrogateKind::Linear));
    // Counted with its own surrogate: 2 samples + 1 check at each of the 2 designs.
    assert_eq!(lab::plan::sweep::fixed_runs(&s, sim, fixed, &[]), 6);
    study_error(
        &sequence("{method: lhs, count: 2, surrogate: spline}"),
        15,
        Some("spline}"),
        "unknown surrogate `spline`",
    );
    study_error(
        &with("count: 4, seed: 1}", "count: 4, seed: 1, surrogate: linear}"),
        15,
        Some("linear}"),
        "`surrogate` goes in `sampling.replaces`",
    );
}

/// `sampling.across_designs` belongs to a sequence and fits a Gaussian process: each mistake at
/// its node; with `surrogate: gp` the study loads and says so.
#[test]
fn across_designs_needs_a_sequence_and_a_gaussian_process() {
    study_error(
        &with("count: 4, seed: 1}", "count: 4, seed: 1, across_designs: true}"),
        15,
        Some("lhs"),
        "`sampling.across_designs` belongs to `method: sequential`",
    );
    let across = with(
        "{method: lhs, count: 4, seed: 1}",
        "{method: sequential, seed: 1, across_designs: true}",
    );
    study_error(&across, 15, Some("true}"), "needs `surrogate: gp`, not `quadratic`");
    let c = case(&across.replace("surrogate: quadratic", "surrogate: gp"), TEMPLATE);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let lab::study::Simulation::Solver(sim) = &s.simulation else {
        panic!("a solver study")
    };
    assert!(sim.across_designs());
    let c = case(
        &across
            .replace("surrogate: quadratic", "surrogate: gp")
            .replace(", across_designs: true", ""),
        TEMPLATE,
    );
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let lab::study::Simulation::Solver(sim) = &s.simulation else {
        panic!("a solver study")
    };
    assert!(!sim.across_designs());
}

#[test]
fn unknown_surrogate_and_sampling_method() {
    study_error(
        &with("surrogate: quadratic", "surrogate: cubic"),
        16,
        Some("cubic"),
        "unknown surrogate `cubic`",
    );
    study_error(
        &with("method: lhs", "method: sobol"),
        15,
        Some("sobol"),
        "unknown sampling method `sobol`",
    );
}

#[test]
fn expression_and_solver_together() {
    let yaml = with("simulation:\n", "simulation:\n  expression: \"E*h\"\n");
    study_error(&yaml, 8, Some("expression"), "exactly one");
}

#[test]
fn solver_keys_without_solver() {
    let yaml = with(
        "  solver:\n    adapter: command\n    templates: [beam.txt.tera]\n    command: [python3, beam.py]\n    timeout: 30\n    retries: {max_attempts: 2, backoff: 0.5, on: [non_zero_exit]}\n",
        "  expression: \"E*h\"\n",
    );
    study_error(&yaml, 9, Some("response"), "goes with `simulation.solver`");
}

#[test]
fn unknown_retry_class_and_zero_timeout() {
    study_error(
        &with("on: [non_zero_exit]", "on: [oops]"),
        13,
        Some("oops"),
        "unknown outcome class `oops`",
    );
    study_error(&with("timeout: 30", "timeout: 0"), 12, Some("0"), "more than zero");
}

#[test]
fn template_syntax_error_names_the_template_file_and_line() {
    let c = case(STUDY, "h = {{ h }}\n\nE = {{ E \n");
    let err = study::load(&c.study).expect_err("a template syntax error");
    assert_located(
        &err,
        &c.dir.path().join("beam.txt.tera"),
        3,
        None,
        "template syntax error",
    );
}

#[test]
fn undefined_template_variable_is_caught_by_lab_check() {
    let c = case(STUDY, "h = {{ h }}\nE = {{ Young }}\n");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lab"))
        .arg("check")
        .arg(&c.study)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let location = format!("{}:2:", c.dir.path().join("beam.txt.tera").display());
    assert!(stderr.contains(&location), "no `{location}` in:\n{stderr}");
}

#[test]
fn slurm_lost_after_loads_and_is_checked() {
    let slurm = |v: &str| {
        with(
            "    timeout: 30\n",
            &format!("    timeout: 30\n    slurm: {{runs_per_job: 3, lost_after: {v}}}\n"),
        )
    };
    let load = |yaml: &str| {
        let c = case(yaml, TEMPLATE);
        let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
        let Simulation::Solver(sim) = s.simulation else {
            panic!("not a solver study")
        };
        sim.execution.slurm
    };
    let settings = load(&slurm("45")).unwrap();
    assert_eq!(settings.lost_after, std::time::Duration::from_secs(45));
    assert_eq!(settings.runs_per_job, 3);
    // Without the key: the default grace period, two minutes.
    let settings = load(&with("    timeout: 30\n", "    timeout: 30\n    slurm: {cpus: 2}\n")).unwrap();
    assert_eq!(settings.lost_after, std::time::Duration::from_secs(120));
    study_error(&slurm("0"), 13, Some("0}"), "`slurm.lost_after` must be at least 1");
    study_error(&slurm("soon"), 13, None, "lost_after");
}

#[test]
fn calculix_dat_window_is_checked_where_written() {
    // A calculix study: the template renders `beam.inp`; the response is a windowed mean.
    let calculix = |window: &str| {
        let dat = format!("response: {{dat: {{block: total force, set: NBOT, component: fz, window: {window}}}}}");
        with(r#"response: {file: out.txt, regex: "y = (\\S+)"}"#, &dat)
            .replace("adapter: command", "adapter: calculix")
            .replace("templates: [beam.txt.tera]", "templates: [beam.inp.tera]")
            .replace("    command: [python3, beam.py]\n", "")
    };
    let load = |yaml: &str| {
        let c = case(yaml, TEMPLATE);
        std::fs::write(c.dir.path().join("beam.inp.tera"), TEMPLATE).unwrap();
        (study::load(&c.study), c)
    };
    let (ok, _c) = load(&calculix("[0.1, 0.9]"));
    let Simulation::Solver(sim) = &ok.unwrap_or_else(|e| panic!("{e}")).simulation else {
        panic!("not a solver study")
    };
    let study::solver::Response::Dat(ccx) = &sim.response else {
        panic!("not a .dat response")
    };
    assert_eq!(ccx.response.window, Some((0.1, 0.9)));
    for bad in ["[0.9, 0.1]", "[0.5]", "[-0.1, 0.5]"] {
        let yaml = calculix(bad);
        let (err, c) = load(&yaml);
        let err = err
            .err()
            .unwrap_or_else(|| panic!("expected an error for window {bad}"));
        // The response is on line 13 once `command` is gone; the error points at the window.
        assert_located(
            &err,
            &c.study,
            13,
            Some(column_of(&yaml, 13, bad)),
            "`dat.window` must be [t0, t1]",
        );
    }
}

/// A sequence's `budget` pays at least for what it runs whatever its runs show: here its first batch
/// (a quadratic surrogate over one parameter needs 3 samples, plus one: 4 at each of 2 designs) and
/// one held-out run per design, 10 in all. Fewer is an error at the budget; 10 loads.
#[test]
fn a_budget_below_what_the_sequence_must_run_is_refused() {
    let budget = |b: usize| {
        with(
            "{method: lhs, count: 4, seed: 1}",
            &format!("{{method: sequential, budget: {b}, seed: 1}}"),
        )
    };
    study_error(
        &budget(9),
        15,
        Some("budget"),
        "`sampling.budget` is 9 solver run(s), fewer than the sequence makes whatever its runs show: its first \
         batch of 8 at the 2 tested design(s), one held-out run per design (2), the confirmation runs at the \
         fitted parameters of the uncorrected simulation and of a named cause (4); a budget of at least 14",
    );
    let c = case(&budget(14), TEMPLATE);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let Simulation::Solver(sim) = &s.simulation else {
        panic!("not a solver study")
    };
    assert_eq!(lab::plan::sweep::sequential_budget(&s, sim), Some(14));
}

/// `simulation.seeds`: at least two seeds, set by a variable some template uses (else every seed
/// would run the same deck); a good one loads.
#[test]
fn seeds_need_two_and_a_variable_a_template_uses() {
    let seeds = |v: &str| {
        with(
            "  surrogate: quadratic\n",
            &format!("  surrogate: quadratic\n  seeds: {v}\n"),
        )
    };
    study_error(&seeds("{count: 1, variable: h}"), 17, Some("1,"), "at least 2");
    study_error(
        &seeds("{count: 3, variable: seed}"),
        17,
        Some("seed}"),
        "used by no template",
    );
    study_error(&seeds("{count: 3}"), 17, None, "variable");
    let c = case(
        &seeds("{count: 3, variable: seed}"),
        "h = {{ h }}\nE = {{ E }}\nseed = {{ seed }}\n",
    );
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let Simulation::Solver(sim) = s.simulation else {
        panic!("not a solver study")
    };
    let seeds = sim.inputs.seeds.expect("seeds");
    assert_eq!((seeds.count, seeds.variable.as_deref()), (3, Some("seed")));
}
