//! Strict study loading: every malformed study or experiments file gives an `InputError` naming the
//! file, the line (and column where meaningful) and a recognisable phrase; nothing panics.

use std::path::{Path, PathBuf};

use crate::common;

use common::{assert_located, column_of};
use lab::error::InputError;
use lab::study::{self, Method};

/// A valid study; each bad case below changes one thing. Line numbers are referred to by the tests.
const STUDY: &str = r#"name: beam
constants: {F: 600, L: 20, b: 2}
design:
  h: {unit: mm, min: 7, max: 13}
parameters:
  E: {min: 50000, max: 80000, unit: MPa}
simulation:
  expression: "4*F*L^3/(E*b*h^3)"
experiments:
  file: tests.csv
  response: deflection
training: [h8, h10]
validation: [h13]
calibration:
  methods: [least_squares, sensitivity, bayesian]
diagnosis:
  hypotheses:
    - name: shear
      term: "1/h"
"#;

const CSV: &str = "design,h,deflection
h7,7,0.448
h8,8,0.308
h10,10,0.167
h13,13,0.084
";

struct Case {
    _dir: tempfile::TempDir,
    study: PathBuf,
    csv: PathBuf,
    yaml: String,
    csv_text: String,
}

fn case(yaml: &str, csv: &str) -> Case {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("study.yaml");
    let csv_path = dir.path().join("tests.csv");
    std::fs::write(&study, yaml).unwrap();
    std::fs::write(&csv_path, csv).unwrap();
    Case {
        _dir: dir,
        study,
        csv: csv_path,
        yaml: yaml.to_string(),
        csv_text: csv.to_string(),
    }
}

/// `STUDY` with `old` replaced by `new` (which must occur).
fn study_with(old: &str, new: &str) -> String {
    assert!(STUDY.contains(old), "test bug: `{old}` not in the base study");
    STUDY.replacen(old, new, 1)
}

/// The load error of a bad case; also checks that `lab check` on it exits 2 and prints that error.
fn load_err(case: &Case) -> InputError {
    let err = match study::load(&case.study) {
        Ok(_) => panic!("expected an error for:\n{}\n---\n{}", case.yaml, case.csv_text),
        Err(e) => e,
    };
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lab"))
        .arg("check")
        .arg(&case.study)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "`lab check` exit code; stderr:\n{stderr}");
    assert!(
        stderr.contains(&err.to_string()),
        "`lab check` did not print the error:\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    err
}

/// Asserts the error is located (see `common::assert_located`) and its message starts with
/// `file:line:column`.
#[track_caller]
fn assert_error(err: &InputError, file: &Path, line: usize, column: Option<usize>, phrase: &str) {
    assert_located(err, file, line, column, phrase);
    let span = err.span.as_ref().expect("located");
    let location = format!("{}:{}:{}", file.display(), span.line, span.column);
    assert!(err.to_string().starts_with(&location), "no `{location}` in:\n{err}");
}

/// A bad study (with the good CSV): the error is in the study file.
#[track_caller]
fn study_error(yaml: &str, line: usize, column: Option<usize>, phrase: &str) -> InputError {
    let c = case(yaml, CSV);
    let err = load_err(&c);
    assert_error(&err, &c.study, line, column, phrase);
    err
}

/// A bad CSV (with the good study): the error is in the CSV file.
#[track_caller]
fn csv_error(csv: &str, line: usize, column: Option<usize>, phrase: &str) -> InputError {
    let c = case(STUDY, csv);
    let err = load_err(&c);
    assert_error(&err, &c.csv, line, column, phrase);
    err
}

// ---------------------------------------------------------------------------------------------
// Positive cases

#[test]
fn base_study_loads() {
    let c = case(STUDY, CSV);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.name, "beam");
    assert_eq!(s.experiments.file, c.csv);
    assert_eq!(s.split.training, ["h8", "h10"]);
    assert_eq!(s.split.validation, ["h13"]);
    assert_eq!(s.diagnosis.hypotheses.len(), 1);
}

