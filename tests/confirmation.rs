//! Issue 53: "no model error" must mean the solver fits the tests. Through `lab run` with a real
//! solver process, the stand-in `clamped_beam` (examples/clamped_beam.rs, a closed form run as a
//! program): a cantilever whose clamp may be compliant (kr), tested at depths h = 7..13 with a few
//! specimens each. The study lists clamp compliance and shear correction (extensions) and a
//! fixture offset (a term), and samples a small fixed design with a crude surrogate, as an
//! engineer with an expensive solver would.
//!
//! The oracle shares no code with lab: it fits the baseline (bending alone, y = a(h)/E) to the
//! drawn tests by weighted least squares in u = 1/E, the weights from the specimens' own scatter,
//! and calls the baseline *exactly wrong* when that χ² exceeds its α/10 critical value (of F with the
//! specimens' degrees of freedom: the scatter is estimated, not known). Nothing
//! outside this file knows the draws.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde_json::Value;

use crate::family_runs;
use crate::verdict_common;

use crate::beam_common;
use beam_common::{bending, clamp};

/// One case: the truth, the tests, and how the study samples its solver.
#[derive(Debug, Clone)]
struct Case {
    e: f64,
    kr: f64,
    hs: Vec<f64>,
    specimens: usize,
    cv: f64,
    seed: u64,
    sampling: String,
    surrogate: &'static str,
}

impl Case {
    fn truth(&self, h: f64) -> f64 {
        (bending(h) + self.kr * clamp(h)) / self.e
    }

    fn names(&self) -> Vec<String> {
        self.hs.iter().map(|h| format!("h{h}")).collect()
    }

    /// The specimens drawn at each design.
    fn tests(&self) -> Vec<Vec<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let z = Normal::new(0.0, 1.0).unwrap();
        self.hs
            .iter()
            .map(|&h| {
                (0..self.specimens)
                    .map(|_| self.truth(h) * (1.0 + self.cv * z.sample(&mut rng)))
                    .collect()
            })
            .collect()
    }
}

/// The issue's beam: E = 68,000, kr = 0.3, 0.3 % scatter at h = 7..13.
fn issue_beam(sampling: &str) -> Case {
    Case {
        e: 68_000.0,
        kr: 0.3,
        hs: (7..=13).map(f64::from).collect(),
        specimens: 3,
        cv: 0.003,
        seed: 53,
        sampling: sampling.into(),
        surrogate: "quadratic",
    }
}

/// Writes the study, its template and its tests into `dir`; returns the study file.
fn write_study(case: &Case, dir: &Path) -> PathBuf {
    let mut csv = String::from("design,h,deflection\n");
    for ((h, name), specimens) in case.hs.iter().zip(case.names()).zip(case.tests()) {
        for y in specimens {
            csv.push_str(&format!("{name},{h},{y:e}\n"));
        }
    }
    std::fs::write(dir.join("tests.csv"), csv).unwrap();
    beam_common::write_template(dir);
    let names = case.names();
    let study = format!(
        "{}\
         \x20 sampling: {}\n\
         \x20 surrogate: {}\n\
         experiments: {{file: tests.csv, response: deflection, unit: mm}}\n\
         training: [{}]\n\
         validation: [{}]\n\
         calibration: {{methods: [least_squares]}}\n\
         diagnosis:\n  hypotheses:\n\
         \x20   - name: clamp compliance\n      extension: {{kr: {{min: 0, max: 1}}}}\n\
         \x20   - name: shear correction\n      extension: {{s: {{min: 0, max: 1.5}}}}\n\
         \x20   - name: fixture offset\n      term: \"1\"\n",
        beam_common::study_head("confirm-case", (7.0, 13.0)),
        case.sampling,
        case.surrogate,
        names[..names.len() - 1].join(", "),
        names.last().unwrap(),
    );
    let path = dir.join("beam.yaml");
    std::fs::write(&path, study).unwrap();
    path
}

/// `lab run` on the case: its results.
fn run(case: &Case) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let study = write_study(case, dir.path());
    let out = dir.path().join("out");
    let (stderr, results) = beam_common::lab_run(&study, &out);
    if std::env::var("LAB_CONFIRM_VERBOSE").is_ok() {
        eprintln!("{stderr}");
    }
    family_runs::tally(&results, results["runs"]["planned"].as_u64().unwrap_or(0));
    let mut results = results;
    // The solver's runs made, one directory each (the store's key): what `runs.planned` must count.
    let made = std::fs::read_dir(out.join("runs")).map_or(0, |d| d.count());
    results["made_by_the_test"] = made.into();
    results["status_by_the_test"] = beam_common::lab_status_planned(&study, &out).into();
    results
}

