//! The cantilever of the paper (Sec. 3) and facts.md: Euler simulation, Timoshenko tests.

use std::time::Instant;

use nalgebra::{DMatrix, DVector};

use super::*;
use crate::emulate::gp;

const F: f64 = 600.0;
const B: f64 = 2.0;
const NU: f64 = 0.36;
const E0: f64 = 68_000.0;

fn euler(d: &[f64], th: &[f64]) -> f64 {
    let l = th.get(1).copied().unwrap_or(20.0);
    4.0 * F * l.powi(3) / (th[0] * B * d[0].powi(3))
}

fn timoshenko(h: f64) -> f64 {
    euler(&[h], &[E0]) + F * 20.0 * (4.0 + 5.0 * NU) / (2.0 * E0 * B * h)
}

fn problem<'a>(hs: &[f64], measured: Vec<f64>, bounds: Bounds, model: &'a dyn super::super::Model) -> Problem<'a> {
    Problem {
        designs: DMatrix::from_column_slice(hs.len(), 1, hs),
        measured: DVector::from_vec(measured),
        bounds,
        model,
    }
}

fn design_bounds() -> Bounds {
    Bounds::new(vec![7.0], vec![13.0])
}

fn e_bounds() -> Bounds {
    Bounds::new(vec![50_000.0], vec![80_000.0])
}

fn run(p: &Problem, settings: &Settings) -> BayesianFit {
    let sim = emulator_samples(p, &design_bounds(), settings);
    calibrate(p, &design_bounds(), &sim, settings).unwrap()
}

fn cantilever_fit(seed: u64) -> BayesianFit {
    cantilever_fit_with(Settings {
        seed,
        ..Settings::default()
    })
}

fn cantilever_fit_with(settings: Settings) -> BayesianFit {
    let model = euler;
    let hs = [8.0, 10.0];
    let p = problem(&hs, hs.iter().map(|&h| timoshenko(h)).collect(), e_bounds(), &model);
    run(&p, &settings)
}

/// A short chain: enough for reproducibility checks, quick in debug builds.
fn short(seed: u64) -> Settings {
    Settings {
        seed,
        mcmc_steps: 300,
        mcmc_burn_in: 100,
        ..Settings::default()
    }
}

#[test]
fn cantilever_matches_paper() {
    let t0 = Instant::now();
    let fit = cantilever_fit(1);
    let secs = t0.elapsed().as_secs_f64();
    let e = fit.theta[0];
    let (lo, hi) = fit.interval95[0];
    eprintln!(
        "E = {e:.1}, median {:.1}, mean {:.1}, 95 % [{lo:.1}, {hi:.1}], {:?}, {secs:.3} s",
        fit.median[0], fit.mean[0], fit.quadrature
    );
    // Paper: 64,911; the exact KOH answer is 64,913.9 and the emulator's own error moves it.
    assert!((e / 64_911.0 - 1.0).abs() < 0.015, "E = {e}");
    assert!(lo < 64_911.0 && 64_911.0 < hi, "[{lo}, {hi}]");
    // The bias-corrected prediction reproduces the training tests (the discrepancy interpolates).
    for h in [8.0, 10.0] {
        let rel = (fit.predict(&[h]) / timoshenko(h) - 1.0).abs();
        assert!(rel < 1e-3, "h = {h}: {rel}");
    }
}

/// A short chain, sampled even for one parameter, with no extension past 300 steps.
fn sampled(seed: u64) -> Settings {
    Settings {
        quadrature_max_params: 0,
        mcmc_max_steps: 300,
        ..short(seed)
    }
}

#[test]
fn seeded_and_reproducible() {
    let (a, b, c) = (
        cantilever_fit_with(sampled(1)),
        cantilever_fit_with(sampled(1)),
        cantilever_fit_with(sampled(2)),
    );
    assert_eq!(a.median, b.median);
    assert_eq!(a.theta, b.theta);
    assert_eq!(a.posterior, b.posterior);
    assert_eq!(a.interval95, b.interval95);
    assert_ne!(a.posterior, c.posterior);
}

#[test]
fn perfect_model_recovers_e() {
    // Tests from the simulation itself at E = 70,000: no discrepancy, so θ̂ must find E.
    let model = euler;
    let hs = [8.0, 10.0, 12.0];
    let p = problem(
        &hs,
        hs.iter().map(|&h| euler(&[h], &[70_000.0])).collect(),
        e_bounds(),
        &model,
    );
    let fit = run(&p, &short(1));
    eprintln!("perfect model: E = {:.1}, 95 % {:?}", fit.theta[0], fit.interval95[0]);
    assert!((fit.theta[0] / 70_000.0 - 1.0).abs() < 0.01, "E = {}", fit.theta[0]);
}

