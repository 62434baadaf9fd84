//! The verdict after the loop (issue 25), through `lab run` with a real solver process: the
//! stand-in `clamped_beam` (examples/clamped_beam.rs, a closed form run as a program) whose
//! template has a shear factor `s` and a clamp compliance `kr` (both 0 in the baseline). The tests
//! are drawn here, from a seed, at a known E and kr; the study lists three hypotheses: shear
//! correction (an extension, `s` in [0, 1.5]), a fixture offset (a term) and clamp compliance (an
//! extension, `kr` in [0, 1]). Nothing outside this file knows the draw.
//!
//! Whether the tests *can* decide is not assumed: an oracle here, sharing no code with lab, fits
//! each rival explanation to the noise-free truth by weighted least squares (y = u·(a + s·c) with
//! u = 1/E, s in its declared range; y = u·a + γ for the offset; y = u·a + γ·h for a trend in h)
//! and takes the weighted misfit as the noncentrality of the test that would reject it. A case
//! *decides* when every rival's noncentrality is ≥ 40 (power ≈ 0.99 at α = 0.01 on ~6 degrees of
//! freedom) and *does not decide* when the shear model's is ≤ 2 (power ≈ α).

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde_json::Value;

use crate::family_runs;
use crate::verdict_common;

use crate::beam_common;
use beam_common::{bending, clamp, shear};

const S_MAX: f64 = 1.5;

/// One drawn case: the truth, the designs, the specimens and their scatter.
#[derive(Debug, Clone)]
struct Case {
    e: f64,
    kr: f64,
    hs: Vec<f64>,
    specimens: usize,
    cv: f64,
    seed: u64,
}

impl Case {
    fn truth(&self, h: f64) -> f64 {
        (bending(h) + self.kr * clamp(h)) / self.e
    }
    fn names(&self) -> Vec<String> {
        self.hs.iter().map(|h| format!("h{}", fmt(*h))).collect()
    }
    /// The last design validates; the others train.
    fn training(&self) -> Vec<String> {
        let n = self.names();
        n[..n.len() - 1].to_vec()
    }
}

fn fmt(h: f64) -> String {
    format!("{h:.2}")
        .trim_end_matches('0')
        .trim_end_matches('.')
        .replace('.', "p")
}

/// Writes the study, template and tests into `dir`; returns the study file.
fn write_study(case: &Case, dir: &Path) -> PathBuf {
    let mut rng = ChaCha8Rng::seed_from_u64(case.seed);
    let z = Normal::new(0.0, 1.0).unwrap();
    let mut csv = String::from("design,h,deflection\n");
    for (h, name) in case.hs.iter().zip(case.names()) {
        for _ in 0..case.specimens {
            let y = case.truth(*h) * (1.0 + case.cv * z.sample(&mut rng));
            csv.push_str(&format!("{name},{h},{y:e}\n"));
        }
    }
    std::fs::write(dir.join("tests.csv"), csv).unwrap();
    beam_common::write_template(dir);
    let names = case.names();
    let lo = case.hs.first().unwrap();
    let hi = case.hs.last().unwrap();
    let study = format!(
        "{}\
         \x20 sampling: {}\n\
         \x20 surrogate: gp\n\
         experiments: {{file: tests.csv, response: deflection, unit: mm}}\n\
         training: [{}]\n\
         validation: [{}]\n\
         calibration: {{methods: [least_squares]}}\n\
         diagnosis:\n  hypotheses:\n\
         \x20   - name: shear correction\n      extension: {{s: {{min: 0, max: {S_MAX}}}}}\n\
         \x20   - name: fixture offset\n      term: \"1\"\n\
         \x20   - name: clamp compliance\n      extension: {{kr: {{min: 0, max: 1}}}}\n",
        beam_common::study_head("clamp-case", (*lo, *hi)),
        sampling(),
        case.training().join(", "),
        names.last().unwrap(),
    );
    let path = dir.join("clamp.yaml");
    std::fs::write(&path, study).unwrap();
    path
}

