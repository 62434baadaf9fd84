//! Calibration against whole force–displacement curves (issue 24): the paper's three methods with
//! a curve on a common stroke grid in place of one number per design.
//!
//! Each design i has n_i specimen curves y_ij(s) on the grid, their mean ȳ_i(s) and pointwise
//! variance v_i(s) (smoothed along the stroke, see [`CurveTarget::new`]); the simulation gives
//! η_i(s, θ) (a functional emulator, Higdon et al. 2008).
//!
//! - [`least_squares`] (Eq. 3 on curves): min_θ Σ_i Σ_s n_i (ȳ_i(s) − η_i(s, θ))² / v_i(s) — each
//!   point weighted by the specimens' scatter there — for `mse`; for another metric m,
//!   min_θ mean_ij m(y_ij, η_i(θ)) by Nelder–Mead from the weighted least-squares point.
//! - [`sensitivity`] (Eqs. 6–7 on curves): consecutive training designs' differences matched point
//!   by point, weighted by their scatter; then the offset curve d(s) = mean_i (ȳ_i − η_i(θ*)).
//! - [`bayesian`] (Kennedy & O'Hagan 2001 on curves): ȳ_i = η_i(θ) + δ_i + ε_i with the discrepancy
//!   δ_i = B w_i on a basis of [`BASIS`] Gaussian bumps along the stroke (w_i ~ N(0, σ_δ² I),
//!   independent between designs: a few designs give no basis to model how it changes with them)
//!   and ε_i ~ N(0, diag(v_i / n_i)). The marginal likelihood is Gaussian with covariance
//!   σ_δ² B Bᵀ + diag(v_i/n_i), evaluated through the Woodbury identity in the basis; the posterior
//!   over (θ, ln σ_δ) with flat priors on the box is integrated by adaptive cubature around its mode.
//!
//! All are pure functions of the curves and the emulator.

use nalgebra::{DMatrix, DVector};

use super::bayesian::cubature::{Rule, integrate};
use super::{Bounds, CalibrationError, optimize};
use crate::base::optim::nelder_mead;
use crate::extract::metrics;
use crate::study::CurveMetric;

/// The simulation's curve at training or validation design `i` (the index into the targets) and θ.
pub type Predict<'a> = dyn Fn(usize, &[f64]) -> Option<DVector<f64>> + Sync + 'a;

/// One design's measured curves on the grid.
#[derive(Debug, Clone)]
pub struct CurveTarget {
    pub name: String,
    pub training: bool,
    pub specimens: Vec<DVector<f64>>,
    pub mean: DVector<f64>,
    /// Pointwise variance of one specimen, smoothed; pooled over the designs where a design has
    /// one specimen.
    pub variance: DVector<f64>,
}

/// Half-width of the moving average that smooths the pointwise variance, as a share of the grid:
/// three specimens give a variance with 2 degrees of freedom per point, far too rough to weight by.
const SMOOTHING: f64 = 0.05;

impl CurveTarget {
    /// The targets with their means and smoothed variances; a design with one specimen takes the
    /// pooled variance of the others (or unit weights when no design has replicates).
    pub fn new(designs: Vec<(String, bool, Vec<DVector<f64>>)>) -> Vec<CurveTarget> {
        let raw: Vec<Option<DVector<f64>>> = designs.iter().map(|(_, _, s)| pointwise_variance(s)).collect();
        let with: Vec<&DVector<f64>> = raw.iter().flatten().collect();
        let pooled = (!with.is_empty())
            .then(|| with.iter().fold(DVector::zeros(with[0].len()), |a, v| a + *v) / with.len() as f64);
        designs
            .into_iter()
            .zip(raw)
            .map(|((name, training, specimens), v)| {
                let g = specimens[0].len();
                let mean = specimens.iter().fold(DVector::zeros(g), |a, s| a + s) / specimens.len() as f64;
                let variance = v
                    .or_else(|| pooled.clone())
                    .map_or(DVector::from_element(g, 1.0), |v| smooth(&v));
                CurveTarget {
                    name,
                    training,
                    specimens,
                    mean,
                    variance,
                }
            })
            .collect()
    }

    fn n(&self) -> f64 {
        self.specimens.len() as f64
    }
}

