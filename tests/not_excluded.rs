//! Issue 53 item 4: what "no model error" leaves open, read from solver runs over the amplitude.
//! The stand-in `clamped_beam` (examples/clamped_beam.rs, a closed form run as a program) with a
//! clamp compliance kr hidden in the tests, drawn here from a seeded generator over a family of
//! beams small enough that the tests often cannot detect it; the study lists the clamp as an
//! extension (kr in [0, 1]). Through `lab run`, for every draw:
//!
//! - where lab says no model error, the clamp's open range is read from the solver run over kr
//!   (`not_excluded[].runs`: the baseline and at least one kr > 0, each at every tested design),
//!   and it agrees with an oracle sharing no code with lab — the exact closed form's profile
//!   likelihood-ratio interval over kr, the parameter E refitted at each kr, under the noise's form
//!   lab estimated from the replicates;
//! - the truth lies inside the open range; where model error is detected, the clamp is named or
//!   among the leading candidates, unless the tests themselves put it out (the exact clamped beam,
//!   fitted to them, misses them or gains from a leading shape at α: a level-α event for the
//!   truth, allowed once); no other cause is ever named.
//!
//! The open range's ends are asserted within a twentieth of the exact interval's width of its ends
//! (lab reads the profile through its emulator's slope and a linear interpolation between the
//! values run at). `LAB_OPEN_SEED_BASE` moves the draws.

use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::beam_common;
use beam_common::{bending, clamp};

const E: f64 = 68_000.0;
/// The specimens' relative scatter.
const CV: f64 = 0.005;

/// The study: tests at E with a clamp of compliance `kr`, three specimens at each depth 7 … 13 mm
/// (drawn from `seed`), the clamp listed as an extension.
fn write_study(dir: &Path, kr: f64, seed: u64) -> std::path::PathBuf {
    let hs: Vec<f64> = (7..=13).map(f64::from).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let z = Normal::new(0.0, 1.0).unwrap();
    let mut csv = String::from("design,h,deflection\n");
    for h in &hs {
        for _ in 0..3 {
            let y = (bending(*h) + kr * clamp(*h)) / E * (1.0 + CV * z.sample(&mut rng));
            csv.push_str(&format!("h{h},{h},{y:e}\n"));
        }
    }
    std::fs::write(dir.join("tests.csv"), csv).unwrap();
    beam_common::write_template(dir);
    let names: Vec<String> = hs.iter().map(|h| format!("h{h}")).collect();
    let study = format!(
        "{}\
         \x20 sampling: {{method: lhs, count: 8, seed: 1, check_runs: 3}}\n\
         \x20 surrogate: quadratic\n\
         experiments: {{file: tests.csv, response: deflection, unit: mm}}\n\
         training: [{}]\n\
         calibration: {{methods: [least_squares]}}\n\
         diagnosis:\n  hypotheses:\n    - name: clamp compliance\n      extension: {{kr: {{min: 0, max: 1}}}}\n",
        beam_common::study_head("open", (7.0, 13.0)),
        names.join(", "),
    );
    let path = dir.join("open.yaml");
    std::fs::write(&path, study).unwrap();
    path
}

/// The oracle, sharing no code with lab: the exact model y = (bending(h) + kr·clamp(h))·u, u = 1/E,
/// fitted to the drawn tests (`dir/tests.csv`) by weighted least squares in u at each kr on a grid
/// of 10,000 over [0, 1]; the kr whose χ² is within t²(1 − α/2, ν) of the least, at the level `alpha`
/// of one of the verdict's K amplitude tests (α/(2K): the range says what the verdict says). The noise is the
/// form lab estimated from the replicates (`noise`: σ² = a² + (b·y)² on ν degrees of freedom, read
/// from results.json; its estimate is the noise families' to check), each mean's variance σ²/3.
fn exact_interval(dir: &Path, noise: &serde_json::Value, alpha: f64) -> [f64; 2] {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let (means, w, nu) = weighted_means(dir, noise);
    let chi2 = |kr: f64| {
        let a: Vec<f64> = means.iter().map(|(h, _, _)| bending(*h) + kr * clamp(*h)).collect();
        let u = (0..a.len()).map(|i| w[i] * a[i] * means[i].1).sum::<f64>()
            / (0..a.len()).map(|i| w[i] * a[i] * a[i]).sum::<f64>();
        (0..a.len())
            .map(|i| w[i] * (means[i].1 - a[i] * u).powi(2))
            .sum::<f64>()
    };
    let grid: Vec<(f64, f64)> = (0..=10_000)
        .map(|i| i as f64 / 10_000.0)
        .map(|k| (k, chi2(k)))
        .collect();
    let least = grid.iter().map(|g| g.1).fold(f64::INFINITY, f64::min);
    let t = StudentsT::new(0.0, 1.0, nu).unwrap().inverse_cdf(1.0 - alpha / 2.0);
    let open: Vec<f64> = grid.iter().filter(|g| g.1 - least <= t * t).map(|g| g.0).collect();
    [open[0], open[open.len() - 1]]
}

/// The drawn tests' means by depth `(h, mean, specimens)`, their weights (one over each mean's
/// variance σ²/n under the noise's form lab estimated, σ² = a² + (b·y)²) and that noise's degrees
/// of freedom ν.
fn weighted_means(dir: &Path, noise: &serde_json::Value) -> (Vec<(f64, f64, usize)>, Vec<f64>, f64) {
    let means: Vec<(f64, f64, usize)> = (beam_common::specimens(dir).iter())
        .map(|(h, ys)| (*h, ys.iter().sum::<f64>() / ys.len() as f64, ys.len()))
        .collect();
    let (a, b) = (noise["absolute"].as_f64().unwrap(), noise["relative"].as_f64().unwrap());
    let w = (means.iter())
        .map(|(_, m, n)| *n as f64 / (a * a + (b * m).powi(2)))
        .collect();
    (means, w, noise["dof"].as_f64().unwrap())
}

