//! Hidden-effect tests. A generator draws, from a seed, a hidden model error out of a family and a
//! magnitude, makes "measured" data with replicate noise (absolute or relative, drawn), and hands
//! the diagnosis only what an engineer would have: the data, the base model, and candidate terms
//! under neutral names in shuffled order. Only this file knows what was hidden.
//!
//! Whether the data *can* tell the hidden shape apart is not assumed: an oracle in this file,
//! independent of lab's fitting code, computes it from the noise-free truth and the true noise by
//! projections (the linearised least-squares algebra of the tests the diagnosis should make). For
//! a hidden shape h, weighted effect e and weighted sensitivities J at the true θ:
//! - detect = ‖(I − P_J) e‖² − ‖(I − P_[J,h]) e‖², the noncentrality of "h beats a refit of θ";
//! - enc(r) = ‖(I − P_[J,r]) e‖² − ‖(I − P_[J,h,r]) e‖², of "h still counts with rival r in";
//! - remaining = ‖(I − P_[J,h]) e‖² plus the validation designs' predictive z², what the right
//!   shape's model leaves (a saturation's first-order term y² is not the saturation itself).
//!
//! A case is *separable* when detect and every enc(r) are ≥ 30 (power > 0.95 for tests at α/K and α)
//! and lab's lack-of-fit tests reject the right shape's model with a chance of at most 0.05 (a
//! bound from what it leaves, [`fit_rejected`]); *inseparable* when detect or some enc(r) is ≤ 1
//! (power ≈ α); anything between is not asserted. A separable case whose own tests reject the
//! truth's model ([`data_reject`]: a level-α test does so about α of the time) is set aside, and
//! the family asserts that such cases are no more than those bounds allow (a Poisson-binomial tail
//! of 0.001). The assertions are the issue's: the right cause in ≥ 9/10 of separable cases,
//! with the extended parameters within 3 % of the truth; no named cause and a next test in ≥ 9/10
//! of inseparable cases; "partly explained" in ≥ 9/10 of effects outside the hypotheses; no false
//! alarm in ≥ 9/10 of clean cases. Every family also asserts that enough of its seeds fell in the
//! class it was built for, so that no assertion passes on an empty class.

use crate::power_common;
use crate::verdict_common;

use lab::calibrate::Bounds;
use lab::diagnose::verdict::Verdict;
use lab::diagnose::{self, Diagnosis, Inputs, Observation, Role, Settings, Shape, Space};
use nalgebra::{DMatrix, DVector};
use power_common::{power_at, power_f};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use statrs::distribution::{ContinuousCDF, FisherSnedecor, StudentsT};

const SEEDS: u64 = 10;