/// The specimens' means and their weights (from the scatter pooled over the designs, relative:
/// the specimens scatter in proportion to the level), with the scatter's degrees of freedom ν.
fn pooled(case: &Case) -> (Vec<f64>, Vec<f64>, usize) {
    let tests = case.tests();
    let means: Vec<f64> = tests.iter().map(|t| t.iter().sum::<f64>() / t.len() as f64).collect();
    let (mut ss, mut nu) = (0.0, 0usize);
    for (t, m) in tests.iter().zip(&means) {
        ss += t.iter().map(|y| ((y - m) / m).powi(2)).sum::<f64>();
        nu += t.len() - 1;
    }
    let cv = (ss / nu as f64).sqrt();
    let w = (means.iter().zip(&tests))
        .map(|(m, t)| t.len() as f64 / (cv * m).powi(2))
        .collect();
    (means, w, nu)
}

/// The weighted least-squares χ² of the tests' means against the model linear in `shapes`
/// ([`beam_common::wls_chi2`]), weighted by the pooled scatter.
fn wls_chi2(case: &Case, shapes: &[fn(f64) -> f64]) -> f64 {
    let (means, w, _) = pooled(case);
    beam_common::wls_chi2(&case.hs, &means, &w, shapes)
}

/// The oracle: the baseline's weighted least-squares χ² against the drawn tests, on n − 1 degrees
/// of freedom, with the critical value at upper tail `q` of its reference distribution: the
/// scatter is estimated from the specimens (ν = Σ (m − 1) degrees of freedom), so χ²/(n − 1) is
/// F(n − 1, ν), not χ².
fn exact_chi2(case: &Case, q: f64) -> (f64, usize, f64) {
    let chi2 = wls_chi2(case, &[bending]);
    let (dof, nu) = (case.hs.len() - 1, pooled(case).2);
    (chi2, dof, dof as f64 * f_quantile(q, dof, nu))
}

/// Whether the tests themselves, read through the exact closed form, reject the hidden clamp in
/// favour of one of `leading` at level `alpha`: the smallest p of a leading shape added to the exact
/// clamped-beam model (an F test on 1 and ν degrees of freedom, the scatter from the specimens).
/// Where it is below α the truth is out of the leading set by the data's own evidence, an event
/// of probability at most α per shape however well `lab` works.
fn tests_reject_the_clamp(case: &Case, leading: &[Value], alpha: f64) -> bool {
    use statrs::distribution::{ContinuousCDF, FisherSnedecor};
    let clamped = wls_chi2(case, &[bending, clamp]);
    let reference = FisherSnedecor::new(1.0, pooled(case).2 as f64).expect("dof > 0");
    (leading
        .iter()
        .filter_map(|l| beam_common::closed_form(l.as_str().unwrap())))
    .map(|shape| 1.0 - reference.cdf(clamped - wls_chi2(case, &[bending, clamp, shape])))
    .any(|p| p < alpha)
}

/// The `q` quantile of F(d1, d2) (statrs, independent of lab's own).
fn f_quantile(q: f64, d1: usize, d2: usize) -> f64 {
    use statrs::distribution::{ContinuousCDF, FisherSnedecor};
    FisherSnedecor::new(d1 as f64, d2 as f64)
        .expect("dof > 0")
        .inverse_cdf(q)
}