#[test]
fn two_parameters_stay_finite_and_inside() {
    // Table 1: E and L together; only L³/E is identifiable, so only sanity is checked.
    let model = euler;
    let hs = [8.0, 10.0, 12.0];
    let bounds = Bounds::new(vec![50_000.0, 18.0], vec![80_000.0, 22.0]);
    let p = problem(&hs, hs.iter().map(|&h| timoshenko(h)).collect(), bounds.clone(), &model);
    let fit = run(&p, &short(1));
    eprintln!(
        "two parameters: θ = {:?}, 95 % {:?}",
        fit.theta.as_slice(),
        fit.interval95
    );
    for k in 0..2 {
        let inside = |v: f64| v.is_finite() && bounds.lower[k] <= v && v <= bounds.upper[k];
        assert!(inside(fit.theta[k]) && inside(fit.median[k]), "{k}: {}", fit.theta[k]);
        assert!(inside(fit.interval95[k].0) && inside(fit.interval95[k].1));
    }
    assert!(fit.posterior.iter().all(|v| v.is_finite()));
    assert!(fit.predict(&[13.0]).is_finite());
}

/// Table 1 with the paper's box: E in [50k, 80k], L in [15, 25], h = 8, 10, 12, 24 emulator runs.
fn table1_fit(settings: &Settings) -> BayesianFit {
    let model = euler;
    let hs = [8.0, 10.0, 12.0];
    let bounds = Bounds::new(vec![50_000.0, 15.0], vec![80_000.0, 25.0]);
    let p = problem(&hs, hs.iter().map(|&h| timoshenko(h)).collect(), bounds, &model);
    run(&p, settings)
}

#[test]
fn table1_predicts_validation() {
    // The response spans a factor ~47 over (h, E, L); emulated in logs it is exact, so the
    // prediction error is KOH's own. Measured: +1.33 % at h = 13 for every seed 1–8 (θ moves along
    // the L³/E ridge; sensitivity gives +1.63 %, the emulator in y gave +14.7 %), training < 1e-9. Bounds: 3 % at the validation design (extrapolation of the discrepancy GP past
    // h = 12 carries most of the error), 1 % at the training designs (the discrepancy interpolates).
    let fit = table1_fit(&short(1));
    let valid = fit.predict(&[13.0]) / 0.083942 - 1.0;
    eprintln!(
        "table 1: θ = {:?}, h = 13: {:+.2} %",
        fit.theta.as_slice(),
        100.0 * valid
    );
    assert!(valid.abs() < 0.03, "h = 13: {valid}");
    for h in [8.0, 10.0, 12.0] {
        let rel = fit.predict(&[h]) / timoshenko(h) - 1.0;
        assert!(rel.abs() < 0.01, "h = {h}: {rel}");
    }
}

#[test]
fn negative_response_falls_back_to_y() {
    // Simulation and tests both shifted by −0.2: the deflection changes sign over the box, so the
    // emulator stays in y; the shift cancels in the residuals, so E is the cantilever's again.
    let model = |d: &[f64], th: &[f64]| euler(d, th) - 0.2;
    let hs = [8.0, 10.0];
    let p = problem(
        &hs,
        hs.iter().map(|&h| timoshenko(h) - 0.2).collect(),
        e_bounds(),
        &model,
    );
    let fit = run(&p, &short(1));
    eprintln!(
        "negative response: E = {:.1}, 95 % {:?}",
        fit.theta[0], fit.interval95[0]
    );
    assert!(!fit.emulator.log_output());
    assert!((fit.theta[0] / 64_911.0 - 1.0).abs() < 0.015, "E = {}", fit.theta[0]);
}

#[test]
fn one_design_is_too_few() {
    let model = euler;
    let p = problem(&[8.0], vec![timoshenko(8.0)], e_bounds(), &model);
    let sim = emulator_samples(&p, &design_bounds(), &Settings::default());
    let err = calibrate(&p, &design_bounds(), &sim, &Settings::default()).unwrap_err();
    assert!(
        matches!(
            err,
            CalibrationError::TooFewDesigns {
                needed: 2,
                given: 1,
                ..
            }
        ),
        "{err:?}"
    );
}