/// The first seed of every family: 0, or `LAB_DIAGNOSE_SEED_BASE` to run the same families on seeds
/// nobody has looked at (the assertions stay the same).
fn seed_base() -> u64 {
    std::env::var("LAB_DIAGNOSE_SEED_BASE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// One parameter: name, bounds, truth.
#[derive(Clone, Copy)]
struct Param {
    name: &'static str,
    lo: f64,
    hi: f64,
    truth: f64,
}

/// The experimental set-up of a family: the base model, its designs and the candidate terms.
#[derive(Clone)]
struct Setup {
    design_names: Vec<&'static str>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    train: Vec<Vec<f64>>,
    val: Vec<Vec<f64>>,
    params: Vec<Param>,
    model: fn(&[f64], &[f64]) -> f64,
    pool: Vec<&'static str>,
    replicates: usize,
    /// Range of the noise's coefficient of variation.
    cv: (f64, f64),
}

impl Setup {
    fn truth(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.truth).collect()
    }
    fn names(&self) -> Vec<String> {
        self.design_names.iter().map(|s| s.to_string()).collect()
    }
    fn param_names(&self) -> Vec<String> {
        self.params.iter().map(|p| p.name.to_string()).collect()
    }
    fn shape(&self, name: &str, term: &str) -> Shape {
        Shape::from_term(name.to_string(), term, &self.names(), &self.param_names(), &[]).unwrap()
    }
}

/// Honeycomb crush force of one Y junction (Wierzbicki): F = 8.61 σ t^(5/3) / c^(1/3), σ calibrated.
fn honeycomb(d: &[f64], th: &[f64]) -> f64 {
    8.61 * th[0] * d[0].powf(5.0 / 3.0) / d[1].powf(1.0 / 3.0)
}

/// The same with the exponent of t calibrated instead (σ = 185 known): a scale error is identifiable.
fn honeycomb_exponent(d: &[f64], th: &[f64]) -> f64 {
    8.61 * 185.0 * d[0].powf(th[0]) / d[1].powf(1.0 / 3.0)
}

/// Two parameters calibrated together: σ and the exponent of t.
fn honeycomb_two(d: &[f64], th: &[f64]) -> f64 {
    8.61 * th[0] * d[0].powf(th[1]) / d[1].powf(1.0 / 3.0)
}

/// The paper's cantilever, Timoshenko (bending + shear), E calibrated: F = 600, L = 20, b = 2, ν = 0.36.
fn timoshenko(d: &[f64], th: &[f64]) -> f64 {
    let (f, l, b, nu, h, e): (f64, f64, f64, f64, f64, f64) = (600.0, 20.0, 2.0, 0.36, d[0], th[0]);
    4.0 * f * l.powi(3) / (e * b * h.powi(3)) + f * l * (4.0 + 5.0 * nu) / (2.0 * e * b * h)
}

const POOL: [&str; 13] = [
    "1", "y", "y^2", "t^0.5", "t^2", "t^3", "1/t", "c^0.5", "c^2", "1/c", "t*c", "t/c", "c/t",
];

fn sigma_param() -> Param {
    Param {
        name: "sigma",
        lo: 100.0,
        hi: 300.0,
        truth: 185.0,
    }
}

/// A 4 × 3 training grid over t ∈ [0.5, 1.6], c ∈ [3, 10] and four validation designs beyond it.
fn honeycomb_setup(model: fn(&[f64], &[f64]) -> f64, params: Vec<Param>, replicates: usize) -> Setup {
    let mut train = Vec::new();
    for t in [0.5, 0.75, 1.1, 1.6] {
        for c in [3.0, 5.5, 10.0] {
            train.push(vec![t, c]);
        }
    }
    Setup {
        design_names: vec!["t", "c"],
        lower: vec![0.5, 3.0],
        upper: vec![2.0, 12.0],
        train,
        val: vec![vec![2.0, 3.0], vec![2.0, 8.0], vec![0.5, 12.0], vec![1.3, 12.0]],
        params,
        model,
        pool: POOL.to_vec(),
        replicates,
        cv: (0.005, 0.015),
    }
}

/// The example with precise tests (0.1–0.3 % scatter: deflections read by a dial gauge):
/// the replicates can then separate 1/h² from 1/h and from a change of E.
fn precise_cantilever_setup() -> Setup {
    Setup {
        cv: (0.001, 0.003),
        ..cantilever_setup()
    }
}

/// The example: h = 7 … 13, three replicates each, hypotheses 1/h, 1/h², constant.
fn cantilever_setup() -> Setup {
    Setup {
        design_names: vec!["h"],
        lower: vec![7.0],
        upper: vec![13.0],
        train: (7..=13).map(|h| vec![h as f64]).collect(),
        val: vec![],
        params: vec![Param {
            name: "E",
            lo: 50_000.0,
            hi: 90_000.0,
            truth: 68_000.0,
        }],
        model: timoshenko,
        pool: vec!["1/h", "1/h^2", "1"],
        replicates: 3,
        cv: (0.005, 0.015),
    }
}

/// What is hidden.
#[derive(Clone, Copy, Debug)]
enum Hidden {
    None,
    /// A term of the pool, additive: y + a·g.
    Term(&'static str),
    /// y / (1 + y/Y): its first-order term is y² (in the pool).
    Saturation,
    /// An effect outside every candidate, as a function of the design.
    Outside(fn(&[f64]) -> f64),
}

/// A drawn case: the observations, the candidates under neutral names, and (for the oracle) the truth.
struct Case {
    obs: Vec<Observation>,
    hypotheses: Vec<Shape>,
    /// The neutral name of the hidden term (None: no effect, or outside the pool).
    hidden: Option<String>,
    hidden_term: Option<&'static str>,
    /// Noise-free mean response at each training design, and σ of one test there.
    mu: Vec<f64>,
    sigma: Vec<f64>,
    /// The same at each validation design.
    mu_val: Vec<f64>,
    sigma_val: Vec<f64>,
    noise_relative: bool,
    magnitude: f64,
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Draws the effect's magnitude (a fraction of the mean training level where the shape is largest),
/// its sign, the noise, the replicates and the neutral names.
fn generate(setup: &Setup, hidden: Hidden, magnitude: (f64, f64), seed: u64, salt: u64) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed * 7919 + salt);
    let theta = setup.truth();
    let model = setup.model;
    let level = setup.train.iter().map(|d| model(d, &theta)).sum::<f64>() / setup.train.len() as f64;
    let ymax = setup.train.iter().map(|d| model(d, &theta)).fold(0.0, f64::max);
    // Log-uniform magnitude: families span small and large effects evenly.
    let m = (magnitude.0.ln() + rng.random::<f64>() * (magnitude.1.ln() - magnitude.0.ln())).exp();
    let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let term_shape = |t: &str| setup.shape("hidden", t);
    let truth = |d: &[f64]| -> f64 {
        let y = model(d, &theta);
        match hidden {
            Hidden::None => y,
            Hidden::Saturation => y / (1.0 + y / (ymax * (1.0 - m) / m)),
            Hidden::Term(t) => {
                let g = term_shape(t);
                let gmax = setup
                    .train
                    .iter()
                    .map(|e| g.eval(e, &theta, model(e, &theta)).abs())
                    .fold(0.0, f64::max);
                y + sign * m * level * g.eval(d, &theta, y) / gmax
            }
            Hidden::Outside(f) => {
                let gmax = setup.train.iter().map(|e| f(e).abs()).fold(0.0, f64::max);
                y + sign * m * level * f(d) / gmax
            }
        }
    };
    let noise_relative = rng.random_bool(0.5);
    let cv: f64 = rng.random_range(setup.cv.0..setup.cv.1);
    let sd = |mu: f64| if noise_relative { cv * mu.abs() } else { cv * level };
    let mut obs = Vec::new();
    let designs = setup
        .train
        .iter()
        .map(|d| (d, Role::Training))
        .chain(setup.val.iter().map(|d| (d, Role::Validation)));
    for (k, (d, role)) in designs.enumerate() {
        let mu = truth(d);
        let reps: Vec<f64> = (0..setup.replicates).map(|_| mu + sd(mu) * gauss(&mut rng)).collect();
        obs.push(Observation::from_replicates(format!("d{k}"), d.clone(), role, &reps));
    }
    let mut terms = setup.pool.clone();
    terms.shuffle(&mut rng);
    let names: Vec<String> = (1..=terms.len()).map(|i| format!("H{i}")).collect();
    let hypotheses = terms.iter().zip(&names).map(|(t, n)| setup.shape(n, t)).collect();
    let hidden_term = match hidden {
        Hidden::Term(t) => Some(t),
        Hidden::Saturation => Some("y^2"),
        _ => None,
    };
    let hidden = hidden_term.map(|h| names[terms.iter().position(|t| *t == h).expect("in the pool")].clone());
    let mu: Vec<f64> = setup.train.iter().map(|d| truth(d)).collect();
    let sigma = mu.iter().map(|&m| sd(m)).collect();
    let mu_val: Vec<f64> = setup.val.iter().map(|d| truth(d)).collect();
    let sigma_val = mu_val.iter().map(|&m| sd(m)).collect();
    Case {
        obs,
        hypotheses,
        hidden,
        hidden_term,
        mu,
        sigma,
        mu_val,
        sigma_val,
        noise_relative,
        magnitude: m,
    }
}

fn run(setup: &Setup, case: &Case) -> Diagnosis {
    let model = setup.model;
    let inputs = Inputs {
        observations: case.obs.clone(),
        model: &model,
        space: Space {
            parameter_names: setup.param_names(),
            parameter_bounds: Bounds::new(
                setup.params.iter().map(|p| p.lo).collect(),
                setup.params.iter().map(|p| p.hi).collect(),
            ),
            design_names: setup.names(),
            design_bounds: Bounds::new(setup.lower.clone(), setup.upper.clone()),
        },
        hypotheses: case.hypotheses.clone(),
        settings: Settings::default(),
        library: None,
        built_ins: None,
        features: None,
        emulator: Default::default(),
    };
    let d = diagnose::diagnose(&inputs).expect("diagnosis runs");
    verdict_common::assert_verdict_follows_evidence(&serde_json::to_value(&d).unwrap());
    d
}

// ---- The oracle: linear algebra on the truth, nothing from lab's fits. ----

/// ‖v − X X⁺ v‖².
fn leftover(x: &[&DVector<f64>], v: &DVector<f64>) -> f64 {
    left(x, v).0.norm_squared()
}

/// v − X X⁺ v, the leverages h_ii of X (the hat matrix's diagonal, from the left singular vectors
/// of X's numerical column space), and the least-squares coefficients X⁺ v.
fn left(x: &[&DVector<f64>], v: &DVector<f64>) -> (DVector<f64>, Vec<f64>, DVector<f64>) {
    if x.is_empty() {
        return (v.clone(), vec![0.0; v.len()], DVector::zeros(0));
    }
    let m = DMatrix::from_columns(&x.iter().map(|c| (*c).clone()).collect::<Vec<_>>());
    let svd = m.clone().svd(true, true);
    let tol = 1e-10 * svd.singular_values.max();
    let coef = svd.solve(v, tol).unwrap();
    let u = svd.u.as_ref().unwrap();
    let leverage = (0..v.len())
        .map(|i| {
            (0..svd.singular_values.len())
                .filter(|&k| svd.singular_values[k] > tol)
                .map(|k| u[(i, k)].powi(2))
                .sum()
        })
        .collect();
    (v - m * &coef, leverage, coef)
}

#[derive(Debug, Clone, Copy)]
struct Truth {
    detect: f64,
    enc_min: f64,
    remaining: f64,
    /// A bound on the probability that lab's lack-of-fit tests reject the hidden term's own model
    /// ([`fit_rejected`]); 0 without a hidden term.
    rejected: f64,
    /// The tests in hand reject the hidden term's own model ([`data_reject`]); false without one.
    data_reject: bool,
    /// The smallest misfit any single candidate leaves (outside effects).
    best_remaining: f64,
    /// The largest detection noncentrality of any candidate.
    best_detect: f64,
    /// How many candidates lab sees (the pool and the built-ins).
    candidates: usize,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Class {
    Separable,
    /// Separable by the truth, but the tests in hand reject the truth's own model: a level-α test
    /// does that with probability about α; lab then rightly calls the cause partial.
    TruthRejected,
    Inseparable,
    Between,
}

fn oracle(setup: &Setup, case: &Case) -> Truth {
    let theta = setup.truth();
    let model = setup.model;
    let n = setup.train.len();
    let w: Vec<f64> = case
        .sigma
        .iter()
        .map(|s| (setup.replicates as f64).sqrt() / s)
        .collect();
    let y: Vec<f64> = setup.train.iter().map(|d| model(d, &theta)).collect();
    let e = DVector::from_fn(n, |i, _| w[i] * (case.mu[i] - y[i]));
    let jac: Vec<DVector<f64>> = (0..theta.len())
        .map(|j| {
            let h = 1e-6 * theta[j].abs().max(1e-6);
            DVector::from_fn(n, |i, _| {
                let (mut up, mut dn) = (theta.clone(), theta.clone());
                up[j] += h;
                dn[j] -= h;
                w[i] * (model(&setup.train[i], &up) - model(&setup.train[i], &dn)) / (2.0 * h)
            })
        })
        .collect();
    let vector = |term: &str| {
        let g = setup.shape("g", term);
        DVector::from_fn(n, |i, _| w[i] * g.eval(&setup.train[i], &theta, y[i]))
    };
    // The candidates lab will see: the pool plus its built-ins (1, y, each design variable).
    let mut terms: Vec<String> = setup.pool.iter().map(|s| s.to_string()).collect();
    for b in ["1".to_string(), "y".to_string()].into_iter().chain(setup.names()) {
        if !terms.contains(&b) {
            terms.push(b);
        }
    }
    let j: Vec<&DVector<f64>> = jac.iter().collect();
    let base = leftover(&j, &e);
    let with = |extra: &[&DVector<f64>]| {
        let mut cols = j.clone();
        cols.extend_from_slice(extra);
        leftover(&cols, &e)
    };
    let vectors: Vec<(String, DVector<f64>)> = terms.iter().map(|t| (t.clone(), vector(t))).collect();
    let best_remaining = vectors.iter().map(|(_, v)| with(&[v])).fold(f64::INFINITY, f64::min);
    let best_detect = vectors.iter().map(|(_, v)| base - with(&[v])).fold(0.0, f64::max);
    let Some(h) = case.hidden_term else {
        return Truth {
            detect: 0.0,
            enc_min: 0.0,
            remaining: base,
            rejected: 0.0,
            data_reject: false,
            best_remaining,
            best_detect,
            candidates: vectors.len(),
        };
    };
    let hv = vector(h);
    // The hidden term's model leaves this much at the training designs, and lab's lack of fit also
    // reads the validation designs' predictions: what the model fitted to the training truth
    // misses there (a saturation's first-order term, y², extrapolated beyond the training range).
    let sigma: Vec<f64> = case.sigma.iter().chain(&case.sigma_val).copied().collect();
    let w_all: Vec<f64> = sigma.iter().map(|s| (setup.replicates as f64).sqrt() / s).collect();
    let mu: Vec<f64> = case.mu.iter().chain(&case.mu_val).copied().collect();
    let truth_left = Leftover::of(setup, h, &w_all, &mu);
    let remaining = truth_left.chi2();
    // Without replicates lab has no lack-of-fit test against a noise of the tests' own.
    let replicated = noise_dof(setup) > 0.0;
    let rejected = if replicated {
        fit_rejected(setup, &truth_left)
    } else {
        0.0
    };
    let enc_min = vectors
        .iter()
        .filter(|(t, v)| {
            t != h && (hv.normalize() - v.normalize()).norm() > 1e-9 && (hv.normalize() + v.normalize()).norm() > 1e-9
        })
        .map(|(_, v)| with(&[v]) - with(&[&hv, v]))
        .fold(f64::INFINITY, f64::min);
    Truth {
        detect: base - remaining,
        enc_min,
        remaining,
        rejected,
        data_reject: replicated && data_reject(setup, case, h),
        best_remaining,
        best_detect,
        candidates: vectors.len(),
    }
}

/// A bound on the probability that lab's lack-of-fit tests of a cause's model (both at α, see
/// src/diagnose/lack_of_fit.rs) reject the model of the hidden term itself, from what that model
/// leaves of the noise-free truth: the omnibus F(dof, ν) on the noncentrality it leaves, plus each
/// standardised residual's t(ν) test at Šidák's level (a union bound). At no leftover it is about
/// 2α, the rate the module notes of lab's test state.
fn fit_rejected(setup: &Setup, left: &Leftover) -> f64 {
    let alpha: f64 = 0.01;
    let (dof, nu) = (left.dof(setup.params.len() + 1), noise_dof(setup));
    let z = left.standardised();
    let single = 1.0 - (1.0 - alpha).powf(1.0 / z.len() as f64);
    power_f(left.chi2(), dof, nu, alpha) + z.iter().map(|z| power_at(z * z, nu, single)).sum::<f64>()
}

/// What the hidden term's model leaves: θ and the term's amplitude (linearised at the truth, as the
/// rest of the oracle) fitted by least squares weighted by `w` (√n / σ of each design, training then
/// validation) to the means `y` at the training designs.
struct Leftover {
    /// The weighted training residuals.
    r: DVector<f64>,
    /// Their leverages in the fit.
    leverage: Vec<f64>,
    /// Each validation design's predictive z: (mean − prediction) / √(σ² of its mean + the
    /// prediction's variance), as lab's predictive check reads it.
    z_val: DVector<f64>,
}

impl Leftover {
    fn of(setup: &Setup, h: &str, w: &[f64], y: &[f64]) -> Leftover {
        let (n, theta) = (setup.train.len(), setup.truth());
        let model = setup.model;
        let x = columns(setup, &setup.train, &w[..n], h);
        let e = DVector::from_fn(n, |i, _| w[i] * (y[i] - model(&setup.train[i], &theta)));
        let cols: Vec<DVector<f64>> = x.column_iter().map(|c| c.into_owned()).collect();
        let (r, leverage, coef) = left(&cols.iter().collect::<Vec<_>>(), &e);
        let xv = columns(setup, &setup.val, &w[n..], h);
        let inverse = (x.transpose() * &x).pseudo_inverse(1e-12).unwrap();
        let z_val = DVector::from_fn(setup.val.len(), |i, _| {
            let row = xv.row(i);
            let miss = w[n + i] * (y[n + i] - model(&setup.val[i], &theta)) - (row * &coef)[(0, 0)];
            miss / (1.0 + (row * &inverse * row.transpose())[(0, 0)]).sqrt()
        });
        Leftover { r, leverage, z_val }
    }

    /// Σ of the squared training residuals and validation z: the omnibus χ²'s numerator.
    fn chi2(&self) -> f64 {
        self.r.norm_squared() + self.z_val.norm_squared()
    }

    /// The standardised residuals: r_i / √(1 − h_ii) (a design the fit passes through exactly
    /// left out), then the validation z.
    fn standardised(&self) -> Vec<f64> {
        self.r
            .iter()
            .zip(&self.leverage)
            .filter(|(_, h)| 1.0 - *h > 1e-9)
            .map(|(r, h)| r / (1.0 - h).sqrt())
            .chain(self.z_val.iter().copied())
            .collect()
    }

    /// The omnibus test's degrees of freedom, `k` the fitted columns.
    fn dof(&self, k: usize) -> f64 {
        (self.r.len() + self.z_val.len()).saturating_sub(k) as f64
    }
}

/// Columns ∂y/∂θ_j, then the term `h`, at each design, at the truth; rows weighted by `w`.
fn columns(setup: &Setup, designs: &[Vec<f64>], w: &[f64], h: &str) -> DMatrix<f64> {
    let (theta, model, g) = (setup.truth(), setup.model, setup.shape("g", h));
    let p = theta.len();
    DMatrix::from_fn(designs.len(), p + 1, |i, j| {
        let d = &designs[i];
        if j < p {
            let step = 1e-6 * theta[j].abs().max(1e-6);
            let (mut up, mut dn) = (theta.clone(), theta.clone());
            up[j] += step;
            dn[j] -= step;
            w[i] * (model(d, &up) - model(d, &dn)) / (2.0 * step)
        } else {
            w[i] * g.eval(d, &theta, model(d, &theta))
        }
    })
}

/// The noise's degrees of freedom: every design's replicates, training and validation.
fn noise_dof(setup: &Setup) -> f64 {
    ((setup.train.len() + setup.val.len()) * (setup.replicates - 1)) as f64
}

/// Whether the tests in hand reject the hidden term's own model, read as lab's lack-of-fit tests
/// of a cause's model read it (src/diagnose/lack_of_fit.rs, both at α): the omnibus F(dof, ν) and
/// the largest standardised residual's t(ν) at Šidák's level. The noise is the replicates' own
/// (pooled under the noise form they support, [`replicate_sigma`]); the model is the truth's
/// family, so a rejection is the data's, at about the rate [`fit_rejected`] bounds.
fn data_reject(setup: &Setup, case: &Case, h: &str) -> bool {
    let alpha: f64 = 0.01;
    let sigma = replicate_sigma(case);
    let w: Vec<f64> = sigma.iter().map(|s| (setup.replicates as f64).sqrt() / s).collect();
    let y: Vec<f64> = case.obs.iter().map(|o| o.mean).collect();
    let left = Leftover::of(setup, h, &w, &y);
    let (dof, nu) = (left.dof(setup.params.len() + 1), noise_dof(setup));
    let omnibus = FisherSnedecor::new(dof, nu).unwrap().sf(left.chi2() / dof);
    let z = left.standardised();
    let largest = z.iter().fold(0.0_f64, |m, z| m.max(z.abs()));
    let single = 2.0 * StudentsT::new(0.0, 1.0, nu).unwrap().sf(largest);
    let sidak = 1.0 - (1.0 - single).powf(z.len() as f64);
    omnibus < alpha || sidak < alpha
}

fn classify(t: &Truth) -> Class {
    if t.detect >= 30.0 && t.enc_min >= 30.0 && t.rejected <= 0.05 {
        if t.data_reject {
            Class::TruthRejected
        } else {
            Class::Separable
        }
    } else if t.detect <= 1.0 || t.enc_min <= 1.0 {
        Class::Inseparable
    } else {
        Class::Between
    }
}

fn named_right(case: &Case, d: &Diagnosis) -> bool {
    d.finding.verdict == Verdict::CauseNamed && d.finding.cause.is_some() && d.finding.cause == case.hidden
}

fn extended_within(setup: &Setup, d: &Diagnosis, tol: f64) -> bool {
    d.explained.extended.as_ref().is_some_and(|x| {
        setup
            .params
            .iter()
            .all(|p| (x.model.parameters[p.name] / p.truth - 1.0).abs() <= tol)
    })
}

fn line(family: &str, seed: u64, case: &Case, t: &Truth, d: &Diagnosis) -> String {
    let term = |n: &str| {
        d.explained
            .candidates
            .iter()
            .find(|c| c.shape.name == n)
            .map(|c| c.shape.term.clone())
            .unwrap_or_default()
    };
    format!(
        "{family} seed {seed}: hidden {:?} m {:.4} rel-noise {} | oracle detect {:.1} enc {:.1} rem {:.1} rejected {:.3} best-rem {:.1} ({:?}) \
         | {:?} cause {:?} ({}) leading {:?} | ext {:?}",
        case.hidden_term,
        case.magnitude,
        case.noise_relative,
        t.detect,
        t.enc_min,
        t.remaining,
        t.rejected,
        t.best_remaining,
        classify(t),
        d.finding.verdict,
        d.finding.cause,
        d.finding.cause.as_deref().map(term).unwrap_or_default(),
        d.finding.leading,
        d.explained.extended.as_ref().map(|x| x
            .model
            .parameters
            .values()
            .map(|v| (v * 1000.0).round() / 1000.0)
            .collect::<Vec<_>>())
    )
}

/// The chance of at least `k` successes among independent trials with these probabilities (the
/// Poisson-binomial tail, by its exact recursion; a probability above 1 counts as 1).
fn at_least(p: &[f64], k: usize) -> f64 {
    let mut dist = vec![1.0];
    for &q in p {
        let q = q.min(1.0);
        let mut next = vec![0.0; dist.len() + 1];
        for (j, d) in dist.iter().enumerate() {
            next[j] += d * (1.0 - q);
            next[j + 1] += d * q;
        }
        dist = next;
    }
    dist.iter().skip(k).sum()
}

/// At least 9 in 10.
fn nine_in_ten(good: usize, of: usize) -> bool {
    good * 10 >= of * 9
}

/// Runs a family of in-pool hidden terms and asserts by oracle class. `min_class`: how many seeds
/// must fall in the class the family was built for.
fn in_pool_family(
    family: &str,
    setup: &Setup,
    draw: impl Fn(&mut ChaCha8Rng) -> Hidden,
    magnitude: (f64, f64),
    built_for: Class,
    salt: u64,
) {
    let mut counts = [(0usize, 0usize); 2]; // (right, of) for separable, inseparable
    let mut within = (0usize, 0usize);
    let mut seeds = 0;
    // Each separable case's bound on the chance that the tests reject the truth's own model, and
    // the cases where they did.
    let (mut bounds, mut truth_rejected) = (Vec::new(), Vec::new());
    // Seeds until ten fall in the class the family was built for, at most ten times as many: the
    // class's share of the draws is the generator's luck, not lab's (the large root rotation's: 9
    // of 40 on seed base 808,080): at a share of 22.5 % a hundred draws fall short of ten with a
    // chance of 0.0003 (binomial), forty with 0.59.
    let intended = |c: &[(usize, usize); 2]| if built_for == Class::Separable { c[0].1 } else { c[1].1 };
    while intended(&counts) < SEEDS as usize && seeds < 10 * SEEDS {
        let seed = seed_base() + seeds;
        seeds += 1;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed ^ salt);
        let hidden = draw(&mut rng);
        let case = generate(setup, hidden, magnitude, seed, salt);
        let d = run(setup, &case);
        let t = oracle(setup, &case);
        eprintln!("{}", line(family, seed, &case, &t, &d));
        if matches!(classify(&t), Class::Separable | Class::TruthRejected) {
            bounds.push(t.rejected);
        }
        match classify(&t) {
            Class::Separable => {
                counts[0].1 += 1;
                if named_right(&case, &d) {
                    counts[0].0 += 1;
                    within.1 += 1;
                    within.0 += usize::from(extended_within(setup, &d, 0.03));
                }
            }
            Class::Inseparable => {
                counts[1].1 += 1;
                counts[1].0 += usize::from(d.finding.cause.is_none() && d.explained.next_test.is_some());
            }
            Class::TruthRejected => truth_rejected.push(t.rejected),
            Class::Between => {}
        }
    }
    eprintln!(
        "{family}: {seeds} seeds; separable named {:?}, inseparable unnamed {:?}, extended within 3 % {within:?}; \
         the tests reject the truth in {} more",
        counts[0],
        counts[1],
        truth_rejected.len()
    );
    assert!(
        intended(&counts) >= SEEDS as usize,
        "{family}: only {} of {seeds} seeds in the class it was built for",
        intended(&counts)
    );
    assert!(
        nine_in_ten(counts[0].0, counts[0].1),
        "{family}: right cause in {:?} separable cases",
        counts[0]
    );
    // The cases set aside because the tests reject the truth are no more than the bounds allow.
    let chance = at_least(&bounds, truth_rejected.len());
    assert!(
        chance >= 1e-3,
        "{family}: the tests reject the truth's own model in {} of {} separable cases, a chance of {chance:.2e}",
        truth_rejected.len(),
        bounds.len()
    );
    assert!(
        nine_in_ten(counts[1].0, counts[1].1),
        "{family}: no cause named in {:?} inseparable cases",
        counts[1]
    );
    assert!(
        nine_in_ten(within.0, within.1),
        "{family}: extended parameters within 3 % in {within:?}"
    );
}

fn pick(rng: &mut ChaCha8Rng, terms: &[&'static str]) -> Hidden {
    Hidden::Term(terms[rng.random_range(0..terms.len())])
}

#[test]
fn constant_offset_is_named() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    in_pool_family("offset", &s, |_| Hidden::Term("1"), (0.08, 0.2), Class::Separable, 1);
}

#[test]
fn power_law_in_a_design_variable_is_named() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    let terms = ["t^0.5", "t^2", "t^3", "1/t", "c^0.5", "c^2", "1/c"];
    in_pool_family("power", &s, |r| pick(r, &terms), (0.15, 0.3), Class::Separable, 2);
}