/// The issue's beam with its fixed design (8 Latin-hypercube samples and 3 check runs per design,
/// a quadratic surrogate): the exact model's misfit is far beyond the noise, so "no model error"
/// is wrong; the clamp is named (its model confirmed by the solver), or the verdict says the
/// emulators' error decides, with the solver's own reading at the fitted parameters.
#[test]
fn the_issues_beam_with_a_fixed_design_is_never_called_a_fit() {
    let case = issue_beam("{method: lhs, count: 8, seed: 1, check_runs: 3}");
    let (chi2, dof, critical) = exact_chi2(&case, 0.999);
    assert!(chi2 > critical, "the exact model must miss: χ² {chi2} on {dof}");
    let r = run(&case);
    let d = &r["diagnosis"];
    eprintln!("{}", d["summary"].as_str().unwrap_or(""));
    assert_ne!(d["verdict"], "no_model_error", "{}", d["summary"]);
    // The quadratic surrogate is off by the same relative error at every design (tip ∝ 1/E): a
    // change of E absorbs that error, so counting it must not excuse the misfit in h: the misfit
    // with it counted stays within 5 % of the noise alone's (counted per design as if independent,
    // it fell to 43 % of it: χ² 1,352 against 3,152).
    let chi2 = |k: &str| d["emulator"][k]["lack_of_fit"]["chi2"].as_f64().unwrap();
    eprintln!(
        "uncorrected χ²: noise alone {}, emulators' error counted {}",
        chi2("noise_alone"),
        chi2("counted")
    );
    assert!(chi2("counted") >= 0.95 * chi2("noise_alone"), "{}", d["emulator"]);
    let confirmed = d["confirmation"].as_array().expect("confirmation runs");
    let uncorrected = confirmed
        .iter()
        .find(|c| c["model"] == "uncorrected")
        .expect("the uncorrected model");
    assert_eq!(
        uncorrected["lack_of_fit"]["fits"], false,
        "the solver at the fitted E misses: {uncorrected}"
    );
    match d["verdict"].as_str().unwrap() {
        "cause_named" => {
            assert_eq!(d["cause"], "clamp compliance");
            let clamp = confirmed
                .iter()
                .find(|c| c["model"] == "clamp compliance")
                .expect("its confirmation");
            assert_eq!(clamp["lack_of_fit"]["fits"], true, "{clamp}");
        }
        "emulator_limited" => {
            assert!(
                d["headline"].as_str().unwrap().contains("the emulators' error"),
                "{}",
                d["headline"]
            );
            assert!(
                d["action"].as_str().unwrap().contains("more solver runs"),
                "{}",
                d["action"]
            );
        }
        other => panic!(
            "neither the clamp named nor undecided by the emulators: {other}: {}",
            d["summary"]
        ),
    }
    assert!(r["runs"]["planned"].as_u64().unwrap() > 0);
}

/// The same beam sampled sequentially: the clamp named, its model confirmed by the solver, from at
/// most the 100 solver runs the issue asks for (the confirmation's included).
#[test]
fn the_issues_beam_sampled_sequentially_names_the_clamp() {
    let case = issue_beam("{method: sequential, seed: 1}");
    let r = run(&case);
    let d = &r["diagnosis"];
    eprintln!("{}", d["summary"].as_str().unwrap_or(""));
    assert_eq!(d["verdict"], "cause_named", "{}", d["summary"]);
    assert_eq!(d["cause"], "clamp compliance");
    let runs = r["runs"]["planned"].as_u64().unwrap();
    eprintln!("solver runs: {runs}");
    // The issue's bound: the screening stops once the error its E cannot absorb is within the
    // tolerance, the misfit standing with it counted (126 runs before, 34 of them refining it).
    assert!(runs <= 100, "{runs} solver runs");
    // Its last batch records the error that decided: within the tolerance at every design, where
    // the whole measured error (the quadratic's in 1/E, the same relative function of E at every
    // design) is not.
    let tolerance = r["sampling"]["tolerance"].as_f64().unwrap();
    let last = (r["sampling"]["sequence"].as_array().unwrap().iter())
        .rfind(|b| b["stage"] == "screening")
        .unwrap();
    let decided = last["unabsorbed_error"]
        .as_object()
        .expect("the unabsorbed error recorded");
    assert!(
        decided.values().all(|v| v.as_f64().is_some_and(|v| v <= tolerance)),
        "{last}"
    );
    let whole = last["emulator_error"].as_object().unwrap();
    assert!(
        whole.values().any(|v| v.as_f64().is_some_and(|v| v > tolerance)),
        "{last}"
    );
    let clamp = d["confirmation"]
        .as_array()
        .and_then(|c| c.iter().find(|c| c["model"] == "clamp compliance"))
        .expect("the clamp's model confirmed");
    assert_eq!(clamp["lack_of_fit"]["fits"], true, "{clamp}");
}

/// The first seed of a family: 0, or the variable's value to draw cases nobody tuned the rules on.
fn seed_base(var: &str) -> u64 {
    std::env::var(var).ok().and_then(|s| s.parse().ok()).unwrap_or(0)
}