/// The studies' sampling: sequential (batches of two, the runs in flight with `--jobs 2`), or
/// `LAB_FAMILY_SAMPLING` (e.g. `{method: lhs, count: 6, seed: 1, check_runs: 1}`, the fixed design
/// these families used before) to compare the solver runs two plans spend on the same verdicts.
fn sampling() -> String {
    std::env::var("LAB_FAMILY_SAMPLING")
        .unwrap_or_else(|_| format!("{{method: sequential, seed: 1, replaces: {FIXED_DESIGN}}}"))
}

/// The fixed design this family used before the sequential one, which each case's
/// `sampling.replaces` counts (never runs): 11,844 runs over base 0's 36 cases when it was run.
const FIXED_DESIGN: &str = "{method: lhs, count: 6, seed: 1, check_runs: 1}";

/// `lab run` on the case; its `diagnosis`.
fn run(case: &Case) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let study = write_study(case, dir.path());
    let out = dir.path().join("out");
    let (_, results) = beam_common::lab_run(&study, &out);
    // Every solver invocation counted: each run's directory holds what the stand-in wrote.
    let invoked = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().join("output.txt").is_file())
        .count() as u64;
    assert_eq!(
        Some(invoked),
        results["runs"]["planned"].as_u64(),
        "{}",
        results["runs"]
    );
    family_runs::tally(&results, invoked);
    if std::env::var("LAB_LOOP_VERBOSE").is_ok() {
        eprintln!("surrogates: {}", results["surrogates"]);
        for c in results["diagnosis"]["candidates"].as_array().unwrap() {
            eprintln!(
                "cand {} wrss {} p {} amp {} params {} loo {} aicc {}",
                c["name"],
                c["weighted_rss"],
                c["p_value"],
                c["amplitude"],
                c["parameters"],
                c["loo_deviance"],
                c["aicc"]
            );
        }
        eprintln!("rivals {}", results["diagnosis"]["rivals"]);
        eprintln!(
            "residuals {}",
            results["diagnosis"]["residuals"]
                .as_array()
                .unwrap()
                .iter()
                .map(|r| format!(
                    "{} n={} sd={} mean={}",
                    r["design"], r["count"], r["std_dev"], r["measured"]
                ))
                .collect::<Vec<_>>()
                .join("; ")
        );
        eprintln!(
            "extensions runs: {:?}",
            results["diagnosis"]["extensions"]
                .as_array()
                .map(|x| x.iter().map(|e| e["runs"].clone()).collect::<Vec<_>>())
        );
    }
    let d = results["diagnosis"].clone();
    verdict_common::assert_verdict_follows_evidence(&d);
    verdict_common::assert_settled_stages_decide_nothing(&results);
    d
}

// ---- The oracle: weighted least squares on the noise-free truth, nothing from lab. ----

/// Weighted misfit of the best fit of `columns` (linear coefficients, unconstrained) to the truth.
fn misfit(y: &[f64], w: &[f64], columns: &[Vec<f64>]) -> (f64, Vec<f64>) {
    let k = columns.len();
    let mut m = nalgebra::DMatrix::<f64>::zeros(k, k);
    let mut b = nalgebra::DVector::<f64>::zeros(k);
    for i in 0..y.len() {
        for a in 0..k {
            b[a] += w[i] * columns[a][i] * y[i];
            for c in 0..k {
                m[(a, c)] += w[i] * columns[a][i] * columns[c][i];
            }
        }
    }
    let beta = m.clone().lu().solve(&b).unwrap();
    let r: f64 = (0..y.len())
        .map(|i| {
            let fit: f64 = (0..k).map(|a| beta[a] * columns[a][i]).sum();
            w[i] * (y[i] - fit).powi(2)
        })
        .sum();
    (r, beta.iter().copied().collect())
}