#[test]
fn cantilever_loads_in_file_order() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies/cantilever.yaml");
    let s = study::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.name, "cantilever");
    assert_eq!(s.path, path);
    let constants: Vec<&str> = s.constants.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(constants, ["F", "L", "b", "nu"]);
    assert_eq!(s.constants[0].1, 600.0);
    let design: Vec<&str> = s.design.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(design, ["h"]);
    assert_eq!((s.design[0].min, s.design[0].max), (Some(7.0), Some(13.0)));
    assert_eq!(s.design[0].unit.as_deref(), Some("mm"));
    let parameters: Vec<&str> = s.parameters.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(parameters, ["E"]);
    assert_eq!((s.parameters[0].min, s.parameters[0].max), (50000.0, 80000.0));
    assert_eq!(s.experiments.designs.len(), 7);
    let names: Vec<&str> = s.experiments.designs.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["h7", "h8", "h9", "h10", "h11", "h12", "h13"]);
    assert_eq!(s.experiments.get("h8").unwrap().values, [8.0]);
    assert_eq!(s.split.training, ["h8", "h10"]);
    assert_eq!(s.split.validation, ["h13"]);
    assert_eq!(
        s.calibration.methods,
        [Method::LeastSquares, Method::Sensitivity, Method::Bayesian]
    );
    assert_eq!(s.calibration.bayesian.emulator_samples, 24);
    assert_eq!(s.calibration.bayesian.seed, 1);
    let hypotheses: Vec<&str> = s.diagnosis.hypotheses.iter().map(|h| h.name.as_str()).collect();
    assert_eq!(hypotheses, ["shear deformation", "root rotation", "offset"]);

    // The simulation evaluates with the study's symbol order.
    let study::Simulation::Expression(expr) = &s.simulation else {
        panic!("a closed-form study")
    };
    let symbols = s.symbols();
    let mut values = vec![0.0; symbols.len()];
    for (name, v) in [
        ("h", 8.0),
        ("E", 68000.0),
        ("F", 600.0),
        ("L", 20.0),
        ("b", 2.0),
        ("nu", 0.36),
    ] {
        values[symbols.index(name).unwrap()] = v;
    }
    let expected = 4.0 * 600.0 * 20f64.powi(3) / (68000.0 * 2.0 * 512.0);
    assert!((expr.eval(&values) - expected).abs() < 1e-12);
}

#[test]
fn replicates_give_mean_and_sample_std() {
    let csv = "design,h,extra,deflection
h8,8,x,0.30
h10,10,y,0.16
h8,8,z,0.31
h13,13,,0.08
h8,8.0,,0.32
h10,10,,0.17
h13,13,,0.09
h10,10,,0.18
h13,13,,0.10
";
    let c = case(STUDY, csv);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = s.experiments.designs.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["h8", "h10", "h13"], "first-appearance order");
    let h8 = s.experiments.get("h8").unwrap();
    assert_eq!(h8.replicates, [0.30, 0.31, 0.32]);
    assert!((h8.mean() - 0.31).abs() < 1e-12);
    assert!((h8.std_dev().unwrap() - 0.01).abs() < 1e-12);
    let h10 = s.experiments.get("h10").unwrap();
    assert!((h10.mean() - 0.17).abs() < 1e-12);
    assert!((h10.std_dev().unwrap() - 0.01).abs() < 1e-12);
}

#[test]
fn calibration_defaults_to_all_methods() {
    let yaml = study_with("calibration:\n  methods: [least_squares, sensitivity, bayesian]\n", "");
    let c = case(&yaml, CSV);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        s.calibration.methods,
        [Method::LeastSquares, Method::Sensitivity, Method::Bayesian]
    );
    let defaults = lab::calibrate::bayesian::Settings::default();
    assert_eq!(s.calibration.bayesian.mcmc_steps, defaults.mcmc_steps);
    assert_eq!(s.calibration.bayesian.emulator_samples, defaults.emulator_samples);
    assert!(s.split.validation.len() == 1 && s.diagnosis.hypotheses.len() == 1);
}

// ---------------------------------------------------------------------------------------------
// Bad study files

#[test]
fn yaml_syntax_error() {
    let yaml = study_with("name: beam", "name: beam: x");
    study_error(&yaml, 1, Some(11), "mapping values are not allowed");
    let yaml = study_with("max: 13}", "max: 13}}");
    study_error(&yaml, 4, Some(column_of(&yaml, 4, "}}") + 1), "misplaced bracket");
}

#[test]
fn empty_study_file() {
    let c = case("", CSV);
    let err = load_err(&c);
    assert_eq!(err.file, c.study);
    assert!(err.to_string().contains("empty"), "{err}");
}

#[test]
fn missing_study_file() {
    let c = case(STUDY, CSV);
    let missing = c.study.with_file_name("nope.yaml");
    let err = study::load(&missing).unwrap_err();
    assert_eq!(err.file, missing);
    assert!(err.to_string().contains("cannot read the study file"), "{err}");
}

#[test]
fn unknown_top_level_key() {
    let yaml = study_with("training:", "colour: red\ntraining:");
    study_error(&yaml, 12, Some(1), "unknown field `colour`");
}