/// Small fixed designs with linear and quadratic surrogates, on drawn beams with a hidden clamp
/// compliance or none (`LAB_CONFIRM_SEED_BASE` moves the draws). Asserted: no "no model error"
/// where the oracle's exact χ² exceeds its α/10 critical value; on clean draws, model error claimed
/// at most once in eight (at α = 0.01 the chance of two or more false claims is 0.3 %); no cause
/// but the clamp named, and an undecided case keeps the clamp among its leading explanations,
/// unless the tests themselves reject it: where the exact clamped-beam model, fitted to the drawn
/// tests, still gains from the named or a leading shape at α (F on 1 and the specimens' ν degrees
/// of freedom), the truth is out by the data's own evidence, which may happen at most once.
#[test]
fn small_fixed_designs_are_confirmed_by_the_solver() {
    let base = seed_base("LAB_CONFIRM_SEED_BASE");
    let cases: Vec<Case> = (0..16u64)
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(base + i);
            let mut case = drawn_beam(&mut rng, i % 2 == 0, base + 1000 + i);
            case.sampling = format!(
                "{{method: lhs, count: {}, seed: 1, check_runs: 2}}",
                [6, 8][rng.random_range(0..2usize)]
            );
            case.surrogate = ["linear", "quadratic"][rng.random_range(0..2usize)];
            case
        })
        .collect();
    let results = family_runs::in_parallel(&cases, run);
    judge_family(&cases, &results);
}

/// The same family sampled sequentially with a quadratic surrogate (cruder than the beam's 1/E,
/// so its screening stops where the error its parameter cannot absorb is within the tolerance, when
/// the misfit stands with it; `src/pipeline/sequence/absorbed.rs`), on its own draws
/// (`LAB_CONFIRM_SEED_BASE` moves them), judged as the fixed designs are; a named clamp's E within
/// 2 % and kr within 15 % of the truth. The solver runs of each case are printed (over seed bases
/// 0, 161,803, 271,828 and 613,979: the same 48 verdicts as when the screening refined the whole
/// error, and 2,402 runs instead of 2,599 on the 24 hidden clamps; docs/sampling.md).
#[test]
fn sequential_designs_with_a_crude_surrogate_are_confirmed_by_the_solver() {
    let base = seed_base("LAB_CONFIRM_SEED_BASE");
    let cases: Vec<Case> = (0..12u64)
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(base + 500 + i);
            drawn_beam(&mut rng, i % 2 == 0, base + 1500 + i)
        })
        .collect();
    let results = family_runs::in_parallel(&cases, run);
    judge_family(&cases, &results);
    for (case, r) in cases.iter().zip(&results) {
        let d = &r["diagnosis"];
        let runs = r["runs"]["planned"].as_u64().unwrap();
        let stages: Vec<String> = (r["sampling"]["stopped"].as_array().into_iter().flatten())
            .map(|s| format!("{} {}", s["stage"], s["runs"]))
            .collect();
        eprintln!(
            "kr {:.3}: {} {}, {runs} solver runs ({})",
            case.kr,
            d["verdict"],
            d["cause"],
            stages.join(", ")
        );
        // Named, its parameters within the tolerances `loop_verdict`'s clamp case holds them to.
        if d["verdict"] == "cause_named" {
            let x = &d["extended"]["parameters"];
            for (name, truth, tolerance) in [("E", case.e, 0.02), ("kr", case.kr, 0.15)] {
                let v = x[name].as_f64().unwrap();
                assert!(
                    (v / truth - 1.0).abs() < tolerance,
                    "{name} = {v}, truth {truth}: {}",
                    d["summary"]
                );
            }
        }
    }
}

/// A beam of the confirmation families: E ~ U(60,000, 76,000) MPa, a hidden clamp kr ~ U(0.1, 0.5)
/// or none, 0.2–0.5 % noise, three specimens at h = 7…13; sampled sequentially with a quadratic
/// surrogate unless the caller draws another plan (its tests from `seed`).
fn drawn_beam(rng: &mut ChaCha8Rng, hidden: bool, seed: u64) -> Case {
    Case {
        e: rng.random_range(60_000.0..76_000.0),
        kr: if hidden { rng.random_range(0.1..0.5) } else { 0.0 },
        hs: (7..=13).map(f64::from).collect(),
        specimens: 3,
        cv: rng.random_range(0.002..0.005),
        seed,
        sampling: "{method: sequential, seed: 1}".into(),
        surrogate: "quadratic",
    }
}