fn pointwise_variance(specimens: &[DVector<f64>]) -> Option<DVector<f64>> {
    let n = specimens.len();
    if n < 2 {
        return None;
    }
    let mean = specimens.iter().fold(DVector::zeros(specimens[0].len()), |a, s| a + s) / n as f64;
    Some(
        specimens
            .iter()
            .fold(DVector::zeros(mean.len()), |a, s| a + (s - &mean).map(|d| d * d))
            / (n - 1) as f64,
    )
}

/// Moving average over ±`SMOOTHING` of the grid, floored at 10⁻⁶ of its mean so no point gets an
/// unbounded weight.
fn smooth(v: &DVector<f64>) -> DVector<f64> {
    let g = v.len();
    let h = ((g as f64 * SMOOTHING).round() as usize).max(1);
    let floor = 1e-6 * v.mean().max(f64::MIN_POSITIVE);
    DVector::from_iterator(
        g,
        (0..g).map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h).min(g - 1));
            (v.rows(a, b - a + 1).sum() / (b - a + 1) as f64).max(floor)
        }),
    )
}

/// The curve problem: targets, the emulator, the parameter box, the grid's strokes and the metric.
pub struct CurveProblem<'a> {
    pub targets: Vec<CurveTarget>,
    pub predict: &'a Predict<'a>,
    pub bounds: Bounds,
    pub stroke: Vec<f64>,
    pub metric: CurveMetric,
}

/// A calibration on curves: θ and, for the sensitivity method, the offset curve; for the Bayesian
/// method the 95 % intervals and the discrepancy's scale.
#[derive(Debug, Clone)]
pub struct CurveEstimate {
    pub theta: DVector<f64>,
    pub offset: Option<DVector<f64>>,
    pub interval: Option<Vec<(f64, f64)>>,
    pub discrepancy_sd: Option<f64>,
}

impl CurveEstimate {
    fn point(theta: DVector<f64>) -> Self {
        CurveEstimate {
            theta,
            offset: None,
            interval: None,
            discrepancy_sd: None,
        }
    }
}

impl CurveProblem<'_> {
    fn training(&self) -> impl Iterator<Item = (usize, &CurveTarget)> {
        self.targets.iter().enumerate().filter(|(_, t)| t.training)
    }

    fn curve(&self, i: usize, theta: &[f64]) -> DVector<f64> {
        (self.predict)(i, theta).unwrap_or_else(|| DVector::from_element(self.stroke.len(), f64::NAN))
    }

    /// The metric of `computed` against one specimen.
    pub fn metric_of(&self, specimen: &DVector<f64>, computed: &DVector<f64>) -> f64 {
        let pts = |y: &DVector<f64>| {
            self.stroke
                .iter()
                .zip(y.iter())
                .map(|(&s, &f)| [s, f])
                .collect::<Vec<_>>()
        };
        match self.metric {
            CurveMetric::Mse => metrics::mse(specimen.as_slice(), computed.as_slice()),
            CurveMetric::Pcm => metrics::pcm(&pts(specimen), &pts(computed)),
            CurveMetric::Frechet => metrics::frechet(&pts(specimen), &pts(computed)),
            CurveMetric::Dtw => metrics::dtw(&pts(specimen), &pts(computed)),
            CurveMetric::Area => metrics::area(&pts(specimen), &pts(computed)),
        }
    }

    /// The metric's mean over the specimens of the training (`training`) or validation designs, of
    /// the calibrated curve (with the offset curve where the method has one); NaN without designs.
    pub fn value(&self, est: &CurveEstimate, training: bool) -> f64 {
        let mut values = Vec::new();
        for (i, t) in self.targets.iter().enumerate().filter(|(_, t)| t.training == training) {
            let mut c = self.curve(i, est.theta.as_slice());
            if let Some(d) = &est.offset {
                c += d;
            }
            values.extend(t.specimens.iter().map(|s| self.metric_of(s, &c)));
        }
        if values.is_empty() {
            f64::NAN
        } else {
            values.iter().sum::<f64>() / values.len() as f64
        }
    }

    /// Weighted residuals √(n_i / v_i(s)) (ȳ_i(s) − η_i(s, θ)) over the training designs.
    fn weighted(&self, theta: &DVector<f64>) -> DVector<f64> {
        let mut r = Vec::new();
        for (i, t) in self.training() {
            let c = self.curve(i, theta.as_slice());
            r.extend((0..c.len()).map(|k| (t.mean[k] - c[k]) * (t.n() / t.variance[k]).sqrt()));
        }
        DVector::from_vec(r)
    }
}