#[test]
fn unknown_nested_key() {
    let yaml = study_with("unit: MPa}", "unti: MPa}");
    study_error(&yaml, 6, Some(column_of(&yaml, 6, "unti")), "unknown field `unti`");
}

#[test]
fn unknown_key_in_calibration() {
    let yaml = study_with("  methods: [", "  method: [");
    study_error(&yaml, 15, Some(3), "unknown field `method`");
}

#[test]
fn duplicate_key() {
    let yaml = study_with(
        "  h: {unit: mm, min: 7, max: 13}\n",
        "  h: {unit: mm, min: 7, max: 13}\n  h: {unit: mm}\n",
    );
    study_error(&yaml, 5, Some(3), "duplicate");
}

#[test]
fn duplicate_top_level_key() {
    let yaml = study_with("validation: [h13]\n", "validation: [h13]\ntraining: [h7]\n");
    study_error(&yaml, 14, Some(1), "duplicate");
}

#[test]
fn string_where_number() {
    let yaml = study_with("min: 50000", "min: lots");
    study_error(&yaml, 6, Some(column_of(&yaml, 6, "lots")), "expected a number");
}

#[test]
fn non_finite_bound() {
    let yaml = study_with("max: 80000", "max: .inf");
    study_error(&yaml, 6, Some(column_of(&yaml, 6, ".inf")), "finite");
}

#[test]
fn missing_required_key() {
    let yaml = study_with("  response: deflection\n", "");
    study_error(&yaml, 10, None, "missing field `response`");
}

#[test]
fn min_not_below_max() {
    let yaml = study_with("E: {min: 50000, max: 80000", "E: {min: 80000, max: 50000");
    study_error(&yaml, 6, Some(column_of(&yaml, 6, "80000")), "must be less than max");
}

#[test]
fn design_min_not_below_max() {
    let yaml = study_with("min: 7, max: 13", "min: 13, max: 13");
    study_error(&yaml, 4, Some(column_of(&yaml, 4, "13")), "must be less than max");
}

#[test]
fn bad_study_name() {
    let yaml = study_with("name: beam", "name: Beam_1");
    study_error(&yaml, 1, Some(7), "invalid study name");
}

#[test]
fn name_defined_twice_across_sections() {
    // `h` is a constant (line 2) and a design variable (line 4): the later one is reported.
    let yaml = study_with("b: 2}", "b: 2, h: 3}");
    let err = study_error(&yaml, 4, Some(3), "`h` is defined twice");
    assert!(
        err.message.contains("constant") && err.message.contains("design variable"),
        "{err}"
    );
}

#[test]
fn parameter_named_like_a_constant() {
    let yaml = study_with("  E: {min: 50000", "  F: {min: 1, max: 2}\n  E: {min: 50000");
    study_error(&yaml, 6, Some(3), "`F` is defined twice");
}

#[test]
fn y_is_reserved() {
    let yaml = study_with("b: 2}", "b: 2, y: 1}");
    study_error(&yaml, 2, Some(column_of(&yaml, 2, "y:")), "`y` is reserved");
}

#[test]
fn no_parameters() {
    let yaml =
        study_with("  E: {min: 50000, max: 80000, unit: MPa}\n", "").replace("parameters:\n", "parameters: {}\n");
    study_error(&yaml, 5, Some(1), "no calibration parameters");
}

#[test]
fn undefined_symbol_in_expression_points_at_it() {
    let yaml = study_with("E*b*h^3", "E*b*hh^3");
    let column = column_of(&yaml, 8, "hh");
    // The string node starts at the quote (column 15); + 1 for the quote; + offset 13 of `hh`.
    assert_eq!(column, 15 + 1 + 13);
    let err = study_error(&yaml, 8, Some(column), "unknown symbol `hh`");
    let shown = err.to_string();
    let caret_line = shown.lines().last().unwrap();
    let source_line = shown.lines().rev().nth(1).unwrap();
    let caret = caret_line.find('^').unwrap();
    assert_eq!(&source_line[caret..caret + 2], "hh", "caret not under `hh`:\n{shown}");
}

#[test]
fn undefined_symbol_in_plain_scalar_expression() {
    let yaml = study_with("expression: \"4*F*L^3/(E*b*h^3)\"", "expression: 4*F*L^3/(E*b*z*h^3)");
    study_error(&yaml, 8, Some(column_of(&yaml, 8, "z*")), "unknown symbol `z`");
}