/// Whether the drawn tests themselves, read through the exact closed form under the noise lab
/// estimated, put the hidden clamp out at level `alpha`: the exact clamped-beam model (1/E and
/// kr/E fitted) misses them (its χ² on n − 2 degrees of freedom against F(n − 2, ν)), or a
/// `leading` shape still reduces its misfit (F on 1 and ν). Each is an event of probability at most
/// α for the truth however well lab works.
fn tests_reject_the_clamp(dir: &Path, noise: &serde_json::Value, leading: &[&str], alpha: f64) -> bool {
    use statrs::distribution::{ContinuousCDF, FisherSnedecor};
    let (means, w, nu) = weighted_means(dir, noise);
    let (hs, ys): (Vec<f64>, Vec<f64>) = means.iter().map(|(h, y, _)| (*h, *y)).unzip();
    let chi2 = |shapes: &[fn(f64) -> f64]| beam_common::wls_chi2(&hs, &ys, &w, shapes);
    let clamped = chi2(&[bending, clamp]);
    let dof = hs.len() - 2;
    let misses = FisherSnedecor::new(dof as f64, nu).expect("dof > 0");
    let adds = FisherSnedecor::new(1.0, nu).expect("dof > 0");
    let p_fit = 1.0 - misses.cdf(clamped / dof as f64);
    (leading.iter().filter_map(|l| beam_common::closed_form(l)))
        .map(|shape| 1.0 - adds.cdf(clamped - chi2(&[bending, clamp, shape])))
        .chain([p_fit])
        .any(|p| p < alpha)
}

#[test]
fn no_model_error_reads_what_it_leaves_open_from_solver_runs_over_the_amplitude() {
    let base: u64 = std::env::var("LAB_OPEN_SEED_BASE").map_or(0, |s| s.parse().expect("a seed base"));
    let mut rng = ChaCha8Rng::seed_from_u64(4_053 + base);
    let (mut said, mut out_by_the_tests) = (Vec::new(), 0);
    for draw in 0..12 {
        let kr = 0.03 * rng.random::<f64>();
        let dir = tempfile::tempdir().unwrap();
        let study = write_study(dir.path(), kr, 4_100 + base + draw);
        let (stderr, results) = beam_common::lab_run(&study, &dir.path().join("out"));
        let d = &results["diagnosis"];
        let verdict = d["verdict"].as_str().unwrap_or_default().to_string();
        assert!(
            d["cause"].is_null() || d["cause"] == "clamp compliance",
            "{}",
            d["cause"]
        );
        if verdict != "no_model_error" {
            // Model error detected: the clamp is named, or among the candidates left standing.
            let leading: Vec<&str> = (d["leading"].as_array().unwrap().iter())
                .filter_map(|l| l.as_str())
                .collect();
            said.push(format!("kr {kr:.4}: {verdict}, leading {leading:?}"));
            if d["cause"] != "clamp compliance" && !leading.contains(&"clamp compliance") {
                // Out of the leading set only where the tests themselves put it out.
                let alpha = d["levels"]["alpha"].as_f64().expect("α");
                assert!(
                    tests_reject_the_clamp(dir.path(), &d["noise"], &leading, alpha),
                    "{}",
                    d["summary"]
                );
                out_by_the_tests += 1;
                said.push("  (the exact clamped beam, fitted to these tests, is out at α)".into());
            }
            continue;
        }
        let open = &d["not_excluded"][0];
        assert_eq!(open["hypothesis"], "clamp compliance", "{stderr}");
        let runs = open["runs"].as_array().expect("runs over the amplitude");
        assert!(
            runs.len() >= 2 && runs.iter().any(|r| r["amplitude"]["kr"].as_f64() > Some(0.0)),
            "{open}"
        );
        let range = &open["amplitude"]["kr"];
        let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
        // The level the verdict tests each of its K candidates at: α/2 shared over them.
        let k = d["candidates"].as_array().expect("candidates").len() as f64;
        let alpha_k = d["levels"]["candidates"].as_f64().expect("the candidates' level") / k;
        let [a, b] = exact_interval(dir.path(), &d["noise"], alpha_k);
        said.push(format!(
            "kr {kr:.4}: [{lo:.4}, {hi:.4}], exact [{a:.4}, {b:.4}], {} values run",
            runs.len()
        ));
        assert!(lo <= kr && kr <= hi, "the truth {kr} outside [{lo}, {hi}]");
        let width = b - a;
        assert!(
            (lo - a).abs() <= 0.05 * width && (hi - b).abs() <= 0.05 * width,
            "[{lo}, {hi}] against the exact [{a}, {b}]: {open:#} {:#} {:#}",
            d["noise"],
            d["confirmation"]
        );
        assert!(
            d["summary"]
                .as_str()
                .unwrap()
                .contains("read from the solver run at kr = 0"),
            "{}",
            d["summary"]
        );
    }
    eprintln!("{}", said.join("\n"));
    // The exact model's fit test and one per leading shape (two or three lead), each at α = 0.01:
    // at most 0.04 per draw, so two or more of the twelve draws with probability at most 8.1 %, and
    // only the draws where model error is detected count.
    assert!(
        out_by_the_tests <= 1,
        "the tests put the hidden clamp out of the leading set in {out_by_the_tests} draws"
    );
}
