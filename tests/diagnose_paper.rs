//! Diagnosis on the two published cases with a known hidden effect, loaded from their study files:
//! the paper's cantilever (Euler simulation, Timoshenko tests) and Brynjarsdóttir & O'Hagan's simple
//! machine (a linear simulation of a saturating process).

use std::path::PathBuf;

use crate::verdict_common;

use lab::diagnose::verdict::Verdict;
use lab::diagnose::{self, Diagnosis, NoiseKind};
use lab::pipeline;

fn run(study: &str) -> Diagnosis {
    run_with(study, |_| {})
}

/// `run` with the study's diagnosis inputs changed by `change` first.
fn run_with(study: &str, change: impl FnOnce(&mut diagnose::Inputs)) -> Diagnosis {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("studies").join(study);
    let study = lab::study::load(&path).expect("study loads");
    let model = pipeline::model(&study).expect("a closed-form study");
    let mut inputs = diagnose::inputs_from_study(&study, model.as_ref());
    change(&mut inputs);
    let d = diagnose::diagnose(&inputs).expect("diagnosis runs");
    eprintln!("{}", serde_json::to_string_pretty(&d).unwrap());
    d
}

/// Tolerance: the 0.5 % on E. The tests are a floating-point-exact Timoshenko, so shear
/// deformation (1/h) is the exact missing term and the joint fit returns E0 to ~1e-9 relative.
#[test]
fn cantilever_cause_is_shear_deformation_and_e_is_recovered() {
    let d = run("cantilever-diagnosis.yaml");
    assert!(d.finding.discrepancy_detected);
    assert_eq!(d.finding.verdict, Verdict::CauseNamed);
    assert_eq!(d.finding.cause.as_deref(), Some("shear deformation"));
    assert_eq!(d.explained.candidates[0].shape.name, "shear deformation");
    let ext = d.explained.extended.as_ref().expect("an extended model");
    let e = ext.model.parameters["E"];
    assert!((e / 68_000.0 - 1.0).abs() < 0.005, "E = {e}");
    // The exact term leaves floating-point residuals: the validation error all but vanishes.
    assert!(
        ext.gains.validation_error_before > 0.05,
        "{}",
        ext.gains.validation_error_before
    );
    assert!(
        ext.gains.validation_error_after < 1e-6,
        "{}",
        ext.gains.validation_error_after
    );
    assert!(ext.gains.gain.unwrap() > 0.99);
    // No replicates: the noise is the measurement's uncertainty the study states (0.3 %), and the
    // output says so.
    assert_eq!(d.record.noise.kind, NoiseKind::Stated);
    assert!(
        d.record.noise.note.contains("no replicates") && d.record.noise.note.contains("states"),
        "{}",
        d.record.noise.note
    );
    // "offset" is the study's name for the built-in constant offset: it replaces it.
    let offset = d
        .explained
        .candidates
        .iter()
        .find(|c| c.shape.name == "offset")
        .expect("offset ranked");
    assert_eq!(offset.shape.replaces.as_deref(), Some("constant offset"));
    assert!(d.explained.candidates.iter().all(|c| c.shape.name != "constant offset"));
    // The scale error is proportional to ∂y/∂E (y ∝ 1/E): confounded with E, and said so.
    let scale = d
        .explained
        .candidates
        .iter()
        .find(|c| c.shape.name == "scale error")
        .expect("scale error ranked");
    assert_eq!(scale.checks.confounded_with, vec!["E".to_string()]);
    assert!(
        d.record
            .confounded
            .iter()
            .any(|s| s.contains("scale error") && s.contains("E"))
    );
    // Without it, the noise comes from the residuals of the models being judged: shear leads the
    // ranking and model error is detected (an F test of nested models needs no measured noise),
    // but no cause is decisive, and the words say why.
    let unmeasured = run_with("cantilever-diagnosis.yaml", |i| i.settings.measurement = None);
    assert_eq!(unmeasured.record.noise.kind, NoiseKind::FromResiduals);
    assert_eq!(
        unmeasured.finding.verdict,
        Verdict::TooFewTests,
        "{}",
        unmeasured.finding.headline
    );
    assert_eq!(unmeasured.finding.cause, None);
    assert!(unmeasured.finding.discrepancy_detected);
    assert_eq!(
        unmeasured.finding.leading.first().map(String::as_str),
        Some("shear deformation")
    );
    assert!(
        unmeasured.finding.headline.contains("noise is not measured"),
        "{}",
        unmeasured.finding.headline
    );
    // Its next test asks for replicates, which measure the scatter the tests lack: every design of
    // the programme has two specimens or more, the scatter's degrees of freedom are theirs, and the
    // power is the t test's on them (stats::t_power, checked against scipy's noncentral t).
    let replicates = unmeasured.explained.next_test.as_ref().expect("a next test");
    let nu = replicates
        .amount
        .scatter_dof
        .expect("replicates where the noise is not measured");
    let programme = &replicates.amount.programme;
    assert!(
        !programme.is_empty() && programme.iter().all(|r| r.specimens >= 2),
        "{programme:?}"
    );
    assert_eq!(nu, programme.iter().map(|r| r.specimens - 1).sum::<usize>());
    assert!(
        nu >= 2 && replicates.amount.power.is_some_and(|p| p >= 0.9 - 1e-9),
        "{:?}",
        replicates.amount
    );
    assert!(
        replicates.choice.advice.contains("replicates that measure the scatter"),
        "{}",
        replicates.choice.advice
    );
    // With the noise stated, no replicates are asked for as such.
    assert_eq!(d.explained.next_test.as_ref().and_then(|t| t.amount.scatter_dof), None);
    // The next test lies inside the design bounds [7, 13].
    let next = d.explained.next_test.as_ref().expect("a next test");
    let h = next.choice.design["h"];
    assert!((7.0..=13.0).contains(&h), "h = {h}");
    assert!(next.choice.between.contains(&"shear deformation".to_string()));
}