#[test]
fn undefined_symbol_in_hypothesis_term() {
    let yaml = study_with("term: \"1/h\"", "term: \"1/h + q\"");
    study_error(&yaml, 19, Some(column_of(&yaml, 19, "q")), "unknown symbol `q`");
}

#[test]
fn hypothesis_term_may_use_y() {
    let yaml = study_with("term: \"1/h\"", "term: \"y/h\"");
    let c = case(&yaml, CSV);
    study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn expression_syntax_error() {
    let yaml = study_with("4*F*L^3/(E*b*h^3)", "4*F*(L^3/(E*b*h^3)");
    study_error(&yaml, 8, Some(column_of(&yaml, 8, "\"")), "does not parse");
}

#[test]
fn expression_without_parameter() {
    let yaml = study_with("4*F*L^3/(E*b*h^3)", "4*F*L^3/(b*h^3)");
    study_error(
        &yaml,
        8,
        Some(column_of(&yaml, 8, "\"")),
        "uses no calibration parameter",
    );
}

#[test]
fn solver_without_sampling() {
    let yaml = study_with(
        "  expression: \"4*F*L^3/(E*b*h^3)\"\n",
        "  solver:\n    adapter: command\n    command: [cp, a, b]\n  response: {file: out.txt, regex: \"y = (\\\\S+)\"}\n",
    );
    study_error(&yaml, 8, Some(3), "needs `simulation.sampling`");
}

#[test]
fn missing_expression() {
    let yaml = study_with("  expression: \"4*F*L^3/(E*b*h^3)\"\n", "").replace("simulation:\n", "simulation: {}\n");
    study_error(&yaml, 7, Some(1), "needs `expression`");
}

#[test]
fn unknown_method() {
    let yaml = study_with("sensitivity, bayesian]", "sensitivity, magic]");
    study_error(&yaml, 15, Some(column_of(&yaml, 15, "magic")), "unknown method `magic`");
}

#[test]
fn sensitivity_needs_two_training_designs() {
    let yaml = study_with("training: [h8, h10]", "training: [h8]");
    study_error(
        &yaml,
        15,
        Some(column_of(&yaml, 15, "sensitivity")),
        "at least 2 training designs",
    );
}

#[test]
fn default_methods_need_two_training_designs() {
    let yaml = study_with("calibration:\n  methods: [least_squares, sensitivity, bayesian]\n", "")
        .replace("training: [h8, h10]", "training: [h8]");
    study_error(&yaml, 12, Some(11), "default calibration methods include sensitivity");
    let yaml = yaml.replace(
        "validation: [h13]\n",
        "validation: [h13]\ncalibration: {methods: [least_squares]}\n",
    );
    let c = case(&yaml, CSV);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.calibration.methods, [Method::LeastSquares]);
}

#[test]
fn undefined_symbol_in_multiline_expression_points_at_the_string() {
    let yaml = study_with("\"4*F*L^3/(E*b*h^3)\"", "\"4*F*L^3/\n    (E*b*hh^3)\"");
    study_error(&yaml, 8, Some(column_of(&yaml, 8, "\"")), "unknown symbol `hh`");
}

#[test]
fn csv_with_bom_and_crlf_loads() {
    let csv = "\u{feff}design,h,deflection\r\nh8,8,0.3\r\nh10,10,0.16\r\nh13,13,0.08\r\n";
    let c = case(STUDY, csv);
    let s = study::load(&c.study).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.experiments.designs.len(), 3);
}

#[test]
fn bad_bayesian_settings() {
    let yaml = study_with(
        "bayesian]\n",
        "bayesian]\n  bayesian: {mcmc_steps: 100, mcmc_burn_in: 100}\n",
    );
    study_error(&yaml, 16, Some(column_of(&yaml, 16, "100}")), "must be less than");
    let yaml = study_with("bayesian]\n", "bayesian]\n  bayesian: {seed: -1}\n");
    study_error(&yaml, 16, Some(column_of(&yaml, 16, "-1")), "whole number");
}

#[test]
fn missing_experiments_file() {
    let yaml = study_with("file: tests.csv", "file: nope.csv");
    study_error(&yaml, 10, Some(column_of(&yaml, 10, "nope.csv")), "does not exist");
}

#[test]
fn unknown_training_design() {
    let yaml = study_with("training: [h8, h10]", "training: [h8, h99]");
    let err = study_error(
        &yaml,
        12,
        Some(column_of(&yaml, 12, "h99")),
        "not in the experiments file",
    );
    assert!(err.message.contains("h7, h8, h10, h13"), "{err}");
}