/// Spread of θ̂ over emulator designs (`cargo test --release -- --ignored --nocapture`).
#[test]
#[ignore]
fn spread_over_seeds() {
    let mut worst: f64 = 0.0;
    for seed in 1..=30 {
        let fit = cantilever_fit(seed);
        let rel = fit.theta[0] / 64_913.9 - 1.0;
        worst = worst.max(rel.abs());
        eprintln!(
            "seed {seed}: E = {:.1} ({:+.3} %), median {:.1}, 95 % [{:.1}, {:.1}]",
            fit.theta[0],
            100.0 * rel,
            fit.median[0],
            fit.interval95[0].0,
            fit.interval95[0].1
        );
    }
    eprintln!("worst {:.3} %", 100.0 * worst);
}

/// MCMC error of the interval: spread of the 2.5/97.5 % points over seeds for several chain
/// shapes, and the time of a whole calibrate (ignored, diagnostic; run with --test-threads=1).
#[test]
#[ignore]
fn long_chain_interval() {
    const SEEDS: u64 = 16;
    let model = euler;
    let hs = [8.0, 10.0];
    let p = problem(&hs, hs.iter().map(|&h| timoshenko(h)).collect(), e_bounds(), &model);
    for (walkers, steps, burn_in) in [(16, 2000, 500), (32, 3000, 500), (16, 20_000, 2000)] {
        let (mut lo, mut hi, mut secs) = (Vec::new(), Vec::new(), 0.0);
        for seed in 1..=SEEDS {
            let s = Settings {
                seed,
                mcmc_walkers: walkers,
                mcmc_steps: steps,
                mcmc_burn_in: burn_in,
                ..Settings::default()
            };
            let t0 = Instant::now();
            let fit = run(&p, &s);
            secs += t0.elapsed().as_secs_f64() / SEEDS as f64;
            lo.push(fit.interval95[0].0);
            hi.push(fit.interval95[0].1);
        }
        let range = |v: &[f64]| {
            (
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(0.0, f64::max),
            )
        };
        let sd = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
        };
        eprintln!(
            "{walkers} x {steps} (burn {burn_in}): 2.5 % in {:.0?} (sd {:.0}), 97.5 % in {:.0?} (sd {:.0}), {secs:.3} s",
            range(&lo),
            sd(&lo),
            range(&hi),
            sd(&hi)
        );
    }
}

#[test]
fn two_design_variables() {
    // Honeycomb-shaped problem: designs (c, t), one parameter σ0, mean stress 16.5 σ0 (t/c)^(5/3);
    // tests from the model itself at σ0 = 185 plus a 3 % bias, four designs.
    let model = |d: &[f64], th: &[f64]| 16.5 * th[0] * (d[1] / d[0]).powf(5.0 / 3.0);
    let designs = DMatrix::from_row_slice(4, 2, &[6.0, 0.05, 3.0, 0.07, 3.0, 0.08, 4.5, 0.06]);
    let measured = DVector::from_fn(4, |i, _| 1.03 * model(&[designs[(i, 0)], designs[(i, 1)]], &[185.0]));
    let p = Problem {
        designs,
        measured,
        bounds: Bounds::new(vec![100.0], vec![200.0]),
        model: &model,
    };
    let db = Bounds::new(vec![3.0, 0.05], vec![6.0, 0.08]);
    // 40 runs: with 24 in three inputs the emulator is off by up to 2.7 % at the corner design
    // (3, 0.08), which moves θ̂ by about 3 %.
    let settings = Settings {
        emulator_samples: 40,
        ..Settings::default()
    };
    let sim = emulator_samples(&p, &db, &settings);
    let fit = calibrate(&p, &db, &sim, &settings).unwrap();
    eprintln!(
        "two design variables: σ0 = {:.2}, 95 % {:?}",
        fit.theta[0], fit.interval95[0]
    );
    // The bias is proportional, so σ0 = 1.03 · 185 = 190.55 explains the tests with no discrepancy.
    assert!((fit.theta[0] / 190.55 - 1.0).abs() < 0.02, "{}", fit.theta[0]);
    let (lo, hi) = fit.interval95[0];
    assert!(100.0 <= lo && lo <= hi && hi <= 200.0);
    let y = fit.predict(&[4.0, 0.065]);
    assert!(y.is_finite() && y > 0.0);
}