/// Eq. 3 on curves (see the module doc).
pub fn least_squares(p: &CurveProblem) -> Result<CurveEstimate, CalibrationError> {
    needs(p, 1, "least_squares")?;
    let theta = optimize::least_squares(&|t: &DVector<f64>| p.weighted(t), &p.bounds)?.theta;
    if p.metric == CurveMetric::Mse {
        return Ok(CurveEstimate::point(theta));
    }
    let cost = |u: &[f64]| {
        let t = p.bounds.from_unit(&DVector::from_column_slice(u));
        p.value(&CurveEstimate::point(t), true)
    };
    let start = p.bounds.to_unit(&theta);
    let (u, _) = nelder_mead(&cost, start.as_slice(), 0.05, 400);
    Ok(CurveEstimate::point(p.bounds.from_unit(&DVector::from_vec(u))))
}

/// Eqs. 6–7 on curves (see the module doc).
pub fn sensitivity(p: &CurveProblem) -> Result<CurveEstimate, CalibrationError> {
    needs(p, 2, "sensitivity")?;
    let train: Vec<(usize, &CurveTarget)> = p.training().collect();
    let residuals = |theta: &DVector<f64>| {
        let curves: Vec<DVector<f64>> = train.iter().map(|(i, _)| p.curve(*i, theta.as_slice())).collect();
        let mut r = Vec::new();
        for (w, c) in train.windows(2).zip(curves.windows(2)) {
            let ((_, a), (_, b)) = (w[0], w[1]);
            r.extend((0..c[0].len()).map(|k| {
                let sd = (a.variance[k] / a.n() + b.variance[k] / b.n()).sqrt();
                ((a.mean[k] - b.mean[k]) - (c[0][k] - c[1][k])) / sd
            }));
        }
        DVector::from_vec(r)
    };
    let theta = optimize::least_squares(&residuals, &p.bounds)?.theta;
    let g = p.stroke.len();
    let offset = train.iter().fold(DVector::zeros(g), |a, (i, t)| {
        a + (&t.mean - p.curve(*i, theta.as_slice()))
    }) / train.len() as f64;
    Ok(CurveEstimate {
        offset: Some(offset),
        ..CurveEstimate::point(theta)
    })
}

/// Gaussian bumps of the discrepancy's basis along the stroke: a smooth discrepancy on the scale of
/// a ninth of the window, which is what the features (peak, plateau, slope) can see.
pub const BASIS: usize = 10;

fn basis(stroke: &[f64]) -> DMatrix<f64> {
    let (a, b) = (stroke[0], stroke[stroke.len() - 1]);
    let h = (b - a) / (BASIS - 1) as f64;
    DMatrix::from_fn(stroke.len(), BASIS, |k, j| {
        let z = (stroke[k] - (a + h * j as f64)) / h;
        (-0.5 * z * z).exp()
    })
}

/// ln N(r; 0, σ² B Bᵀ + diag(n)) by the Woodbury identity and the matrix determinant lemma.
fn log_normal(r: &DVector<f64>, b: &DMatrix<f64>, noise: &DVector<f64>, sigma2: f64) -> f64 {
    let ninv_r = r.component_div(noise);
    let ninv_b = DMatrix::from_fn(b.nrows(), b.ncols(), |k, j| b[(k, j)] / noise[k]);
    let mut inner = b.transpose() * &ninv_b;
    for j in 0..inner.nrows() {
        inner[(j, j)] += 1.0 / sigma2;
    }
    let Some(chol) = inner.clone().cholesky() else {
        return f64::NEG_INFINITY;
    };
    let btr = b.transpose() * &ninv_r;
    let quad = r.dot(&ninv_r) - btr.dot(&chol.solve(&btr));
    let ln_det_inner: f64 = 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let ln_det = ln_det_inner + b.ncols() as f64 * sigma2.ln() + noise.iter().map(|v| v.ln()).sum::<f64>();
    -0.5 * (quad + ln_det + r.len() as f64 * (2.0 * std::f64::consts::PI).ln())
}

