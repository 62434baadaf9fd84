//! Seeded families of honeycomb curve sets (issue 24): the tests' truth drawn — yield stress,
//! strain hardening, Cowper–Symonds rate parameters, specimen scatter, measurement noise, the three
//! designs — made into test-machine CSVs by the stand-in solver `crushsim` (through
//! `examples/make_honeycomb_tests.rs`, `HONEYCOMB_TESTS_TRUTH`), and a study calibrated against the
//! mean force and the curves with hardening as an extension, run live by `lab run` (solver in the
//! loop). Nothing outside this file knows the draw.
//!
//! Three families, in turn by seed:
//! - **baseline**: the study's own physics (no hardening, no rate effect): no cause may be named;
//! - **hardening** (ETAN drawn 0–450 MPa): leads when the oracle calls it large enough, and is named;
//! - **rate** (SRC drawn 5,000–40,000 1/s, SRP 4; in half the draws hardening too, ETAN 0–300): a
//!   rate effect raises the initial peak and the plateau alike, by a factor that falls with the cell
//!   size; it is not listed, so no listed cause is the whole story: the honest answers are "partly
//!   explained" (hardening at most a partial explanation, in `diagnosis.partial`) or "no listed
//!   cause", never a cause named, and no model is called a fit while a residual beyond its corrected
//!   threshold remains (the figures of every lack-of-fit record are checked against its words).
//!
//! The oracle (crushsim's fold model, `crushsim/src/physics.rs`, which the test knows because it
//! made the tests): hardening's share of the hinges' flow stress, 0.5 ETAN ε_h / σy with
//! ε_h = t / H, H = 0.82 t^(1/3) s^(2/3), s = c/√3, at the tested design where it is smallest. It is
//! *large enough* when that share is at least 2 %: four times the largest per-sample noise drawn
//! (0.5 % of the mean force), before the averaging over the stroke and the specimens, so the
//! plateau-to-peak difference it leaves is many standard errors at every tested design.
//!
//! `LAB_CURVES_SEEDS` (default 12, four per family; about 11 s each) and `LAB_CURVES_SEED_BASE` (default 0) run other draws; the
//! assertions stay the same.

use std::path::{Path, PathBuf};
use std::process::Command;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

use crate::crushsim_bin;
use crate::family_runs;
use crate::verdict_common;

const HARDENING: &str = "strain hardening in the fold hinges";

#[derive(Debug, Clone, Copy, PartialEq)]
enum Family {
    Baseline,
    Hardening,
    Rate,
}

#[derive(Debug, Clone)]
struct Case {
    family: Family,
    sigma_y: f64,
    etan: f64,
    src: f64,
    scatter: f64,
    noise: f64,
    /// (name, c, t): two training designs, then the validation design.
    designs: Vec<(String, f64, f64)>,
    specimens: usize,
    seed: u64,
}