#[test]
fn saturation_is_named() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    in_pool_family(
        "saturation",
        &s,
        |_| Hidden::Saturation,
        (0.06, 0.15),
        Class::Separable,
        3,
    );
}

#[test]
fn interaction_is_named() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    in_pool_family(
        "interaction",
        &s,
        |_| Hidden::Term("t*c"),
        (0.08, 0.2),
        Class::Separable,
        4,
    );
}

#[test]
fn identifiable_scale_error_is_named() {
    let p = Param {
        name: "a",
        lo: 1.0,
        hi: 2.5,
        truth: 5.0 / 3.0,
    };
    let s = honeycomb_setup(honeycomb_exponent, vec![p], 3);
    in_pool_family(
        "scale (exponent base)",
        &s,
        |_| Hidden::Term("y"),
        (0.15, 0.3),
        Class::Separable,
        5,
    );
}

/// F ∝ σ: a scale error is exactly a change of σ. The oracle finds it inseparable; the diagnosis
/// names no cause and says the scale term cannot be told from σ.
#[test]
fn scale_error_on_a_multiplicative_parameter_is_not_named() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    in_pool_family(
        "scale (sigma base)",
        &s,
        |_| Hidden::Term("y"),
        (0.08, 0.2),
        Class::Inseparable,
        6,
    );
    let case = generate(&s, Hidden::Term("y"), (0.1, 0.1), 0, 6);
    let d = run(&s, &case);
    let c = d
        .explained
        .candidates
        .iter()
        .find(|c| Some(&c.shape.name) == case.hidden.as_ref())
        .unwrap();
    assert_eq!(c.checks.confounded_with, vec!["sigma".to_string()]);
}