/// Kennedy–O'Hagan on curves (see the module doc): posterior means of θ, their 95 % intervals, and
/// the posterior median of σ_δ.
pub fn bayesian(p: &CurveProblem) -> Result<CurveEstimate, CalibrationError> {
    needs(p, 1, "bayesian")?;
    let b = basis(&p.stroke);
    let train: Vec<(usize, &CurveTarget)> = p.training().collect();
    let level = (train
        .iter()
        .map(|(_, t)| t.mean.norm_squared() / t.mean.len() as f64)
        .sum::<f64>()
        / train.len() as f64)
        .sqrt();
    let (lo_tau, hi_tau) = ((1e-4 * level).ln(), level.ln());
    let dim = p.bounds.dim();
    let theta_of = |x: &[f64]| DVector::from_column_slice(&x[..dim]);
    let log_post = |x: &[f64]| -> f64 {
        let theta = theta_of(x);
        let sigma2 = (2.0 * x[dim]).exp();
        train
            .iter()
            .map(|(i, t)| {
                let r = &t.mean - p.curve(*i, theta.as_slice());
                log_normal(&r, &b, &t.variance.map(|v| v / t.n()), sigma2)
            })
            .sum()
    };
    let full = Bounds::new(
        p.bounds.lower.iter().copied().chain([lo_tau]).collect(),
        p.bounds.upper.iter().copied().chain([hi_tau]).collect(),
    );
    let mode = posterior_mode(&log_post, &full);
    let top = log_post(mode.as_slice());
    if !top.is_finite() {
        return Err(CalibrationError::Numerics(
            "the curve posterior is not finite at its mode".into(),
        ));
    }
    let region = laplace_box(&log_post, &mode, &full);
    let density = |x: &[f64]| (log_post(x) - top).exp();
    let cub = integrate(&density, vec![region], Rule::k15(), 1e-3, 48);
    let marginals: Vec<_> = (0..=dim).map(|k| cub.marginal(k)).collect();
    let theta = DVector::from_iterator(dim, marginals[..dim].iter().map(|m| m.mean()));
    let interval = (0..dim)
        .map(|k| {
            let (lo, hi) = (p.bounds.lower[k], p.bounds.upper[k]);
            (
                marginals[k].quantile(0.025, lo, hi),
                marginals[k].quantile(0.975, lo, hi),
            )
        })
        .collect();
    let tau = marginals[dim].quantile(0.5, lo_tau, hi_tau);
    Ok(CurveEstimate {
        theta,
        offset: None,
        interval: Some(interval),
        discrepancy_sd: Some(tau.exp()),
    })
}

/// The posterior's mode over the box: Nelder–Mead in the unit cube from the best of a coarse
/// Latin hypercube.
fn posterior_mode(f: &dyn Fn(&[f64]) -> f64, bounds: &Bounds) -> DVector<f64> {
    let cost = |u: &[f64]| -f(bounds.from_unit(&DVector::from_column_slice(u)).as_slice());
    let plan = crate::base::latin_hypercube(24, bounds.dim(), 7);
    let start = plan
        .row_iter()
        .map(|r| r.iter().copied().collect::<Vec<f64>>())
        .min_by(|a, b| cost(a).total_cmp(&cost(b)))
        .expect("a start");
    let (u, _) = nelder_mead(&cost, &start, 0.05, 2000);
    bounds.from_unit(&DVector::from_vec(u))
}

/// The box around the mode where the posterior lives: ±8 Laplace standard deviations per axis
/// (from the diagonal curvature), inside the prior box.
fn laplace_box(f: &dyn Fn(&[f64]) -> f64, mode: &DVector<f64>, bounds: &Bounds) -> (Vec<f64>, Vec<f64>) {
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for k in 0..mode.len() {
        let h = 1e-4 * (bounds.upper[k] - bounds.lower[k]);
        let at = |d: f64| {
            let mut x = mode.clone();
            x[k] = (x[k] + d).clamp(bounds.lower[k], bounds.upper[k]);
            f(x.as_slice())
        };
        let curv = -(at(h) - 2.0 * at(0.0) + at(-h)) / (h * h);
        let sd = if curv > 0.0 && curv.is_finite() {
            curv.sqrt().recip()
        } else {
            f64::INFINITY
        };
        lo.push((mode[k] - 8.0 * sd).max(bounds.lower[k]));
        hi.push((mode[k] + 8.0 * sd).min(bounds.upper[k]));
    }
    (lo, hi)
}