fn env_u64(key: &str, default: u64) -> u64 {
    std::env::var(key).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// A foil thickness from 0.05 to 0.1 mm in steps of 5 µm.
fn thickness(rng: &mut ChaCha8Rng) -> f64 {
    f64::from(rng.random_range(10..=20u32)) * 0.005
}

/// `x` rounded to `step` (the deck's 10-character fields take what a test engineer would write).
fn round(x: f64, step: f64) -> f64 {
    let decimals = (-step.log10()).ceil().max(0.0) as usize;
    format!("{:.*}", decimals, (x / step).round() * step).parse().unwrap()
}

fn draw(seed: u64) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xc0_27e5);
    let family = [Family::Baseline, Family::Hardening, Family::Rate][(seed % 3) as usize];
    let sigma_y = match family {
        // A rate effect raises the flow stress by 20–40 %: the baseline's sigma_y must still reach it.
        Family::Rate => round(rng.random_range(140.0..170.0), 0.1),
        _ => round(rng.random_range(160.0..210.0), 0.1),
    };
    let etan = match family {
        Family::Hardening => round(rng.random_range(0.0..450.0), 1.0),
        Family::Rate if rng.random_bool(0.5) => round(rng.random_range(0.0..300.0), 1.0),
        _ => 0.0,
    };
    let src = if family == Family::Rate {
        round(rng.random_range(5_000.0..40_000.0), 10.0)
    } else {
        0.0
    };
    // Cell sizes the mesher's paper tube takes (3 and 6 mm), one of each in training.
    let mut designs = Vec::new();
    for c in [6.0, 3.0, if rng.random_bool(0.5) { 6.0 } else { 3.0 }] {
        let mut t = thickness(&mut rng);
        while designs
            .iter()
            .any(|(_, c0, t0): &(String, f64, f64)| *c0 == c && (*t0 - t).abs() < 1e-9)
        {
            t = thickness(&mut rng);
        }
        designs.push((format!("C{c}T{}", (t * 1000.0).round()), c, t));
    }
    Case {
        family,
        sigma_y,
        etan,
        src,
        scatter: round(rng.random_range(0.01..0.03), 1e-4),
        noise: round(rng.random_range(0.002..0.005), 1e-4),
        designs,
        specimens: rng.random_range(3..=4),
        seed,
    }
}