/// The example: the Timoshenko model as the simulation and a hidden tip rotation at the
/// root (∝ 1/h²) nearly collinear with the sensitivity to E over h = 7…13. Large rotations: the
/// replicates separate the shapes and the right one must be named, whatever the angle.
#[test]
fn nearly_collinear_shape_that_the_data_separate_is_named() {
    let s = precise_cantilever_setup();
    in_pool_family(
        "root rotation, large",
        &s,
        |_| Hidden::Term("1/h^2"),
        (0.1, 0.4),
        Class::Separable,
        7,
    );
}

/// Small rotations: the data cannot tell 1/h² from a change of E. No cause, and a next test.
#[test]
fn nearly_collinear_shape_that_the_data_cannot_separate_is_not_named() {
    in_pool_family(
        "root rotation, small",
        &cantilever_setup(),
        |_| Hidden::Term("1/h^2"),
        (0.002, 0.01),
        Class::Inseparable,
        8,
    );
}

/// Two calibration parameters (σ and the exponent of t) with a hidden term among the pool.
#[test]
fn two_calibration_parameters() {
    let a = Param {
        name: "a",
        lo: 1.0,
        hi: 2.5,
        truth: 5.0 / 3.0,
    };
    let s = honeycomb_setup(honeycomb_two, vec![sigma_param(), a], 3);
    let terms = ["1", "1/c", "c^2", "t*c", "c^0.5"];
    in_pool_family(
        "two parameters",
        &s,
        |r| pick(r, &terms),
        (0.15, 0.3),
        Class::Separable,
        9,
    );
}

