//! Clean families: tests made from the model itself with few replicates, no model error. Whatever
//! the noise model decides, the diagnosis may not call the model wrong, and the library search may
//! not "discover" a term, at a rate beyond the diagnosis's α = 0.01 (a binomial test of the counts).
//!
//! A family draws, from a seed, the parameter's truth, the noise (a coefficient of variation, and
//! for one family a constant σ), two or three replicates per design, and whether the study lists
//! hypotheses; it makes the tests and hands the diagnosis only the data. Only this file knows the
//! draw. With two or three replicates per design the replicates cannot tell a constant σ from a
//! constant coefficient of variation: a diagnosis that picks one by likelihood calls the model
//! wrong whenever the draw favours the wrong form (about one draw in sixty on the cantilever).
//!
//! The families run on the seeds the rules were developed on (`LAB_NOISE_SEED_BASE`, default 0) and
//! CI runs them again on a base drawn once and never tuned on (`.ci/run`: 613,979, drawn with
//! `python3 -c 'import secrets; print(secrets.randbelow(10**6))'`).

use lab::calibrate::Bounds;
use lab::diagnose::discover::Outcome;
use lab::diagnose::{self, Inputs, Observation, Role, Settings, Shape, Space};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Draws per family.
const DRAWS: u64 = 400;

fn seed_base() -> u64 {
    std::env::var("LAB_NOISE_SEED_BASE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// The paper's cantilever with shear (Timoshenko), E calibrated: F = 600, L = 20, b = 2, ν = 0.36.
fn cantilever(d: &[f64], th: &[f64]) -> f64 {
    let (f, l, b, nu, h, e): (f64, f64, f64, f64, f64, f64) = (600.0, 20.0, 2.0, 0.36, d[0], th[0]);
    4.0 * f * l.powi(3) / (e * b * h.powi(3)) + f * l * (4.0 + 5.0 * nu) / (2.0 * e * b * h)
}

/// Mean crush force of a honeycomb Y junction (Wierzbicki): 8.61 σ t^(5/3) / c^(1/3).
fn honeycomb(d: &[f64], th: &[f64]) -> f64 {
    8.61 * th[0] * d[0].powf(5.0 / 3.0) / d[1].powf(1.0 / 3.0)
}

struct Family {
    name: &'static str,
    model: fn(&[f64], &[f64]) -> f64,
    designs: Vec<Vec<f64>>,
    design_names: Vec<&'static str>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    parameter: (&'static str, f64, f64),
    /// The terms a study might list.
    terms: Vec<&'static str>,
    /// Proportional noise (else a constant σ).
    proportional: bool,
}

fn families() -> Vec<Family> {
    let cantilever_family = |proportional| Family {
        name: if proportional {
            "cantilever, proportional noise"
        } else {
            "cantilever, constant noise"
        },
        model: cantilever,
        designs: (0..9).map(|i| vec![7.0 + 0.75 * i as f64]).collect(),
        design_names: vec!["h"],
        lower: vec![7.0],
        upper: vec![13.0],
        parameter: ("E", 50_000.0, 90_000.0),
        terms: vec!["1/h", "1/h^2", "1"],
        proportional,
    };
    let mut grid = Vec::new();
    for t in [0.5, 0.8, 1.2] {
        for c in [3.0, 6.0, 10.0] {
            grid.push(vec![t, c]);
        }
    }
    vec![
        cantilever_family(true),
        Family {
            name: "honeycomb-like, proportional noise",
            model: honeycomb,
            designs: grid,
            design_names: vec!["t", "c"],
            lower: vec![0.5, 3.0],
            upper: vec![1.2, 10.0],
            parameter: ("sigma", 100.0, 300.0),
            terms: vec!["1/c", "t^2", "1"],
            proportional: true,
        },
        cantilever_family(false),
    ]
}

/// The diagnosis of one draw: truth, noise, replicates, listed hypotheses; discovery on as
/// `diagnosis.discover: true` runs it.
fn diagnose_draw(f: &Family, salt: u64, seed: u64) -> diagnose::Diagnosis {
    let mut rng = ChaCha8Rng::seed_from_u64((seed ^ 0x0c1ea4).wrapping_mul(31).wrapping_add(salt));
    let (pname, lo, hi) = f.parameter;
    let truth = rng.random_range(lo + 0.2 * (hi - lo)..hi - 0.2 * (hi - lo));
    let cv = rng.random_range(0.005..0.03);
    let level = f.designs.iter().map(|d| (f.model)(d, &[truth])).sum::<f64>() / f.designs.len() as f64;
    let observations: Vec<Observation> = f
        .designs
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let mu = (f.model)(d, &[truth]);
            let sd = if f.proportional { cv * mu } else { cv * level };
            let n = rng.random_range(2..=3);
            let reps: Vec<f64> = (0..n)
                .map(|_| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    mu + sd * z
                })
                .collect();
            Observation::from_replicates(format!("d{i}"), d.clone(), Role::Training, &reps)
        })
        .collect();
    let names: Vec<String> = f.design_names.iter().map(|s| s.to_string()).collect();
    let listed = rng.random_bool(0.5);
    let hypotheses: Vec<Shape> = if listed {
        f.terms
            .iter()
            .enumerate()
            .map(|(k, t)| Shape::from_term(format!("H{k}"), t, &names, &[pname.to_string()], &[]).unwrap())
            .collect()
    } else {
        Vec::new()
    };
    let model = f.model;
    let inputs = Inputs {
        observations,
        model: &model,
        space: Space {
            parameter_names: vec![pname.to_string()],
            parameter_bounds: Bounds::new(vec![lo], vec![hi]),
            design_names: names,
            design_bounds: Bounds::new(f.lower.clone(), f.upper.clone()),
        },
        hypotheses,
        settings: Settings::default(),
        library: Some(Default::default()),
        built_ins: None,
        features: None,
        emulator: Default::default(),
    };
    diagnose::diagnose(&inputs).expect("the diagnosis runs")
}