fn needs(p: &CurveProblem, needed: usize, method: &'static str) -> Result<(), CalibrationError> {
    let given = p.training().count();
    if given < needed {
        return Err(CalibrationError::TooFewDesigns { method, needed, given });
    }
    Ok(())
}

/// How well the curves pin each parameter down, against the mean force over `window` alone: the
/// standard error from the Fisher information Jᵀ W J of the weighted curve residuals, and from the
/// designs' mean forces (the mean of the curve over the window's grid points) with their scatter.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Pinned {
    pub parameter: String,
    /// Standard error from the whole curves.
    pub curves_se: f64,
    /// From the mean forces alone: infinite where they cannot tell this parameter from the others.
    pub mean_force_se: f64,
}

/// [`Pinned`] for every parameter at θ (`names` in θ's order, `window` the stroke indices of the
/// mean force).
pub fn pinned(p: &CurveProblem, theta: &DVector<f64>, names: &[String], window: std::ops::Range<usize>) -> Vec<Pinned> {
    let curves = |t: &DVector<f64>| p.weighted(t);
    let mean_force = |t: &DVector<f64>| {
        DVector::from_iterator(
            p.training().count(),
            p.training().map(|(i, tg)| {
                let c = p.curve(i, t.as_slice());
                let w = window.clone();
                let m = |y: &DVector<f64>| y.rows(w.start, w.len()).mean();
                let sd = (tg.variance.rows(w.start, w.len()).mean() / tg.n()).sqrt();
                (m(&tg.mean) - m(&c)) / sd
            }),
        )
    };
    let se = |j: DMatrix<f64>| -> Vec<f64> {
        let info = j.transpose() * j;
        let scale = info.diagonal().map(|d| d.sqrt().max(f64::MIN_POSITIVE));
        let sc = DMatrix::from_fn(info.nrows(), info.ncols(), |a, b| info[(a, b)] / (scale[a] * scale[b]));
        let svd = sc.clone().svd(false, false);
        let top = svd.singular_values.max();
        if svd.singular_values.min() <= 1e-10 * top {
            return vec![f64::INFINITY; info.nrows()];
        }
        match sc.try_inverse() {
            Some(inv) => (0..info.nrows()).map(|a| inv[(a, a)].sqrt() / scale[a]).collect(),
            None => vec![f64::INFINITY; info.nrows()],
        }
    };
    let u = p.bounds.to_unit(theta);
    let in_box = |f: &dyn Fn(&DVector<f64>) -> DVector<f64>| {
        let g = |u: &DVector<f64>| f(&p.bounds.from_unit(u));
        let mut j = optimize::jacobian(&g, &u);
        for (c, w) in p.bounds.width().iter().enumerate() {
            j.column_mut(c).unscale_mut(*w);
        }
        j
    };
    let (a, b) = (se(in_box(&curves)), se(in_box(&mean_force)));
    names
        .iter()
        .enumerate()
        .map(|(k, n)| Pinned {
            parameter: n.clone(),
            curves_se: a[k],
            mean_force_se: b[k],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A crush-like curve family: a peak ∝ a·design near the start, a plateau a·(1 + b·design)
    /// after it. (The peak must change with the design for the sensitivity method to see a apart
    /// from a·b: differences between designs cancel whatever does not.)
    fn curve(stroke: &[f64], design: f64, theta: &[f64]) -> DVector<f64> {
        DVector::from_iterator(
            stroke.len(),
            stroke.iter().map(|&s| {
                let plateau = theta[0] * (1.0 + theta.get(1).copied().unwrap_or(0.0) * design);
                plateau + 0.8 * theta[0] * design * (-s / 3.0).exp()
            }),
        )
    }

    fn problem<'a>(predict: &'a Predict<'a>, truth: &[f64], noise: f64, seed: u64, dim: usize) -> CurveProblem<'a> {
        let stroke: Vec<f64> = (0..61).map(|k| k as f64).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = Normal::new(0.0, noise).unwrap();
        let designs = [0.5, 1.0, 1.5, 2.0];
        let targets = designs
            .iter()
            .enumerate()
            .map(|(i, &d)| {
                let c = curve(&stroke, d, truth);
                let specs = (0..3).map(|_| c.map(|v| v + n.sample(&mut rng))).collect();
                (format!("D{i}"), i < 3, specs)
            })
            .collect();
        CurveProblem {
            targets: CurveTarget::new(targets),
            predict,
            bounds: Bounds::new(vec![1.0, 0.0][..dim].to_vec(), vec![20.0, 1.0][..dim].to_vec()),
            stroke,
            metric: CurveMetric::Mse,
        }
    }

    fn predictor(stroke_len: usize) -> impl Fn(usize, &[f64]) -> Option<DVector<f64>> + Sync {
        let designs = [0.5, 1.0, 1.5, 2.0];
        move |i, t| {
            let stroke: Vec<f64> = (0..stroke_len).map(|k| k as f64).collect();
            Some(curve(&stroke, designs[i], t))
        }
    }

    #[test]
    fn the_three_methods_recover_two_parameters_from_noisy_curves() {
        let f = predictor(61);
        for seed in 0..5 {
            let p = problem(&f, &[10.0, 0.3], 0.1, seed, 2);
            for est in [
                least_squares(&p).unwrap(),
                sensitivity(&p).unwrap(),
                bayesian(&p).unwrap(),
            ] {
                // Noise 0.1 on ~10 over 180 points: the standard error of a is ~0.01; 0.1 is ten of them.
                assert!((est.theta[0] - 10.0).abs() < 0.1, "seed {seed}: {:?}", est.theta);
                assert!((est.theta[1] - 0.3).abs() < 0.01, "seed {seed}: {:?}", est.theta);
            }
            let b = bayesian(&p).unwrap();
            let iv = b.interval.unwrap();
            assert!(iv[0].0 < iv[0].1 && iv[0].1 - iv[0].0 < 0.2, "{iv:?}");
        }
    }

    #[test]
    fn bayesian_intervals_cover_the_truth_at_about_their_level() {
        let f = predictor(61);
        let covered = (0..40)
            .filter(|&seed| {
                let p = problem(&f, &[10.0], 0.2, 100 + seed, 1);
                let iv = bayesian(&p).unwrap().interval.unwrap()[0];
                iv.0 <= 10.0 && 10.0 <= iv.1
            })
            .count();
        // 95 % intervals over 40 draws: P(≤ 33 covered) < 0.5 % under the nominal level.
        assert!(covered >= 34, "{covered}/40 covered");
    }

    #[test]
    fn a_constant_offset_does_not_bias_the_sensitivity_method() {
        let base = predictor(61);
        let shifted = move |i: usize, t: &[f64]| base(i, t).map(|c| c.add_scalar(-1.5));
        let p = problem(&shifted, &[10.0, 0.3], 0.05, 3, 2);
        let est = sensitivity(&p).unwrap();
        assert!(
            (est.theta[0] - 10.0).abs() < 0.05 && (est.theta[1] - 0.3).abs() < 0.005,
            "{:?}",
            est.theta
        );
        let d = est.offset.unwrap();
        // a within 0.05 moves the level by up to 0.05 × 1.6 (the largest 1 + b·design): 0.1.
        assert!((d.mean() - 1.5).abs() < 0.1, "offset {}", d.mean());
    }

    #[test]
    fn curves_pin_down_what_the_mean_force_cannot() {
        // One design: the mean force alone gives one equation for two parameters; the peak
        // (set by a alone) separates them.
        let f = |_: usize, t: &[f64]| {
            let stroke: Vec<f64> = (0..61).map(|k| k as f64).collect();
            Some(curve(&stroke, 1.0, t))
        };
        let mut p = problem(&f, &[10.0, 0.3], 0.1, 9, 2);
        p.targets.truncate(1);
        let names = vec!["a".to_string(), "b".to_string()];
        let pins = pinned(&p, &DVector::from_vec(vec![10.0, 0.3]), &names, 5..61);
        assert!(
            pins.iter()
                .all(|q| q.curves_se.is_finite() && q.mean_force_se.is_infinite()),
            "{pins:?}"
        );
    }
}