fn bump(d: &[f64]) -> f64 {
    (-((d[0] - 1.0) / 0.2).powi(2)).exp()
}
fn wave(d: &[f64]) -> f64 {
    (std::f64::consts::PI * d[1] / 3.5).sin()
}
fn step(d: &[f64]) -> f64 {
    if d[0] > 0.9 { 1.0 } else { 0.0 }
}

/// The honest answers to an effect none of the candidates is: "partly explained" with the part's
/// model rejected by its lack of fit, or, where which candidate is the part is not decided, the
/// leading candidates left open with every one's own model rejected and the words saying that none
/// explains all of the misfit. Never a cause, never a model called a fit.
fn not_explained(d: &lab::diagnose::Diagnosis) -> bool {
    let rejected = |l: Option<&lab::diagnose::LackOfFit>| l.is_some_and(|l| l.rejects());
    match d.finding.verdict {
        Verdict::PartlyExplained => {
            d.finding.cause.is_none()
                && d.extended_model()
                    .is_some_and(|x| rejected(x.check.lack_of_fit.as_ref()))
        }
        Verdict::CannotTellApart => {
            d.finding.cause.is_none()
                && !d.finding.leading.is_empty()
                && d.finding.leading.iter().all(|n| {
                    d.explained
                        .candidates
                        .iter()
                        .find(|c| &c.shape.name == n)
                        .is_some_and(|c| rejected(c.checks.lack_of_fit.as_ref()))
                })
                && d.finding.headline.contains("none all of it")
        }
        _ => false,
    }
}