/// The chance of `k` or more false claims in `n` draws were each made at the level α = 0.01: the
/// one-sided binomial test of "the rate is within the level".
fn beyond_the_level(k: usize, n: u64) -> f64 {
    use statrs::distribution::{Binomial, DiscreteCDF};
    if k == 0 {
        1.0
    } else {
        Binomial::new(0.01, n).unwrap().sf(k as u64 - 1)
    }
}

/// Each clean family: model error claimed, and a term discovered, at a rate within the level α =
/// 0.01 — each count, and the families' pooled count, not beyond α by a one-sided binomial test at
/// 0.001 (an observed share above 1 % is no evidence of a rate above it: at a true rate of exactly
/// 1 %, 400 draws give 5 or more in 37 % of runs; the test allows up to 11 of 400, and 24 of the
/// 1,200 pooled).
#[test]
fn clean_families_with_few_replicates_claim_no_model_error() {
    let mut failures = Vec::new();
    let mut pooled = (0, 0);
    for (salt, f) in families().into_iter().enumerate() {
        let (mut detected, mut discovered, mut switched) = (Vec::new(), Vec::new(), 0);
        for i in 0..DRAWS {
            let seed = seed_base() + i;
            let d = diagnose_draw(&f, salt as u64, seed);
            if d.finding.discrepancy_detected {
                eprintln!(
                    "{} seed {seed}: {}\n  noise: {}",
                    f.name, d.finding.headline, d.record.noise.note
                );
                detected.push(seed);
            }
            if d.checked
                .discovered
                .as_ref()
                .is_some_and(|x| x.found.outcome == Outcome::Found)
            {
                discovered.push(seed);
            }
            switched += usize::from(d.record.noise.note.contains("not claimed on the noise model's account"));
        }
        eprintln!(
            "{}: model error claimed {}/{DRAWS} {detected:?}, term discovered {}/{DRAWS} {discovered:?}; the noise \
             model's set of mixings spared the model in {switched}",
            f.name,
            detected.len(),
            discovered.len()
        );
        if beyond_the_level(detected.len(), DRAWS) < 1e-3 || beyond_the_level(discovered.len(), DRAWS) < 1e-3 {
            failures.push(f.name);
        }
        pooled = (pooled.0 + detected.len(), pooled.1 + discovered.len());
    }
    assert!(
        failures.is_empty(),
        "false claims beyond the level α = 0.01 in {failures:?}"
    );
    let draws = DRAWS * families().len() as u64;
    assert!(
        beyond_the_level(pooled.0, draws) >= 1e-3 && beyond_the_level(pooled.1, draws) >= 1e-3,
        "pooled over the families, model error claimed {} and a term discovered {} times in {draws}: beyond α = 0.01",
        pooled.0,
        pooled.1
    );
}

/// One draw's data and diagnosis (`FAMILY`, `SEED`), for a look.
#[test]
#[ignore]
fn debug_one() {
    let k: usize = std::env::var("FAMILY").unwrap().parse().unwrap();
    let seed: u64 = std::env::var("SEED").unwrap().parse().unwrap();
    let f = &families()[k];
    let d = diagnose_draw(f, k as u64, seed);
    for r in &d.record.residuals {
        eprintln!(
            "{} mean {} sd {:?} n {} pred {} z {}",
            r.design, r.test.measured, r.test.std_dev, r.test.count, r.predicted, r.z
        );
    }
    eprintln!("{}", d.record.summary);
}