/// What [`small_fixed_designs_are_confirmed_by_the_solver`] asserts of a family of hidden clamps
/// and clean beams (see there).
fn judge_family(cases: &[Case], results: &[Value]) {
    let (mut false_claims, mut wrong_causes, mut undecided_without) = (0, Vec::new(), Vec::new());
    let mut rejected_by_the_tests = 0;
    for (case, r) in cases.iter().zip(results) {
        let d = &r["diagnosis"];
        let verdict = d["verdict"].as_str().unwrap();
        verdict_common::assert_listed_rivals_said(d);
        let (chi2, dof, critical) = exact_chi2(case, 0.999);
        eprintln!(
            "kr {:.3} E {:.0} cv {:.4} {} {}: exact χ² {chi2:.1} on {dof}; lab: {verdict} {}",
            case.kr, case.e, case.cv, case.surrogate, case.sampling, d["cause"]
        );
        if chi2 > critical {
            assert_ne!(
                verdict, "no_model_error",
                "the exact model misses (χ² {chi2} on {dof}): {}",
                d["summary"]
            );
        }
        if case.kr == 0.0 && d["discrepancy_detected"] == true && verdict != "emulator_limited" {
            false_claims += 1;
        }
        if verdict == "cause_named" && d["cause"] != "clamp compliance" {
            // Another cause named over a hidden clamp only where the tests themselves, read through
            // the exact clamped beam, prefer it (seed base 200,200: a clamp of kr = 0.184 whose
            // three specimens scatter at half their true spread; the shear's shape added to the
            // exact clamped beam p = 0.0079, the clamp's to the exact shear model p = 0.40).
            let alpha = d["levels"]["alpha"].as_f64().unwrap();
            match case.kr > 0.0 && tests_reject_the_clamp(case, std::slice::from_ref(&d["cause"]), alpha) {
                true => rejected_by_the_tests += 1,
                false => wrong_causes.push(d["cause"].clone()),
            }
        }
        // Every extension the solver's runs over its amplitude favour is said and kept among the
        // leading explanations, not only the first.
        for open in d["not_excluded"].as_array().into_iter().flatten() {
            if open["favoured"].is_object() {
                let name = open["hypothesis"].as_str().unwrap();
                assert_eq!(verdict, "emulator_limited", "{}", d["summary"]);
                assert!(
                    d["leading"].as_array().unwrap().iter().any(|l| l == name),
                    "{}",
                    d["summary"]
                );
                assert!(
                    r["answer"]["verdict"].as_str().unwrap().contains(name),
                    "{}",
                    r["answer"]
                );
            }
        }
        let undecided = matches!(verdict, "emulator_limited" | "cannot_tell_apart");
        let leading = d["leading"].as_array().unwrap();
        if case.kr > 0.0 && undecided && !leading.iter().any(|l| l == "clamp compliance") {
            let alpha = d["levels"]["alpha"].as_f64().unwrap();
            if tests_reject_the_clamp(case, leading, alpha) {
                rejected_by_the_tests += 1;
            } else {
                undecided_without.push(d["leading"].clone());
            }
        }
    }
    let clean = cases.iter().filter(|c| c.kr == 0.0).count();
    assert!(
        false_claims <= 1,
        "{false_claims} false claims of model error on {clean} clean draws"
    );
    assert!(wrong_causes.is_empty(), "wrong causes named: {wrong_causes:?}");
    assert!(
        undecided_without.is_empty(),
        "undecided without the clamp where the tests do not reject it: {undecided_without:?}"
    );
    // Each hidden clamp's tests reject its exact model for a leading shape with probability at most
    // α per shape (two or three shapes lead): at most 0.03 per case, so two or more of the six or
    // eight hidden clamps with probability below 2.3 %.
    let hidden = cases.iter().filter(|c| c.kr > 0.0).count();
    eprintln!(
        "hidden clamps whose own tests reject the exact clamp for a leading shape: {rejected_by_the_tests} of {hidden}"
    );
    assert!(
        rejected_by_the_tests <= 1,
        "the tests reject the exact clamp for a leading shape on {rejected_by_the_tests} of {hidden} hidden clamps"
    );
}