/// The noncentralities of the rivals' misfits (shear within its range, offset, trend in h) over
/// every tested design, weights n/σ² of the relative noise.
fn oracle(case: &Case) -> (f64, f64, f64) {
    let tested: Vec<(f64, f64)> = case.hs.iter().map(|&h| (h, case.specimens as f64)).collect();
    let y: Vec<f64> = case.hs.iter().map(|&h| case.truth(h)).collect();
    let w = weights(case, &tested);
    let ones = vec![1.0; y.len()];
    let bend: Vec<f64> = case.hs.iter().map(|&h| bending(h)).collect();
    let offset = misfit(&y, &w, &[bend.clone(), ones]).0;
    let trend = misfit(&y, &w, &[bend, case.hs.clone()]).0;
    (shear_misfit(case, &tested), offset, trend)
}

/// Weights m/σ² of `m` specimens at each design `h`, the noise relative to the truth.
fn weights(case: &Case, at: &[(f64, f64)]) -> Vec<f64> {
    at.iter().map(|&(h, m)| m / (case.cv * case.truth(h)).powi(2)).collect()
}

/// The shear model's weighted misfit to the truth, refitted within its range, over `m` specimens at
/// each design `h` (several entries may share a design).
fn shear_misfit(case: &Case, at: &[(f64, f64)]) -> f64 {
    rival_misfit(case, "shear correction", &|h| case.truth(h), at).unwrap()
}

/// The weighted misfit of the explanation `name` refitted to `truth` over `m` specimens at each
/// design `h`: y = u·(bend + s·shear), s in [0, S_MAX]; y = u·(bend + kr·clamp), kr in [0, 1];
/// y = u·bend + γ (the offset, listed or built in); y = u·bend + γ·h (the built-in linear term);
/// y = u·bend (the uncorrected model, a scale error). Every explanation the study lists and every
/// built-in shape is modelled; `None` (a failure of the test) for any other name.
fn rival_misfit(case: &Case, name: &str, truth: &dyn Fn(f64) -> f64, at: &[(f64, f64)]) -> Option<f64> {
    let y: Vec<f64> = at.iter().map(|&(h, _)| truth(h)).collect();
    let w = weights(case, at);
    let bend: Vec<f64> = at.iter().map(|&(h, _)| bending(h)).collect();
    let column = |f: fn(f64) -> f64| at.iter().map(|&(h, _)| f(h)).collect::<Vec<f64>>();
    Some(match name {
        "shear correction" => bounded_misfit(&y, &w, &bend, &column(shear), S_MAX),
        "clamp compliance" => bounded_misfit(&y, &w, &bend, &column(clamp), 1.0),
        // The study's term "1" and the built-in of the same shape.
        "fixture offset" | "constant offset" => misfit(&y, &w, &[bend, vec![1.0; y.len()]]).0,
        // The built-in term proportional to the design variable.
        "linear in h" => misfit(&y, &w, &[bend, column(|h| h)]).0,
        // y·(1 + γ) is E refitted: the same misfit as the simulation's.
        "uncorrected" | "scale error" => misfit(&y, &w, &[bend]).0,
        _ => return None,
    })
}

/// y = u·bend + v·extra with v = u·s, 0 ≤ s ≤ max: the free optimum if inside, else a bound.
fn bounded_misfit(y: &[f64], w: &[f64], bend: &[f64], extra: &[f64], max: f64) -> f64 {
    let (free, beta) = misfit(y, w, &[bend.to_vec(), extra.to_vec()]);
    if beta[0] > 0.0 && beta[1] >= 0.0 && beta[1] <= max * beta[0] {
        return free;
    }
    let at_max: Vec<f64> = bend.iter().zip(extra).map(|(a, c)| a + max * c).collect();
    misfit(y, w, &[bend.to_vec()]).0.min(misfit(y, w, &[at_max]).0)
}