/// The oracle: hardening's smallest share of the flow stress over the tested designs.
fn hardening_share(case: &Case) -> f64 {
    case.designs
        .iter()
        .map(|&(_, c, t)| {
            let s = c / 3f64.sqrt();
            let h = 0.82 * t.cbrt() * s.powf(2.0 / 3.0);
            0.5 * case.etan * (t / h) / case.sigma_y
        })
        .fold(f64::INFINITY, f64::min)
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The test generator, built with the tests (`cargo test` compiles the examples).
fn generator() -> PathBuf {
    let path = PathBuf::from(env!("CARGO_BIN_EXE_lab"))
        .with_file_name("examples")
        .join("make_honeycomb_tests");
    assert!(
        path.is_file(),
        "{} is not built: run `cargo test --release` (it builds the examples)",
        path.display()
    );
    path
}

fn make_tests(case: &Case, dir: &Path) {
    let list: Vec<String> = case.designs.iter().map(|(n, c, t)| format!("{n}:{c}:{t}")).collect();
    let truth = format!(
        "sigma_y={},etan={},src={},srp={},scatter={},noise={}",
        case.sigma_y,
        case.etan,
        case.src,
        if case.src > 0.0 { 4.0 } else { 0.0 },
        case.scatter,
        case.noise
    );
    let o = Command::new(generator())
        .arg(dir.join("tests"))
        .arg(crushsim_bin::crushsim())
        .arg(list.join(","))
        .arg(case.specimens.to_string())
        .env("HONEYCOMB_TESTS_TRUTH", truth)
        .env("HONEYCOMB_TESTS_SEED", (case.seed + 7).to_string())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The family's study; `listed` adds hypotheses after the others.
fn write_study(case: &Case, dir: &Path, listed: &str, sampling: &str) -> PathBuf {
    let names: Vec<&str> = case.designs.iter().map(|d| d.0.as_str()).collect();
    let template = root().join("templates/honeycomb/main.k.tera");
    let study = format!(
        r#"name: curves-family
constants: {{term_time: 0.061, dt_out: 0.0005, ribbon_factor: 2}}
design:
  c: {{unit: mm}}
  t: {{unit: mm}}
parameters:
  sigma_y: {{min: 100, max: 250, unit: MPa}}
simulation:
  solver:
    adapter: lsdyna
    templates: [{template}]
    command: [crushsim, i=main.k, ncpu=1]
    timeout: 600
  response: {{kind: crush_force, window: [5, 60], interface: 1, side: master, axis: z, node: 9000005, force_to_kn: 0.001}}
  mesh: {{kind: honeycomb_tube, element_size: 2.0}}
  sampling: {sampling}
  surrogate: linear
experiments:
  file: tests/experiments.csv
  response: force
  unit: kN
  curves: tests/{{design}}-*.csv
training: [{a}, {b}]
validation: [{v}]
calibration:
  methods: [least_squares]
  against: [response, curves]
  curve: {{window: [0, 60], points: 121, surrogate: gp}}
diagnosis:
  hypotheses:
    - name: {HARDENING}
      extension:
        etan: {{min: 0, max: 600, unit: MPa}}
    - name: cell-size effect
      term: "1/c"
{listed}"#,
        template = template.display(),
        a = names[0],
        b = names[1],
        v = names[2],
    );
    let path = dir.join("study.yaml");
    std::fs::write(&path, study).unwrap();
    path
}

/// The studies' sampling: sequential (batches of two, the runs in flight with `--jobs 2`), or
/// `LAB_FAMILY_SAMPLING` (e.g. `{method: lhs, count: 24, seed: 1, check_runs: 5}`, the fixed design
/// this family used before) to compare the solver runs two plans spend on the same verdicts.
fn sampling() -> String {
    std::env::var("LAB_FAMILY_SAMPLING")
        .unwrap_or_else(|_| format!("{{method: sequential, seed: 1, replaces: {FIXED_DESIGN}}}"))
}

/// The fixed design this family used before the sequential one, which each case's
/// `sampling.replaces` counts (never runs): 2,430 over the 12 cases at base 0 when it was run.
const FIXED_DESIGN: &str = "{method: lhs, count: 24, seed: 1, check_runs: 5}";

/// `lab run` live with crushsim on PATH; the diagnosis of results.json.
fn run(case: &Case) -> Value {
    let dir = tempfile::tempdir().unwrap();
    run_in(case, dir.path(), "")
}

fn run_in(case: &Case, dir: &Path, listed: &str) -> Value {
    let r = results_of(case, dir, listed, &sampling());
    verdict_common::assert_verdict_follows_evidence(&r["diagnosis"]);
    verdict_common::assert_settled_stages_decide_nothing(&r);
    family_runs::tally(&r, r["runs"]["planned"].as_u64().unwrap_or(0));
    r["diagnosis"].clone()
}

/// `lab run` live on `case` with `sampling`: the whole results.json.
fn results_of(case: &Case, dir: &Path, listed: &str, sampling: &str) -> Value {
    make_tests(case, dir);
    let study = write_study(case, dir, listed, sampling);
    let bin = crushsim_bin::crushsim().parent().unwrap().to_path_buf();
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args([
            "run",
            study.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            "2",
        ])
        .env("PATH", format!("{}:/usr/bin:/bin", bin.display()))
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "seed {}: {}",
        case.seed,
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap()
}

/// The extended model's value of `name` and whether `truth` lies in its 95 % interval.
fn estimate(d: &Value, name: &str, truth: f64) -> Option<(f64, bool)> {
    let x = d["extensions"]
        .as_array()?
        .iter()
        .find(|x| x["hypothesis"] == HARDENING)?;
    let value = x["parameters"][name].as_f64()?;
    let iv = &x["interval95"][name];
    let inside = match (iv[0].as_f64(), iv[1].as_f64()) {
        (Some(lo), Some(hi)) => lo <= truth && truth <= hi,
        _ => false,
    };
    Some((value, inside))
}

/// What the families must show: no cause on the baseline physics; no decisive claim that is false
/// in any family (a named cause is hardening, and only where the tests hold it); where hardening is
/// large enough it is never rejected and leads (named, or first of the explanations the tests cannot
/// tell apart — three designs with two cell sizes may not separate it from a cell-size term, and the
/// verdict then says so with the test that would), and it is named decisively in most of them, with
/// σy within 3 % and ETAN within 20 % of the truth and both truths inside the extended model's 95 %
/// intervals; where an unlisted rate effect is in the tests, no cause is named (hardening, if
/// present, is at most partial).
#[test]
fn curves_name_hardening_when_it_is_there_and_nothing_on_the_baseline_physics() {
    let n = env_u64("LAB_CURVES_SEEDS", 12);
    let base = env_u64("LAB_CURVES_SEED_BASE", 0);
    let mut t = Tally::default();
    let cases: Vec<Case> = (base..base + n).map(draw).collect();
    for (case, d) in cases.iter().zip(family_runs::in_parallel(&cases, run)) {
        t.count(case, &d);
    }
    eprintln!(
        "{}; {} solver runs for {n} cases ({})",
        t.line(),
        family_runs::runs(),
        sampling()
    );
    assert!(t.clean >= 3 && t.large >= 1 && t.rate >= 3, "too few cases in a family");
    assert!(
        t.false_claims.is_empty(),
        "a cause named that the tests do not hold: seeds {:?}",
        t.false_claims
    );
    assert!(t.clean_quiet == t.clean, "a cause claimed on the baseline physics");
    assert!(
        t.leads * 10 >= t.large * 9,
        "hardening leads in {} of {}",
        t.leads,
        t.large
    );
    assert!(
        t.named * 2 > t.large,
        "hardening named decisively in {} of {}",
        t.named,
        t.large
    );
    // σy within 3 % and ETAN within 20 % (README), the truths inside the 95 % intervals: the
    // intervals are 95 %, so one miss in a handful is chance (in three named cases, one miss or
    // more has probability 0.14, two or more 0.007); more than 30 % missed, or two in three, is not.
    assert!(
        t.close * 10 >= t.named * 8,
        "σy within 3 % and ETAN within 20 % in {} of {}",
        t.close,
        t.named
    );
    let missed = t.named - t.covered;
    assert!(
        missed <= 1 || missed * 10 <= t.named * 3,
        "the truths inside the intervals in {} of {}",
        t.covered,
        t.named
    );
    assert_eq!(
        t.rate_named, 0,
        "a cause named with an unlisted rate effect in the tests"
    );
    family_runs::assert_a_third_of(FIXED_DESIGN);
}

/// The rate effect as a listed hypothesis (Cowper–Symonds C over a range, p = 4).
const LISTED_RATE: &str =
    "    - name: strain rate\n      extension:\n        src: {min: 1000, max: 40000, unit: 1/s}\n        srp: 4\n";

/// With two hypotheses in the loop, their stages take turns, a batch each: the budget is not the
/// first one's to spend. A pure-rate draw whose screening leaves the hardening and the listed rate
/// both open (rate family, seed 424,268), under a budget the hardening's loop alone would spend
/// (run one stage after the other, the hardening took every run left and the rate's loop kept only
/// its first batch, which left its emulator unfittable).
#[test]
fn loop_stages_take_turns_with_the_budget() {
    let case = draw(424_268);
    assert!(case.family == Family::Rate && case.etan == 0.0);
    let dir = tempfile::tempdir().unwrap();
    let r = results_of(
        &case,
        dir.path(),
        LISTED_RATE,
        "{method: sequential, seed: 1, budget: 60}",
    );
    let sequence = r["sampling"]["sequence"].as_array().unwrap();
    let stages: Vec<&str> = ["loop: strain hardening in the fold hinges", "loop: strain rate"].into();
    // Per stage: its batches after the first of the loop's (its probes or first batch), and how it stopped.
    let turns: Vec<(usize, Option<&str>)> = stages
        .iter()
        .map(|s| {
            let mine: Vec<&Value> = sequence.iter().filter(|b| b["stage"] == *s).collect();
            let first = mine.first().map_or(0, |b| b["batch"].as_u64().unwrap());
            let later = mine.iter().filter(|b| b["batch"].as_u64().unwrap() > first).count();
            (later, mine.iter().rev().find_map(|b| b["stopped"].as_str()))
        })
        .collect();
    eprintln!(
        "loop stages' later batches and stops: {turns:?}; {} runs",
        r["runs"]["planned"]
    );
    for (a, (n, stop)) in turns.iter().enumerate() {
        for (b, (m, _)) in turns.iter().enumerate() {
            if a != b && *stop == Some("budget") {
                assert!(
                    n.abs_diff(*m) <= 1,
                    "{}: {n} batches, {}: {m}, when the budget ran out",
                    stages[a],
                    stages[b]
                );
            }
        }
    }
    assert!(
        turns.iter().all(|(n, _)| *n >= 1),
        "a loop stage had no batch of its own: {turns:?}"
    );
}

/// The rate effect listed as a hypothesis too (Cowper–Symonds C over a range, p = 4, as in
/// `studies/honeycomb-diagnosis-curves.yaml`), on the family's pure-rate draws (ETAN = 0): no other
/// cause is ever named decisively, and a loop model's intervals stay within the ranges the study
/// gave its variables (checked for every case by `verdict_common`). How often the rate is named is
/// printed, not asserted: with two training designs its cell-size signature is often within the
/// noise, and the honest answer is then an open one. Where it is named, whether the truths lie inside
/// the rate model's 95 % intervals is printed (an open finding, below).
#[test]
fn a_listed_rate_effect_is_the_only_cause_named() {
    let n = env_u64("LAB_CURVES_RATE_SEEDS", 6) as usize;
    let base = env_u64("LAB_CURVES_SEED_BASE", 0);
    let listed = LISTED_RATE;
    let cases: Vec<Case> = (base..)
        .map(draw)
        .filter(|c| c.family == Family::Rate && c.etan == 0.0)
        .take(n)
        .collect();
    let (mut named, mut covered, mut wrong) = (0, 0, Vec::new());
    let diagnoses = family_runs::in_parallel(&cases, |case| {
        let dir = tempfile::tempdir().unwrap();
        run_in(case, dir.path(), listed)
    });
    for (case, d) in cases.iter().zip(diagnoses) {
        let cause = d["cause"].as_str().map(str::to_string);
        eprintln!(
            "seed {} rate only: sigma_y {:.1} src {:.0} designs {:?} → {} ({cause:?}; leading {})",
            case.seed,
            case.sigma_y,
            case.src,
            case.designs.iter().map(|d| d.0.as_str()).collect::<Vec<_>>(),
            d["verdict"],
            d["leading"]
        );
        let rate = d["extensions"]
            .as_array()
            .into_iter()
            .flatten()
            .find(|x| x["hypothesis"] == "strain rate");
        let inside = |x: &Value, name: &str, truth: f64| {
            let iv = &x["interval95"][name];
            iv[0].as_f64().is_some_and(|lo| lo <= truth) && iv[1].as_f64().is_some_and(|hi| truth <= hi)
        };
        let truths_inside = rate.is_some_and(|x| inside(x, "sigma_y", case.sigma_y) && inside(x, "src", case.src));
        if let Some(x) = rate {
            eprintln!(
                "  sigma_y {} {}, src {} {}; truths inside {truths_inside}",
                x["parameters"]["sigma_y"], x["interval95"]["sigma_y"], x["parameters"]["src"], x["interval95"]["src"]
            );
        }
        match cause.as_deref() {
            Some("strain rate") => {
                named += 1;
                covered += usize::from(truths_inside);
            }
            Some(_) => wrong.push(case.seed),
            None => {}
        }
    }
    eprintln!(
        "listed rate: named {named} of {}, both truths inside the 95 % intervals in {covered}",
        cases.len()
    );
    assert!(
        wrong.is_empty(),
        "another cause named where the rate effect is listed and true: seeds {wrong:?}"
    );
    // Not asserted yet (open, docs/diagnosis.md): from seed 0 the truths are inside the rate model's
    // 95 % intervals in 5 of 6; the miss (seed 5) is an interval a few MPa wide whose optimum is the
    // loop emulators' (run with the solver itself, the truth fits the tests better).
}

/// The families' outcomes, case by case.
#[derive(Default)]
struct Tally {
    clean: usize,
    clean_quiet: usize,
    large: usize,
    leads: usize,
    named: usize,
    close: usize,
    covered: usize,
    small: usize,
    rate: usize,
    rate_partly: usize,
    rate_named: usize,
    false_claims: Vec<u64>,
}

impl Tally {
    fn count(&mut self, case: &Case, d: &Value) {
        let share = hardening_share(case);
        let cause = d["cause"].as_str().unwrap_or("-").to_string();
        let decisive = d["verdict"] == "cause_named";
        eprintln!(
            "seed {} {:?}: sigma_y {:.1} etan {:.0} src {:.0} share {:.3} designs {:?} × {} → {} ({cause}; partial {})",
            case.seed,
            case.family,
            case.sigma_y,
            case.etan,
            case.src,
            share,
            case.designs.iter().map(|d| d.0.as_str()).collect::<Vec<_>>(),
            case.specimens,
            d["verdict"],
            d["partial"]["name"]
        );
        if decisive && !(case.family == Family::Hardening && cause == HARDENING) {
            self.false_claims.push(case.seed);
        }
        match case.family {
            Family::Baseline => {
                self.clean += 1;
                self.clean_quiet += usize::from(d["cause"].is_null() && d["partial"].is_null());
            }
            Family::Rate => {
                self.rate += 1;
                self.rate_partly += usize::from(d["verdict"] == "partly_explained");
                self.rate_named += usize::from(!d["cause"].is_null());
            }
            Family::Hardening if share >= 0.02 => self.hardening(case, d, decisive && cause == HARDENING),
            Family::Hardening => self.small += 1,
        }
    }

    fn hardening(&mut self, case: &Case, d: &Value, named: bool) {
        self.large += 1;
        let first = d["leading"][0] == HARDENING || d["cause"] == HARDENING;
        let rejected = d["after_loop"]["explanations"]
            .as_array()
            .is_some_and(|e| e.iter().any(|x| x["name"] == HARDENING && x["rejected"] == true));
        self.leads += usize::from(first && !rejected);
        if !named {
            eprintln!("{}", d["summary"].as_str().unwrap_or(""));
            return;
        }
        self.named += 1;
        let sy = estimate(d, "sigma_y", case.sigma_y);
        let et = estimate(d, "etan", case.etan);
        eprintln!("  sigma_y {sy:?}, etan {et:?}");
        let within =
            |e: Option<(f64, bool)>, truth: f64, tol: f64| e.is_some_and(|(v, _)| (v / truth - 1.0).abs() < tol);
        let inside = |e: Option<(f64, bool)>| e.is_some_and(|(_, inside)| inside);
        self.close += usize::from(within(sy, case.sigma_y, 0.03) && within(et, case.etan, 0.2));
        self.covered += usize::from(inside(sy) && inside(et));
    }

    fn line(&self) -> String {
        format!(
            "baseline: no cause {}/{}; hardening large enough: leads and not rejected {}/{}, named decisively {}/{}, \
             sigma_y within 3 % and etan within 20 % {}/{}, both truths inside their 95 % intervals {}/{}; smaller \
             ({}) not judged; rate (not listed): partly explained {}/{}, a cause named {}; false decisive claims {:?}",
            self.clean_quiet,
            self.clean,
            self.leads,
            self.large,
            self.named,
            self.large,
            self.close,
            self.named,
            self.covered,
            self.named,
            self.small,
            self.rate_partly,
            self.rate,
            self.rate_named,
            self.false_claims
        )
    }
}

/// One draw kept in `/tmp/curves-family-SEED` for a look at its results and report.
#[test]
#[ignore]
fn debug_one() {
    let seed = env_u64("SEED", 0);
    let dir = PathBuf::from(format!("/tmp/curves-family-{seed}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let case = draw(seed);
    eprintln!("{case:?}");
    let d = run_in(&case, &dir, "");
    eprintln!("{}", d["summary"].as_str().unwrap_or(""));
}