/// Small hidden clamps (kr ~ U(0.01, 0.05), where the emulators of a small design often find no
/// model error) and clean beams, on fixed designs of 6 samples and 2 check runs per design with
/// linear and quadratic surrogates (`LAB_FAVOURED_SEED_BASE` moves the draws). Where the emulators
/// find no model error but the solver's runs over an extension's amplitude favour it, the solver in
/// the loop over the open extensions decides. Asserted: no cause but the clamp is named, unless the
/// tests themselves, read through the exact clamped beam, prefer it at α (once at most); on a
/// hidden clamp, wherever that loop ran, the clamp is named or among the leading explanations, and
/// where named its kr lies within three standard errors of the truth; the loop ran on at least one
/// of the twelve hidden clamps (about half start it: it is what the family measures); on the four
/// clean beams model error is claimed at most once.
#[test]
fn runs_that_favour_an_extension_start_the_loop_over_it() {
    let base = seed_base("LAB_FAVOURED_SEED_BASE");
    let cases: Vec<Case> = (0..16u64)
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(7_700 + base + i);
            Case {
                e: rng.random_range(62_000.0..74_000.0),
                kr: if i < 12 { rng.random_range(0.01..0.05) } else { 0.0 },
                hs: (7..=13).map(f64::from).collect(),
                specimens: 3,
                cv: 0.003,
                seed: base + 7_800 + i,
                sampling: "{method: lhs, count: 6, seed: 1, check_runs: 2}".into(),
                surrogate: ["linear", "quadratic"][rng.random_range(0..2usize)],
            }
        })
        .collect();
    let results = family_runs::in_parallel(&cases, run);
    let (mut looped, mut false_claims, mut rejected_by_the_tests) = (0, 0, 0);
    for (case, r) in cases.iter().zip(&results) {
        let d = &r["diagnosis"];
        let verdict = d["verdict"].as_str().unwrap();
        let favoured = d["after_loop"]["favoured"].as_array().map_or(0, Vec::len);
        eprintln!(
            "kr {:.4} E {:.0} {}: {verdict} {} (loop from favoured runs: {favoured}; moved by the solver: {}); {}",
            case.kr, case.e, case.surrogate, d["cause"], d["solver_refit"]["outside"], d["leading"]
        );
        if !(d["cause"].is_null() || d["cause"] == "clamp compliance") {
            // Another cause named over a hidden clamp only where the tests themselves prefer it.
            let alpha = d["levels"]["alpha"].as_f64().unwrap();
            assert!(
                case.kr > 0.0 && tests_reject_the_clamp(case, std::slice::from_ref(&d["cause"]), alpha),
                "{}",
                d["summary"]
            );
            rejected_by_the_tests += 1;
        }
        if case.kr == 0.0 {
            false_claims += usize::from(d["discrepancy_detected"] == true && verdict != "emulator_limited");
            continue;
        }
        if favoured > 0 {
            looped += 1;
            // The runs made before the loop are read again after it, never planned twice.
            assert_eq!(r["runs"]["planned"], r["made_by_the_test"], "runs planned against made");
            assert_eq!(
                r["status_by_the_test"], r["made_by_the_test"],
                "`lab status` against made"
            );
            let leading = d["leading"].as_array().unwrap();
            assert!(
                d["cause"] == "clamp compliance" || leading.iter().any(|l| l == "clamp compliance"),
                "{}",
                d["summary"]
            );
        }
        if d["cause"] == "clamp compliance" {
            let x = &d["extended"];
            let (kr, se) = (
                x["parameters"]["kr"].as_f64().unwrap(),
                x["parameter_se"]["kr"].as_f64().unwrap(),
            );
            assert!((kr - case.kr).abs() <= 3.0 * se, "kr {kr} ± {se} against {}", case.kr);
        }
    }
    eprintln!("the loop started from favoured runs on {looped} of 12 hidden clamps");
    assert!(
        looped >= 1,
        "no hidden clamp started the loop from the runs over its amplitude"
    );
    assert!(
        false_claims <= 1,
        "{false_claims} false claims of model error on 4 clean beams"
    );
    // A rival named over the hidden clamp where the exact clamped beam, fitted to the tests, gains
    // from its shape at α: a level-α event for the truth (however well lab works), at most α per
    // case, so two or more in the twelve with probability below 0.7 %.
    assert!(
        rejected_by_the_tests <= 1,
        "the tests prefer a rival to the exact clamp on {rejected_by_the_tests} of 12 hidden clamps"
    );
}