/// Tolerance: the 2 % on θ. facts.md: the quadratic term gives θ = 0.6414 by least squares
/// on the 11 noise-free points (1.3 % short of 0.65: x² is only the first term of the saturation).
/// The saturation 0.65 x / (1 + x/20) = 0.65 (x − x²/20 + x³/400 − …) has a cubic term too, and on
/// noise-free points the quadratic's residuals are that cubic, which 'cubic wear' explains: the
/// quadratic is the leading part of the cause, not a decided cause (issue 31: `cause` means decided).
#[test]
fn simple_machine_names_the_saturation_term() {
    let d = run("simple-machine.yaml");
    assert!(d.finding.discrepancy_detected);
    assert_eq!(d.finding.cause, None);
    let partial = d.finding.partial.as_ref().expect("a partial explanation");
    assert_eq!(partial.name, "saturation");
    let ext = d.extended_model().unwrap();
    let theta = ext.model.parameters["theta"];
    assert!((theta / 0.65 - 1.0).abs() < 0.02, "theta = {theta}");
    assert!((theta - 0.6414).abs() < 5e-4, "theta = {theta} (facts.md: 0.6414)");
    // Uncorrected least squares: 0.5626 (facts.md); unweighted without replicates.
    let theta0 = d.record.uncorrected.parameters["theta"];
    assert!((theta0 - 0.5626).abs() < 5e-4, "theta0 = {theta0}");
    // No validation designs: the gain is measured leave-one-design-out.
    assert_eq!(ext.gains.measured_on, "leave-one-out");
    assert!(ext.gains.gain.unwrap() > 0.5, "{ext:?}");
    // Linear in x and the scale error are both ∝ ∂y/∂θ = x: confounded with theta.
    for name in ["linear in x", "scale error"] {
        let c = d.explained.candidates.iter().find(|c| c.shape.name == name).unwrap();
        assert_eq!(c.checks.confounded_with, vec!["theta".to_string()], "{name}");
    }
}

/// The contract's keys, read back as another program would; and the value survives a round trip.
#[test]
fn output_has_the_contract_keys_and_round_trips() {
    let d = run("cantilever-diagnosis.yaml");
    let json = serde_json::to_string(&d).unwrap();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["discrepancy_detected"], true);
    assert_eq!(v["cause"], "shear deformation");
    for key in ["name", "loo_error", "bic", "aicc", "weight"] {
        assert!(!v["candidates"][0][key].is_null(), "candidates[0].{key}");
    }
    for key in [
        "cause",
        "parameters",
        "validation_error_before",
        "validation_error_after",
        "gain",
    ] {
        assert!(!v["extended"][key].is_null(), "extended.{key}");
    }
    assert!(v["next_test"]["design"]["h"].is_f64());
    assert!(v["next_test"]["why"].is_string());
    assert_eq!(v["verdict"], "cause_named");
    assert!(v["extended"]["gain_loo"].is_f64());
    let weights: f64 =
        d.explained.candidates.iter().map(|c| c.scores.weight).sum::<f64>() + d.record.uncorrected.weight.unwrap();
    assert!((weights - 1.0).abs() < 1e-12, "weights sum to {weights}");
    let back: Diagnosis = serde_json::from_str(&json).unwrap();
    assert_eq!(back, d);
}

/// The paper's two tests (h = 8, 10), one specimen each: no test of model error is possible. The
/// verdict says so instead of "no discrepancy", every candidate is still fitted with its
/// predictions at the tested designs, and a next test is given (without a noise, no specimen count).
#[test]
fn two_tests_are_too_few_to_tell_and_give_a_next_test() {
    let d = run("cantilever.yaml");
    assert!(!d.finding.discrepancy_detected);
    assert_eq!(d.finding.verdict, Verdict::TooFewTests);
    assert!(d.finding.cause.is_none() && d.explained.extended.is_none());
    assert!(
        d.record.summary.starts_with("Too few tests to tell"),
        "{}",
        d.record.summary
    );
    assert!(
        !d.record.summary.contains("No significant discrepancy"),
        "{}",
        d.record.summary
    );
    assert!(!d.explained.candidates.is_empty());
    for c in &d.explained.candidates {
        assert_eq!(
            c.checks.predictions.len(),
            3,
            "{}: a prediction at every tested design",
            c.shape.name
        );
        assert!(c.fit.p_value.is_none(), "{}: no test without a noise", c.shape.name);
    }
    let next = d.explained.next_test.as_ref().expect("a next test");
    assert!((7.0..=13.0).contains(&next.choice.design["h"]));
    assert!(
        next.amount.specimens.is_none() && next.choice.why.contains("noise is unknown"),
        "{}",
        next.choice.why
    );
    assert_eq!(d.record.residuals.len(), 3);
    verdict_common::assert_verdict_follows_evidence(&serde_json::to_value(&d).unwrap());
}

/// The verdict follows the evidence on the published cases too.
#[test]
fn published_cases_follow_the_rule() {
    for study in [
        "cantilever-diagnosis.yaml",
        "simple-machine.yaml",
        "cantilever-three-tests.yaml",
        "cantilever-table1.yaml",
    ] {
        let d = run(study);
        verdict_common::assert_verdict_follows_evidence(&serde_json::to_value(&d).unwrap());
    }
}