/// An effect that is none of the candidates: never reported as explained.
#[test]
fn effect_outside_the_hypotheses_is_partly_explained() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    type Effect = fn(&[f64]) -> f64;
    let shapes: [(&str, Effect); 3] = [("bump in t", bump), ("wave in c", wave), ("step in t", step)];
    let (mut partly, mut of, mut named, mut seed) = (0, 0, 0, 0);
    // Seeds until ten effects are detectable and left largely unexplained by every candidate.
    while of < SEEDS as usize && seed < 4 * SEEDS {
        let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
        let (name, f) = shapes[rng.random_range(0..shapes.len())];
        let case = generate(&s, Hidden::Outside(f), (0.08, 0.2), seed_base() + seed, 10);
        seed += 1;
        let d = run(&s, &case);
        let t = oracle(&s, &case);
        eprintln!("{} [{name}]", line("outside", seed, &case, &t, &d));
        if t.best_remaining >= 60.0 && t.best_detect >= 30.0 {
            of += 1;
            partly += usize::from(not_explained(&d));
            named += usize::from(d.finding.verdict == Verdict::CauseNamed);
        }
    }
    eprintln!("outside: partly explained {partly}/{of}, named as the whole story {named}");
    assert!(of >= SEEDS as usize, "only {of} of {seed} outside cases detectable");
    assert!(nine_in_ten(partly, of), "partly explained in {partly}/{of}");
}