#[test]
fn unknown_validation_design() {
    let yaml = study_with("validation: [h13]", "validation: [h13, h42]");
    study_error(
        &yaml,
        13,
        Some(column_of(&yaml, 13, "h42")),
        "validation design `h42` is not in",
    );
}

#[test]
fn design_in_training_and_validation() {
    let yaml = study_with("validation: [h13]", "validation: [h13, h10]");
    study_error(
        &yaml,
        13,
        Some(column_of(&yaml, 13, "h10")),
        "both training and validation",
    );
}

#[test]
fn no_training_designs() {
    let yaml = study_with("training: [h8, h10]", "training: []");
    study_error(&yaml, 12, Some(11), "no training designs");
}

// ---------------------------------------------------------------------------------------------
// Bad experiments files

#[test]
fn csv_missing_response_column() {
    let err = csv_error("design,h,defl\nh8,8,0.3\n", 1, Some(1), "missing column `deflection`");
    assert!(
        err.message.contains("`design`, `h`, `defl`"),
        "header not listed: {err}"
    );
}

#[test]
fn csv_missing_design_variable_column() {
    csv_error("design,thickness,deflection\nh8,8,0.3\n", 1, None, "missing column `h`");
}

#[test]
fn csv_non_numeric_value() {
    let csv = "design,h,deflection\nh7,7,0.448\nh8,8,n/a\nh10,10,0.167\n";
    let err = csv_error(csv, 3, Some(6), "expected a finite number, found `n/a`");
    assert!(err.to_string().contains("h8,8,n/a"), "row not shown: {err}");
}

#[test]
fn csv_non_finite_value() {
    csv_error("design,h,deflection\nh8,inf,0.3\n", 2, Some(4), "column `h`");
}

#[test]
fn csv_replicates_disagree_on_design_values() {
    let csv = "design,h,deflection\nh8,8,0.30\nh10,10,0.16\nh8,8.5,0.31\n";
    let err = csv_error(csv, 4, Some(4), "replicate of design `h8`");
    assert!(err.message.contains("line 2"), "{err}");
}

#[test]
fn csv_empty() {
    let c = case(STUDY, "");
    let err = load_err(&c);
    assert_eq!(err.file, c.csv);
    assert!(err.message.contains("empty"), "{err}");
}

#[test]
fn csv_header_only() {
    csv_error("design,h,deflection\n", 1, Some(1), "no data rows");
}

#[test]
fn csv_row_with_wrong_field_count() {
    csv_error(
        "design,h,deflection\nh8,8,0.3\nh10,10\n",
        3,
        Some(1),
        "has 2 fields but the header has 3",
    );
}

#[test]
fn csv_duplicate_column() {
    csv_error("design,h,h,deflection\nh8,8,8,0.3\n", 1, Some(10), "appears twice");
}

// ---------------------------------------------------------------------------------------------
// Never a panic

#[test]
fn truncated_and_mangled_studies_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tests.csv"), CSV).unwrap();
    let path = dir.path().join("study.yaml");
    let mut inputs: Vec<String> = (0..=STUDY.len())
        .filter(|&i| STUDY.is_char_boundary(i))
        .map(|i| STUDY[..i].to_string())
        .collect();
    for (i, _) in STUDY.char_indices() {
        for junk in ["\"", "[", "}", ":", "\t", "-", "*x", "&a", "\u{feff}"] {
            let mut s = STUDY.to_string();
            s.insert_str(i, junk);
            inputs.push(s);
        }
    }
    for input in inputs {
        std::fs::write(&path, &input).unwrap();
        match std::panic::catch_unwind(|| study::load(&path)) {
            Ok(Ok(_)) => {}
            Ok(Err(e)) => assert!(e.file == path || e.file == dir.path().join("tests.csv"), "{e}"),
            Err(_) => panic!("panic on:\n{input}"),
        }
    }
}

#[test]
fn mangled_csvs_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("study.yaml"), STUDY).unwrap();
    let path = dir.path().join("tests.csv");
    let mut inputs: Vec<String> = (0..=CSV.len()).map(|i| CSV[..i].to_string()).collect();
    for i in 0..CSV.len() {
        for junk in ["\"", ",", "\n", "x", "\r"] {
            let mut s = CSV.to_string();
            s.insert_str(i, junk);
            inputs.push(s);
        }
    }
    for input in inputs {
        std::fs::write(&path, &input).unwrap();
        if std::panic::catch_unwind(|| study::load(&dir.path().join("study.yaml"))).is_err() {
            panic!("panic on:\n{input}");
        }
    }
}