/// What an offered programme would show if `truth` held: for each of the two explanations it is
/// to tell apart, the increase of its noncentrality when the programme's additional specimens join
/// the tests in hand (refitted to all); the larger (the one the programme would reject), and the
/// power at `level` it gives (normal approximation of the noncentral χ²₁, as lab states its power).
fn programme_power(
    case: &Case,
    truth: &dyn Fn(f64) -> f64,
    between: &[Value],
    programme: &[Value],
    level: f64,
) -> Option<(f64, f64)> {
    use statrs::distribution::{ContinuousCDF, Normal as Gauss};
    let tested: Vec<(f64, f64)> = case.hs.iter().map(|&h| (h, case.specimens as f64)).collect();
    let mut with: Vec<(f64, f64)> = tested.clone();
    with.extend(
        programme
            .iter()
            .map(|r| (r["design"]["h"].as_f64().unwrap(), r["additional"].as_f64().unwrap())),
    );
    let mut gain = 0.0_f64;
    for name in between {
        let name = name.as_str()?;
        let before = rival_misfit(case, name, truth, &tested)?;
        gain = gain.max(rival_misfit(case, name, truth, &with)? - before);
    }
    let n = Gauss::new(0.0, 1.0).unwrap();
    Some((gain, n.cdf(gain.sqrt() - n.inverse_cdf(1.0 - level / 2.0))))
}