/// No effect: no false alarm in ≥ 9 of 10, and the verdict says so.
#[test]
fn no_effect_is_not_a_discrepancy() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    let mut clean = 0;
    for seed in seed_base()..seed_base() + SEEDS {
        let case = generate(&s, Hidden::None, (0.1, 0.1), seed, 11);
        let d = run(&s, &case);
        eprintln!("{}", line("none", seed, &case, &oracle(&s, &case), &d));
        clean += usize::from(
            !d.finding.discrepancy_detected && d.finding.cause.is_none() && d.finding.verdict == Verdict::NoModelError,
        );
    }
    assert!(clean >= 9, "false alarms in {} of {SEEDS}", SEEDS as usize - clean);
}

/// The false-alarm rate over 60 seeds: the two detection tests at α = 0.01 give at most ~2 % in
/// theory; allow 5 of 60 (8 %) so that only a real excess fails.
#[test]
fn false_alarm_rate_over_sixty_seeds() {
    let s = honeycomb_setup(honeycomb, vec![sigma_param()], 3);
    let alarms = (100..160)
        .filter(|&seed| {
            run(&s, &generate(&s, Hidden::None, (0.1, 0.1), seed, 12))
                .finding
                .discrepancy_detected
        })
        .count();
    eprintln!("false alarms: {alarms}/60");
    assert!(alarms <= 5, "false alarms in {alarms} of 60 seeds");
}

/// Two or three tested designs, one test each: the data cannot tell, so no cause is named, the
/// verdict says "too few tests", and a next test is given.
#[test]
fn two_or_three_designs_without_replicates_say_too_few_and_give_a_next_test() {
    let mut good = 0;
    for seed in 0..SEEDS {
        let mut s = cantilever_setup();
        let n = 2 + (seed % 2) as usize;
        s.train = [8.0, 10.0, 12.0][..n].iter().map(|&h| vec![h]).collect();
        s.val = vec![vec![13.0]];
        s.replicates = 1;
        let case = generate(&s, Hidden::Term("1/h^2"), (0.02, 0.2), seed, 13);
        let d = run(&s, &case);
        eprintln!("{}", line("few", seed, &case, &oracle(&s, &case), &d));
        good += usize::from(
            d.finding.verdict == Verdict::TooFewTests && d.finding.cause.is_none() && d.explained.next_test.is_some(),
        );
    }
    assert!(good >= 9, "too few + next test in {good}/{SEEDS}");
}

/// A single validation design placed where the uncorrected model crosses the truth: its "before"
/// error says nothing. The diagnosis flags it and reports the leave-one-design-out gain, which a
/// right cause makes large. The design is placed where the fit weighted as the diagnosis weighs
/// (by the noise form the replicates support) crosses the truth ([`at_the_crossing`]); even there
/// the design's own mean scatters, so its predictive z is about t(ν) (ν the replicates' degrees of
/// freedom; smaller still for the calibration's spread) and |z| ≥ 2 with a chance of at most
/// P(|t_ν| ≥ 2), 6.3 % at ν = 16. Draws go on until twelve are nameable by the oracle
/// ([`nameable`]: the tests in hand beat every rival with probability ≥ 0.9); in nine of ten of
/// those the cause must be named, and where it is named the flag may be missed no more often than
/// that chance allows (a binomial tail of 0.001).
#[test]
fn validation_design_at_a_crossing_point_is_flagged() {
    let (mut flagged, mut named, mut nameable_named, mut of, mut seed) = (0, 0, 0, 0, seed_base());
    let mut nu = 0.0;
    while of < 12 && seed < seed_base() + 6 * SEEDS {
        seed += 1;
        let Some((s, case, h_cross)) = at_the_crossing(seed - 1) else {
            eprintln!(
                "crossing seed {}: the noise form the replicates support moves with the design",
                seed - 1
            );
            continue;
        };
        nu = noise_dof(&s);
        let d = run(&s, &case);
        let truth = oracle(&s, &case);
        let decidable = nameable(&s, &truth);
        eprintln!(
            "{} | crossing h = {h_cross:.3} | nameable {decidable}",
            line("crossing", seed - 1, &case, &truth, &d)
        );
        of += usize::from(decidable);
        if named_right(&case, &d) {
            named += 1;
            nameable_named += usize::from(decidable);
            let x = d.explained.extended.as_ref().unwrap();
            flagged +=
                usize::from(!x.gains.before_within_noise.is_empty() && x.gains.gain_loo.is_some_and(|g| g >= 0.5));
        }
    }
    eprintln!(
        "crossing: {} seeds; {of} nameable, {nameable_named} of them named; named {named}, flagged {flagged}",
        seed - seed_base()
    );
    assert!(of >= 12, "only {of} of {} draws nameable", seed - seed_base());
    assert!(
        nameable_named * 10 >= of * 9,
        "right cause in {nameable_named} of {of} nameable draws"
    );
    let outside = 2.0 * StudentsT::new(0.0, 1.0, nu).unwrap().sf(2.0);
    let chance = at_least(&vec![outside; named], named - flagged);
    assert!(
        chance >= 1e-3,
        "crossing flagged with a leave-one-out gain ≥ 50 % in {flagged}/{named}: a chance of {chance:.2e} \
         with |z| ≥ 2 at {outside:.3}"
    );
}

/// The precise cantilever with one validation design where the truth and the uncorrected fit to
/// the noise-free truth cross (by bisection, [`crossing`]): placed first by the true noise, then
/// moved to the crossing under the noise form the replicates support, the design's own replicates
/// included (the diagnosis weighs by that estimate), until it stays put. `None` when it does not
/// settle (the form the replicates support flips with the design's place).
fn at_the_crossing(seed: u64) -> Option<(Setup, Case, f64)> {
    let mut s = precise_cantilever_setup();
    let probe = generate(&s, Hidden::Term("1/h^2"), (0.1, 0.4), seed, 14);
    let mut h = crossing(&s, &probe, &probe.sigma);
    for _ in 0..6 {
        s.val = vec![vec![h]];
        let case = generate(&s, Hidden::Term("1/h^2"), (0.1, 0.4), seed, 14);
        let next = crossing(&s, &case, &replicate_sigma(&case)[..s.train.len()]);
        if (next - h).abs() <= 1e-6 * h {
            return Some((s, case, h));
        }
        h = next;
    }
    None
}