/// Table 1 over emulator designs and chains (ignored, diagnostic).
#[test]
#[ignore]
fn table1_over_seeds() {
    for seed in 1..=8 {
        let fit = table1_fit(&Settings {
            seed,
            ..Settings::default()
        });
        let train = [8.0, 10.0, 12.0]
            .iter()
            .map(|&h| (fit.predict(&[h]) / timoshenko(h) - 1.0).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "seed {seed}: θ = [{:.0}, {:.3}], h = 13: {:+.2} %, training max {:.1e} %",
            fit.theta[0],
            fit.theta[1],
            100.0 * (fit.predict(&[13.0]) / 0.083942 - 1.0),
            100.0 * train
        );
    }
}

/// Stage times (ignored, diagnostic): emulator fit, ML, sampling.
#[test]
#[ignore]
fn stage_times() {
    let model = euler;
    let hs = [8.0, 10.0];
    let p = problem(&hs, hs.iter().map(|&h| timoshenko(h)).collect(), e_bounds(), &model);
    let s = Settings::default();
    let sim = emulator_samples(&p, &design_bounds(), &s);
    let b = joint_bounds(&design_bounds(), &p.bounds);
    let t0 = Instant::now();
    let emu = gp::Emulator::fit(&sim.inputs, &sim.outputs, &b).unwrap();
    let t1 = Instant::now();
    let koh = koh::Koh::new(&emu, &p, &design_bounds()).unwrap();
    let (u, _) = koh.fit_ml(7);
    let t2 = Instant::now();
    let n = 10_000;
    for _ in 0..n {
        std::hint::black_box(koh.cost(&u, koh::Trend::Marginal));
    }
    let t3 = Instant::now();
    eprintln!(
        "emulator {:.4} s, ML {:.4} s, one likelihood {:.2} µs",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        (t3 - t2).as_secs_f64() / n as f64 * 1e6
    );
}

/// Stage times of a honeycomb-shaped problem (two design variables, two tests, 36 runs; ignored).
#[test]
#[ignore]
fn stage_times_two_design_variables() {
    let model = |d: &[f64], th: &[f64]| 16.5 * th[0] * (d[1] / d[0]).powf(5.0 / 3.0) * (1.0 + 0.02 * d[0]);
    let designs = DMatrix::from_row_slice(2, 2, &[6.0, 0.05, 3.0, 0.08]);
    let measured = DVector::from_fn(2, |i, _| {
        1.1 * model(&[designs[(i, 0)], designs[(i, 1)]], &[185.0]) * (1.0 + 0.03 * i as f64)
    });
    let p = Problem {
        designs,
        measured,
        bounds: Bounds::new(vec![100.0], vec![250.0]),
        model: &model,
    };
    let db = Bounds::new(vec![3.0, 0.05], vec![6.0, 0.08]);
    let s = Settings {
        emulator_samples: 36,
        ..Settings::default()
    };
    let sim = emulator_samples(&p, &db, &s);
    let t0 = Instant::now();
    let emu = gp::Emulator::fit(&sim.inputs, &sim.outputs, &joint_bounds(&db, &p.bounds)).unwrap();
    let t1 = Instant::now();
    let koh = koh::Koh::new(&emu, &p, &db).unwrap();
    let (u, _) = koh.fit_ml(7);
    let t2 = Instant::now();
    let post = exact::posterior(&koh, &u);
    let t3 = Instant::now();
    eprintln!(
        "emulator {:.4} s, ML {:.4} s, quadrature {:.4} s ({:?})",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        (t3 - t2).as_secs_f64(),
        post.summary
    );
}

/// Three identifiable parameters: bending, shear and offset terms, y = a·1e3/h³ + b/h + c, against
/// Timoshenko tests at five designs.
fn three_parameter_problem<'a>(model: &'a dyn super::super::Model) -> Problem<'a> {
    let hs = [7.0, 8.0, 10.0, 12.0, 13.0];
    let bounds = Bounds::new(vec![50.0, 0.0, -0.05], vec![150.0, 0.5, 0.05]);
    problem(&hs, hs.iter().map(|&h| timoshenko(h)).collect(), bounds, model)
}

fn three_parameter_model(d: &[f64], th: &[f64]) -> f64 {
    th[0] * 1e3 / d[0].powi(3) + th[1] / d[0] + th[2]
}