/// The first seed of the families: 0, or `LAB_LOOP_SEED_BASE` to run them on seeds nobody has
/// looked at (the assertions stay the same).
fn seed_base() -> u64 {
    std::env::var("LAB_LOOP_SEED_BASE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

fn draw(seed: u64) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
    let h0 = rng.random_range(5.5..8.0);
    let step = rng.random_range(0.6..1.6);
    Case {
        e: rng.random_range(62_000.0..74_000.0),
        kr: rng.random_range(0.15..0.45),
        hs: (0..7).map(|i| h0 + step * i as f64).collect(),
        specimens: rng.random_range(3..=8),
        cv: rng.random_range(0.0015..0.007),
        seed,
    }
}

fn interval_holds(d: &Value, name: &str, truth: f64) -> bool {
    // The answer's interval: the solver's refit where it moved the loop's point, else the loop's.
    let refit = &d["solver_refit"];
    let x = match refit["model"] == "clamp compliance" {
        true => &refit["interval95"][name],
        false => &d["extensions"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["hypothesis"] == "clamp compliance")
            .expect("clamp extended")["interval95"][name],
    };
    let (lo, hi) = (x[0].as_f64().unwrap(), x[1].as_f64().unwrap());
    lo <= truth && truth <= hi
}

/// The case: tests at E = 68,000 and kr = 0.3, h = 6..14, five specimens at 0.3 %
/// scatter. The screening's linearised shapes may leave clamp and shear open; the loop's models
/// decide: the shear model, held to its declared range, misses the tests (oracle noncentrality
/// printed below, far above what the lack-of-fit test needs), the clamp model fits.
#[test]
fn clamp_case_names_clamp_compliance_from_the_loops_evidence() {
    let case = Case {
        e: 68_000.0,
        kr: 0.3,
        hs: (0..7).map(|i| 6.0 + 8.0 * f64::from(i) / 6.0).collect(),
        specimens: 5,
        cv: 0.003,
        seed: 25,
    };
    let (shear, offset, trend) = oracle(&case);
    eprintln!("oracle noncentralities: shear {shear:.1}, offset {offset:.1}, trend {trend:.1}");
    assert!(
        shear >= 40.0 && offset >= 40.0 && trend >= 40.0,
        "the case must be decidable"
    );
    let d = run(&case);
    eprintln!("{}", d["summary"].as_str().unwrap());
    assert_eq!(d["verdict"], "cause_named", "{}", d["summary"]);
    assert_eq!(d["cause"], "clamp compliance");
    let params = &d["extended"]["parameters"];
    // kr and E with their intervals, the truths inside them.
    assert!(interval_holds(&d, "kr", 0.3), "{}", d["extensions"]);
    assert!(interval_holds(&d, "E", 68_000.0), "{}", d["extensions"]);
    assert!((params["kr"].as_f64().unwrap() / 0.3 - 1.0).abs() < 0.15, "{params}");
    assert!(
        (params["E"].as_f64().unwrap() / 68_000.0 - 1.0).abs() < 0.02,
        "{params}"
    );
    assert_eq!(d["extended"]["solver_in_the_loop"], true);
    // Issue 30: this beam, tried as a new user would with a fixed design, took 399 solver runs; the
    // sequential design must reach the same verdict from at most a quarter of them (85 measured;
    // 38 with `across_designs`; the family's fixed design of 6 + 1 per design makes 280).
    let runs = family_runs::runs();
    eprintln!("solver runs: {runs} ({})", sampling());
    if std::env::var("LAB_FAMILY_SAMPLING").is_err() {
        assert!(runs * 4 <= 399, "{runs} solver runs");
    }
    // The rival is out (the oracle says its model misses by far), and the evidence says how: by its
    // lack of fit where the loop judged it, else by the screening's encompassing test, which the
    // named cause beat.
    let judged = d["after_loop"]["explanations"]
        .as_array()
        .and_then(|e| e.iter().find(|e| e["name"] == "shear correction"));
    match judged {
        Some(shear) => {
            assert_eq!(shear["rejected"], true, "{shear}");
            let line = d["evidence"].as_array().unwrap().iter().any(|l| {
                l.as_str()
                    .unwrap()
                    .starts_with("'shear correction' calibrated with the solver in the loop: rejected")
            });
            assert!(line, "{}", d["summary"]);
        }
        None => {
            let rival = d["rivals"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["rival"] == "shear correction")
                .unwrap_or_else(|| {
                    panic!(
                        "the shear correction is neither judged by the loop nor a rival: {}",
                        d["rivals"]
                    )
                });
            assert_eq!(rival["beaten"], true, "{rival}");
        }
    }
}

/// Seeded families: designs, specimens, scatter and the truth drawn; classified by the oracle.
/// Where every rival's model misses the noise-free truth by far, the clamp is named (≥ 9 in 10)
/// with E and kr inside their intervals (≥ 8 in 10); where the shear model within its range fits
/// the truth as well, no cause is named in ≥ 8 in 10, and the next test offers a programme of
/// designs or an independent measurement in at least half of them (a solver study can only be
/// predicted at its tested designs; where nothing there decides, the next test says so). The shear
/// correction is never named: the truth has none. 120 seeds give about 30 decidable cases, so that
/// the 9-in-10 bound is not at the mercy of two chance rejections at α (each case runs several
/// tests at α = 0.01).
#[test]
fn loop_decides_where_the_evidence_does_and_says_so_where_it_does_not() {
    let n = std::env::var("LAB_LOOP_SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(120);
    let (mut decides, mut named, mut inside) = (0, 0, 0);
    let (mut open, mut not_named, mut with_test) = (0, 0, 0);
    let mut shear_named = 0;
    // The power under the truth of each programme the next test offers.
    let mut programmes: Vec<f64> = Vec::new();
    // The cases the oracle classifies, run on the machine's cores, then judged in seed order.
    let cases: Vec<(u64, Case, (f64, f64, f64))> = (seed_base()..seed_base() + n)
        .map(|seed| (seed, draw(seed)))
        .map(|(seed, case)| {
            let o = oracle(&case);
            (seed, case, o)
        })
        .filter(|(_, _, (shear, offset, trend))| (*shear >= 40.0 && *offset >= 40.0 && *trend >= 40.0) || *shear <= 2.0)
        .collect();
    let diagnoses = family_runs::in_parallel(&cases, |(_, case, _)| run(case));
    for ((seed, case, (shear, offset, trend)), d) in cases.into_iter().zip(diagnoses) {
        let class_decides = shear >= 40.0 && offset >= 40.0 && trend >= 40.0;
        eprintln!(
            "seed {seed}: shear {shear:.1} offset {offset:.1} trend {trend:.1} → {} ({}; moved by the solver: {})",
            d["verdict"], d["cause"], d["solver_refit"]["outside"]
        );
        shear_named += usize::from(d["cause"] == "shear correction");
        let expected = if class_decides {
            d["verdict"] == "cause_named"
        } else {
            d["cause"].is_null()
        };
        if !expected || std::env::var("LAB_LOOP_VERBOSE").is_ok() {
            eprintln!("{}\n{}", d["summary"].as_str().unwrap_or(""), d["next_test"]);
        }
        if class_decides {
            decides += 1;
            if d["cause"] == "clamp compliance" && d["verdict"] == "cause_named" {
                named += 1;
                inside += usize::from(interval_holds(&d, "kr", case.kr) && interval_holds(&d, "E", case.e));
            }
        } else {
            open += 1;
            not_named += usize::from(d["cause"].is_null());
            let t = &d["next_test"];
            assert!(t.is_object(), "cannot tell apart without a next test");
            let offers = t["programme"].as_array().is_some_and(|p| !p.is_empty())
                || t["measurements"].as_array().is_some_and(|m| !m.is_empty());
            with_test += usize::from(offers);
            if let Some(p) = t["programme"].as_array().filter(|p| !p.is_empty()) {
                let between = t["between"].as_array().unwrap();
                let level = t["level"].as_f64().unwrap();
                let (gain, power) = programme_power(&case, &|h| case.truth(h), between, p, level)
                    .unwrap_or_else(|| panic!("the oracle does not model {between:?}"));
                eprintln!(
                    "seed {seed}: programme of {} specimens between {between:?}: under the truth λ {gain:.1}, power \
                     {power:.2} (lab: {} at the fitted numbers, {} over their uncertainty)",
                    p.iter().map(|r| r["additional"].as_u64().unwrap()).sum::<u64>(),
                    t["power"],
                    t["expected_power"]
                );
                programmes.push(power);
            }
            if !offers {
                // Nothing within reach decides: the next test says so, with no power claimed.
                assert!(t["power"].is_null() && t["specimens"].is_null(), "{t}");
            }
        }
    }
    eprintln!(
        "decidable {decides}: named {named}, intervals hold {inside}; undecidable {open}: not named {not_named}, \
         with a next test {with_test}; shear named {shear_named}; {} solver runs for {} cases ({})",
        family_runs::runs(),
        decides + open,
        sampling()
    );
    assert!(
        decides >= 6 && open >= 4,
        "too few cases in a class: {decides} / {open}"
    );
    assert!(named * 10 >= decides * 9, "{named} of {decides}");
    assert!(inside * 10 >= named * 8, "{inside} of {named}");
    assert!(not_named * 10 >= open * 8, "{not_named} of {open}");
    assert!(with_test * 2 >= open, "{with_test} of {open}");
    assert_eq!(shear_named, 0);
    // A programme offered is one that would decide: lab states power ≥ 90 % at the fitted numbers
    // and over their uncertainty; under the truth its power may fall below that (the fitted numbers
    // are the noisy tests'), but a programme more likely to fail than to decide is a false promise.
    // (Before the loop models' emulator error was counted, programmes built on differences within
    // it had a power of 0.03 to 0.35 under the truth in 10 of 14 offers.)
    eprintln!(
        "programmes offered: {}, power under the truth {programmes:.2?}",
        programmes.len()
    );
    assert!(programmes.iter().all(|&p| p >= 0.5), "{programmes:?}");
    family_runs::assert_a_third_of(FIXED_DESIGN);
}