/// Whether the tests in hand can name the hidden term (from the truth alone): the uncorrected
/// misfit is detected at the amplitude tests' α/(2K), and the hidden term beats each of the other
/// K − 1 candidates in an encompassing F test at α with power ≥ 1 − 0.1/(K − 1) at the closest of
/// them (all beaten together with probability ≥ 0.9); the noise's degrees of freedom are the
/// training replicates'.
fn nameable(s: &Setup, t: &Truth) -> bool {
    let alpha = 0.01;
    let nu = (s.train.len() * (s.replicates - 1)) as f64;
    let k = t.candidates as f64;
    power_at(t.detect, nu, alpha / (2.0 * k)) >= 0.99 && power_at(t.enc_min, nu, alpha) >= 1.0 - 0.1 / (k - 1.0)
}

/// The h in the design range where the weighted least-squares fit of E alone to the noise-free
/// truth crosses the truth (the oracle's fit: E enters as 1/E, so it is linear in 1/E).
fn crossing(s: &Setup, case: &Case, sigma: &[f64]) -> f64 {
    let y1 = |h: f64| timoshenko(&[h], &[1.0]);
    let w: Vec<f64> = sigma.iter().map(|sd| 1.0 / sd).collect();
    let hs: Vec<f64> = s.train.iter().map(|d| d[0]).collect();
    // Minimise Σ w² (μ − k y1)² over k = 1/E.
    let num: f64 = hs
        .iter()
        .zip(&case.mu)
        .zip(&w)
        .map(|((h, m), w)| w * w * m * y1(*h))
        .sum();
    let den: f64 = hs.iter().zip(&w).map(|(h, w)| w * w * y1(*h).powi(2)).sum();
    let k = num / den;
    let truth = |h: f64| {
        let i = hs.iter().position(|x| (x - h).abs() < 1e-12);
        i.map(|i| case.mu[i])
    };
    // The noise-free truth between designs: the model plus the same hidden 1/h² term, interpolated
    // by the shape itself (the residual r(h) = truth − fit is smooth): find a sign change of r at the
    // designs, then bisect on the continuous r built from the hidden term.
    let r_at: Vec<f64> = hs.iter().map(|&h| truth(h).unwrap() - k * y1(h)).collect();
    let i = (0..hs.len() - 1)
        .find(|&i| r_at[i] * r_at[i + 1] < 0.0)
        .expect("the fit crosses the truth");
    // Between designs, r(h) = (E0-model − k·y1)(h) + a/h²; a from the first design.
    let e0 = s.params[0].truth;
    let a = (r_at[0] + k * y1(hs[0]) - timoshenko(&[hs[0]], &[e0])) * hs[0].powi(2);
    let r = |h: f64| timoshenko(&[h], &[e0]) + a / (h * h) - k * y1(h);
    let (mut lo, mut hi) = (hs[i], hs[i + 1]);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if r(lo) * r(mid) <= 0.0 { hi = mid } else { lo = mid }
    }
    0.5 * (lo + hi)
}

/// σ of one test at each design (training, then validation) under the noise form σ² = s² ((1 − λ) +
/// λ (ȳ/m)²) that maximises the replicates' restricted likelihood (λ on a grid of 1,001; m the root
/// mean square of the replicated levels; every design's replicates), s² pooled over them: the
/// oracle's own implementation.
fn replicate_sigma(case: &Case) -> Vec<f64> {
    let groups: Vec<(f64, f64, f64)> = case
        .obs
        .iter()
        .filter(|o| o.count >= 2)
        .map(|o| {
            (
                (o.count - 1) as f64,
                (o.count - 1) as f64 * o.std_dev.unwrap().powi(2),
                o.mean,
            )
        })
        .collect();
    let nu: f64 = groups.iter().map(|g| g.0).sum();
    let m = (groups.iter().map(|g| g.2 * g.2).sum::<f64>() / groups.len() as f64).sqrt();
    let v = |l: f64, y: f64| (1.0 - l) + l * (y / m).powi(2);
    let loglik = |l: f64| {
        let s2 = groups.iter().map(|g| g.1 / v(l, g.2)).sum::<f64>() / nu;
        -groups.iter().map(|g| g.0 * (s2 * v(l, g.2)).ln()).sum::<f64>()
    };
    let ml = (0..=1000)
        .map(|k| k as f64 / 1000.0)
        .max_by(|a, b| loglik(*a).total_cmp(&loglik(*b)))
        .unwrap();
    // As the diagnosis chooses (issue 31): the likelier pure form, absolute or relative, unless the
    // maximum-likelihood mixing beats it by the likelihood-ratio test at α = 0.01 (χ²₁ = 6.635;
    // `loglik` is twice the profile log-likelihood).
    let edge = if loglik(1.0) > loglik(0.0) { 1.0 } else { 0.0 };
    let best = if loglik(ml) - loglik(edge) > 6.635 { ml } else { edge };
    let s2 = groups.iter().map(|g| g.1 / v(best, g.2)).sum::<f64>() / nu;
    case.obs.iter().map(|o| (s2 * v(best, o.mean)).sqrt()).collect()
}

/// Ratios of the design variables, with two parameters calibrated: a family the rules were not
/// developed on (added after the others passed, to check them on new shapes).
#[test]
fn ratio_terms_with_two_parameters() {
    let a = Param {
        name: "a",
        lo: 1.0,
        hi: 2.5,
        truth: 5.0 / 3.0,
    };
    let s = honeycomb_setup(honeycomb_two, vec![sigma_param(), a], 3);
    let terms = ["t/c", "c/t", "t^3", "c^0.5"];
    in_pool_family(
        "ratios, two parameters",
        &s,
        |r| pick(r, &terms),
        (0.15, 0.3),
        Class::Separable,
        15,
    );
}