#[test]
fn three_parameters_are_sampled_with_diagnostics() {
    // Three parameters go to the sampler, which extends its chains until split R-hat ≤ 1.01 and
    // ESS ≥ 1000 for every parameter or its budget ends (here a wide, prior-bounded posterior:
    // measured R-hat 1.016–1.024, ESS 1700–2400 at the default 20,000 steps); either way the
    // flags agree with the figures and the interval lies inside the bounds.
    let model = three_parameter_model;
    let p = three_parameter_problem(&model);
    let settings = Settings {
        emulator_samples: 40,
        mcmc_max_steps: 4000,
        ..Settings::default()
    };
    let fit = run(&p, &settings);
    eprintln!(
        "three parameters: {:?}, {:?}, {} steps",
        fit.interval95, fit.sampler.convergence, fit.sampler.steps
    );
    assert!(fit.quadrature.is_none() && fit.sampler.convergence.len() == 3);
    let all = fit.sampler.convergence.iter().all(|c| c.converged());
    assert!(all || fit.sampler.steps == 4000, "{} steps", fit.sampler.steps);
    for (k, &(lo, hi)) in fit.interval95.iter().enumerate() {
        assert!(
            p.bounds.lower[k] <= lo && lo < hi && hi <= p.bounds.upper[k],
            "{k}: [{lo}, {hi}]"
        );
    }
}

#[test]
fn sampler_budget_ends_unconverged() {
    // A 60-step budget cannot reach ESS 1000 with 32 walkers: reported so.
    let model = three_parameter_model;
    let p = three_parameter_problem(&model);
    let settings = Settings {
        emulator_samples: 40,
        mcmc_steps: 60,
        mcmc_burn_in: 0,
        mcmc_max_steps: 60,
        ..Settings::default()
    };
    let fit = run(&p, &settings);
    assert_eq!(fit.sampler.steps, 60);
    assert!(
        fit.sampler.convergence.iter().any(|c| !c.converged()),
        "{:?}",
        fit.sampler.convergence
    );
}

/// The scale case: a cantilever of depth h and length L (two design variables) under F at L − a,
/// with four parameters: E (bending), G (shear), C_r (root rotation of a compliant clamp) and a (the
/// load point's offset). `δ = 4Fℓ³/(E b h³) + Fℓ/(κ G b h) + 4Fℓ²/(C_r b h²)`, ℓ = L − a, κ = 5/6.
pub(super) fn four_parameter_cantilever(d: &[f64], th: &[f64]) -> f64 {
    let (h, l) = (d[0], d[1] - th[3]);
    4.0 * F * l.powi(3) / (th[0] * B * h.powi(3))
        + F * l / (5.0 / 6.0 * th[1] * B * h)
        + 4.0 * F * l * l / (th[2] * B * h * h)
}

/// Eight tested designs of the scale case, its parameter box and its tests: the model at
/// E = 68,000, G = 26,000, C_r = 200,000, a = 0.3 with 0.3 % seeded scatter.
fn four_parameter_problem<'a>(model: &'a dyn super::super::Model) -> (Problem<'a>, Bounds) {
    four_parameter_problem_seeded(model, 13)
}

/// [`four_parameter_problem`] with the tests' scatter drawn from `seed`.
fn four_parameter_problem_seeded<'a>(model: &'a dyn super::super::Model, seed: u64) -> (Problem<'a>, Bounds) {
    use rand::{Rng, SeedableRng};
    let designs = [
        [7.0, 15.0],
        [7.0, 30.0],
        [10.0, 20.0],
        [13.0, 15.0],
        [13.0, 30.0],
        [8.0, 25.0],
        [12.0, 22.0],
        [10.0, 28.0],
    ];
    let truth = [68_000.0, 26_000.0, 200_000.0, 0.3];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut gauss = || {
        let (u, v): (f64, f64) = (rng.random(), rng.random());
        (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let measured: Vec<f64> = designs
        .iter()
        .map(|d| four_parameter_cantilever(d, &truth) * (1.0 + 0.003 * gauss()))
        .collect();
    let p = Problem {
        designs: DMatrix::from_fn(8, 2, |i, k| designs[i][k]),
        measured: DVector::from_vec(measured),
        bounds: Bounds::new(
            vec![50_000.0, 15_000.0, 50_000.0, -1.0],
            vec![80_000.0, 40_000.0, 500_000.0, 1.0],
        ),
        model,
    };
    (p, Bounds::new(vec![7.0, 15.0], vec![13.0, 30.0]))
}

/// How the cost grows with the number of simulation runs (ignored, diagnostic; `--nocapture`):
/// the four-parameter cantilever ([`four_parameter_cantilever`]), eight tested designs, n
/// Latin-hypercube runs over (design, parameters). Prints the emulator fit's time, one evaluation
/// of the sampled density (hyperparameters integrated), and the time and convergence of a whole
/// calibration with the default sampler, which stops on convergence (`SCALE_RUNS=100,200` picks
/// the sizes).
#[test]
#[ignore]
fn scale_growth() {
    let model = four_parameter_cantilever;
    let (p, db) = four_parameter_problem(&model);
    let ns: Vec<usize> = std::env::var("SCALE_RUNS")
        .map(|v| v.split(',').map(|s| s.parse().unwrap()).collect())
        .unwrap_or(vec![100, 200, 400]);
    for n in ns {
        let s = Settings {
            emulator_samples: n,
            ..Settings::default()
        };
        let sim = emulator_samples(&p, &db, &s);
        let t0 = Instant::now();
        let emu = gp::Emulator::fit(&sim.inputs, &sim.outputs, &joint_bounds(&db, &p.bounds)).unwrap();
        let fit_s = t0.elapsed().as_secs_f64();
        let koh = koh::Koh::new(&emu, &p, &db).unwrap();
        let marginal = exact::Marginal::new(&koh);
        let t1 = Instant::now();
        for _ in 0..100 {
            std::hint::black_box(marginal.log_density(&[0.5; 4]));
        }
        let lik_s = t1.elapsed().as_secs_f64() / 100.0;
        let t2 = Instant::now();
        let fit = calibrate(&p, &db, &sim, &s).unwrap();
        let cal_s = t2.elapsed().as_secs_f64();
        if let Ok(dump) = std::env::var("SCALE_DUMP") {
            let rows: Vec<String> = fit
                .posterior
                .row_iter()
                .map(|r| r.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(","))
                .collect();
            std::fs::write(format!("{dump}-{n}.csv"), rows.join("\n")).unwrap();
        }
        eprintln!(
            "n = {n}: emulator fit {fit_s:.2} s, one density {:.3} ms, calibrate {cal_s:.1} s ({} steps, {} evaluations), θ̂ {:?}, 95 % {:?}, {:?}",
            1e3 * lik_s,
            fit.sampler.steps,
            fit.sampler.evaluations,
            fit.theta.as_slice(),
            fit.interval95,
            fit.sampler.convergence
        );
    }
}

/// The sampler on fresh data (ignored, diagnostic; `--nocapture`): the four-parameter cantilever's
/// tests drawn again with scatter seeds 101–106 (`FRESH_SEEDS=101,102` picks them), 400 runs,
/// default settings. Prints per seed the run's steps, acceptance, evaluations, convergence, time
/// and which 95 % intervals hold the truth; fails if a run ends unconverged.
#[test]
#[ignore]
fn scale_fresh_data() {
    let model = four_parameter_cantilever;
    let seeds: Vec<u64> = std::env::var("FRESH_SEEDS")
        .map(|v| v.split(',').map(|s| s.parse().unwrap()).collect())
        .unwrap_or((101..=106).collect());
    let truth = [68_000.0, 26_000.0, 200_000.0, 0.3];
    let s = Settings {
        emulator_samples: 400,
        ..Settings::default()
    };
    let mut unconverged = vec![];
    for seed in seeds {
        let (p, db) = four_parameter_problem_seeded(&model, seed);
        let sim = emulator_samples(&p, &db, &s);
        let t0 = Instant::now();
        let fit = calibrate(&p, &db, &sim, &s).unwrap();
        let secs = t0.elapsed().as_secs_f64();
        let covered: Vec<bool> = fit
            .interval95
            .iter()
            .zip(truth)
            .map(|(&(lo, hi), t)| lo < t && t < hi)
            .collect();
        let converged = fit.sampler.convergence.iter().all(|c| c.converged());
        eprintln!(
            "seed {seed}: {secs:.1} s, {} steps, acceptance {:.2}, {} evaluations, powers {:?}, R-hat ≤ {:.3}, ESS ≥ {:.0}, truth inside {covered:?}",
            fit.sampler.steps,
            fit.sampler.acceptance,
            fit.sampler.evaluations,
            fit.sampler.sampling_powers,
            fit.sampler.convergence.iter().map(|c| c.split_rhat).fold(0.0, f64::max),
            fit.sampler
                .convergence
                .iter()
                .map(|c| c.ess)
                .fold(f64::INFINITY, f64::min),
        );
        if !converged {
            unconverged.push(seed);
        }
    }
    assert!(unconverged.is_empty(), "unconverged: {unconverged:?}");
}
