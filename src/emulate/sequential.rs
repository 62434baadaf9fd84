//! Sequential design of solver runs: where the next batch goes, and whether more runs would change
//! the answer. Pure: points and numbers in, points and numbers out.
//!
//! The space is a box (the calibration parameters θ, or θ with an extension's ranged variables);
//! every tested design (a *site*) has its own runs in it and its own emulator per output (the mean
//! crush force, and the curve features the diagnosis reads, whitened by the specimens' scatter).
//! Each output of a site has the tests' mean and the noise variance of that mean, τ².
//!
//! 1. **Emulators.** Per site and output, the Gaussian process of [`crate::emulate::gp`]
//!    (maximum-likelihood roughness, universal kriging): mean μ(x) and covariance c(x, x').
//! 2. **Posterior** of x from the training sites' tests, with the emulator's own variance in the
//!    likelihood (Kennedy & O'Hagan 2001): −ln p(x) = Σ_{site, k} [(ȳ − μ)² / (τ² + s²) + ln(τ² + s²)] / 2,
//!    uniform on the box. Represented by weighted points: its mode by bounded least squares (and
//!    searched again from the best draw where a draw beats it clearly: the residuals lack the
//!    ln(τ² + s²) term), a Laplace covariance there, and importance draws from a widened Gaussian
//!    around the mode (weights p/q, truncated to the box).
//! 3. **Where next** (integrated variance, after Sürer, Plumlee & Wild 2024 and the IMSE criteria of
//!    Sacks et al. 1989): a run at (site, x*) lowers the emulator's variance at every x by
//!    c(x, x*)² / c(x*, x*); its value is that reduction, in units of τ² and integrated over the
//!    posterior, summed over the site's outputs. A batch is chosen greedily, the covariances updated
//!    after each pick by that same rank-one formula (the variance does not depend on the value the
//!    run will give, so the greedy batch needs no guess of it).
//! 4. **Enough?** A site is done when its emulator's error at the posterior is small beside the
//!    tests' noise, both as measured on runs it was not fitted to (the caller's check) and as its
//!    own integrated predictive standard deviation, √(Σ w s²/τ²), maximised over outputs.
//!
//! The candidates are the posterior draws and a seeded Latin hypercube of the box, in a fixed
//! order, and ties go to the first: a batch depends only on the runs so far, the tests and the seed.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::gp::Emulator;
use crate::base::latin_hypercube;

pub mod shared;
use crate::base::{Bounds, optimize};

/// The lattice the planner's points are snapped to, as a fraction of the box's width: finer than
/// a posterior of precise tests is narrow (35 specimens at 0.25 % scatter know a modulus to about
/// 1e-4 of a 50 % wide box), far coarser than the last bits of a floating-point sum or an
/// optimiser's stopping point (1e-13 of the box), so that a rounding difference (another CPU,
/// another compiler, a reordered sum) does not change which run a batch asks for, and recordings
/// replay.
const RESOLUTION: f64 = 1e-6;

/// `x` on the planner's lattice of the box (see [`RESOLUTION`]).
pub fn snap(bounds: &Bounds, x: &[f64]) -> Vec<f64> {
    let w = bounds.width();
    (0..x.len())
        .map(|j| {
            let u = ((x[j] - bounds.lower[j]) / w[j] / RESOLUTION).round() * RESOLUTION;
            (bounds.lower[j] + u * w[j]).clamp(bounds.lower[j], bounds.upper[j])
        })
        .collect()
}

/// Posterior draws (importance sampling) and space-filling candidates.
const DRAWS: usize = 256;
const FILL: usize = 64;

/// One tested design as the planner sees it.
#[derive(Debug, Clone)]
pub struct Site {
    pub name: String,
    /// Its tests inform the posterior (training) or are predicted (validation).
    pub training: bool,
    /// The runs so far: a point of the box each.
    pub x: Vec<Vec<f64>>,
    /// Each run's value of every output (`y[run][output]`; NaN where it could not be read).
    pub y: Vec<Vec<f64>>,
    /// Per output: the tests' mean, and the noise variance of that mean (τ²).
    pub observed: Vec<f64>,
    pub noise: Vec<f64>,
}

/// One site's emulators, one per output (`None`: too few runs, or the fit failed).
pub struct SiteEmulators {
    pub outputs: Vec<Option<Emulator>>,
    /// The design's coordinates, which an emulator shared by every design takes before the point
    /// of the box (see [`shared`]); empty for the site's own emulators.
    pub at: Vec<f64>,
}

impl SiteEmulators {
    /// `x` as the emulators take it: the design's coordinates, then x.
    fn point(&self, x: &[f64]) -> Vec<f64> {
        self.at.iter().chain(x).copied().collect()
    }

    /// The emulators' mean of every output at `x` (`None` where an output has no emulator).
    pub fn predict(&self, x: &[f64]) -> Option<Vec<f64>> {
        let p = self.point(x);
        self.outputs
            .iter()
            .map(|o| o.as_ref()?.mean_var_at(&p).map(|m| m.0))
            .collect()
    }

    /// Every row of `points` as the emulators take it (see [`SiteEmulators::point`]).
    fn rows(&self, points: &DMatrix<f64>) -> DMatrix<f64> {
        let a = self.at.len();
        DMatrix::from_fn(points.nrows(), a + points.ncols(), |i, j| {
            if j < a { self.at[j] } else { points[(i, j - a)] }
        })
    }
}

impl Site {
    /// The site's runs as output `k`'s emulator takes them, at the design's coordinates `at`
    /// (empty for the site's own emulator).
    pub fn runs<'a>(&'a self, k: usize, at: &'a [f64]) -> Vec<super::Run<'a, f64>> {
        self.x
            .iter()
            .zip(&self.y)
            .map(|(x, y)| super::Run {
                design: &self.name,
                values: at,
                x,
                y: Some(&y[k]),
            })
            .collect()
    }
}

/// The posterior of x as weighted points.
#[derive(Debug, Clone)]
pub struct Posterior {
    /// One point per row.
    pub points: DMatrix<f64>,
    /// Normalised importance weights.
    pub weights: Vec<f64>,
    pub mode: Vec<f64>,
    pub mean: Vec<f64>,
    /// 2.5 % and 97.5 % weighted quantiles per coordinate.
    pub interval: Vec<[f64; 2]>,
}

/// Fits every site's emulators (the sites in parallel; each fit depends only on its site's runs).
pub fn emulators(bounds: &Bounds, sites: &[Site]) -> Vec<SiteEmulators> {
    use rayon::prelude::*;
    sites
        .par_iter()
        .map(|s| {
            let outputs = (0..s.observed.len())
                .map(|k| <Emulator as super::Emulator>::fit(bounds, &s.runs(k, &[])).ok())
                .collect();
            SiteEmulators {
                outputs,
                at: Vec::new(),
            }
        })
        .collect()
}

/// Mean and variance of every output of every site at `x` (NaN variance where no emulator).
fn predict(emus: &[SiteEmulators], x: &[f64]) -> Vec<Vec<(f64, f64)>> {
    emus.iter()
        .map(|e| {
            e.outputs
                .iter()
                .map(|o| match o.as_ref().and_then(|g| g.mean_var_at(&e.point(x))) {
                    Some((m, v)) => (m, v.max(0.0)),
                    None => (f64::NAN, f64::NAN),
                })
                .collect()
        })
        .collect()
}

/// Mean and variance of every output of every site at every row of `points`
/// (`[site][output][row]`; NaN where no emulator).
fn predict_rows(emus: &[SiteEmulators], points: &DMatrix<f64>) -> Vec<Vec<Vec<(f64, f64)>>> {
    let m = points.nrows();
    emus.iter()
        .map(|e| {
            let rows = e.rows(points);
            e.outputs
                .iter()
                .map(|o| match o.as_ref().and_then(|g| g.mean_var(&rows)) {
                    Some((mu, v)) => mu.iter().zip(v.iter()).map(|(a, b)| (*a, b.max(0.0))).collect(),
                    None => vec![(f64::NAN, f64::NAN); m],
                })
                .collect()
        })
        .collect()
}

/// −ln p(x) at every row of `points`, up to a constant: the training sites' tests against the
/// emulators, their variance in the likelihood, the tests' noise scaled by the dispersion `phi`;
/// infinite outside the box.
fn neg_log_posterior(
    bounds: &Bounds,
    sites: &[Site],
    emus: &[SiteEmulators],
    points: &DMatrix<f64>,
    phi: f64,
) -> Vec<f64> {
    let pred = predict_rows(emus, points);
    (0..points.nrows())
        .map(|i| {
            let x = points.row(i);
            if (0..x.len()).any(|j| x[j] < bounds.lower[j] || x[j] > bounds.upper[j]) {
                return f64::INFINITY;
            }
            let mut nlp = 0.0;
            for (s, p) in sites.iter().zip(&pred) {
                if !s.training {
                    continue;
                }
                for (k, rows) in p.iter().enumerate() {
                    let (mu, s2) = rows[i];
                    let v = phi * s.noise[k] + s2;
                    if mu.is_finite() && v > 0.0 {
                        nlp += 0.5 * ((s.observed[k] - mu).powi(2) / v + v.ln());
                    }
                }
            }
            nlp
        })
        .collect()
}

/// The posterior of x (module notes, step 2).
///
/// Its mode is searched by bounded least squares over the residuals (ȳ − μ)/√(τ² + s²), which lack
/// the likelihood's ln(τ² + s²): away from the runs, where s² is large, they are small, and the
/// search can end there, far from where the posterior's mass is. The draws around it then show
/// it: when one has a higher posterior density than that point, the search is repeated from it
/// and the posterior drawn again around what it finds.
pub fn posterior(bounds: &Bounds, sites: &[Site], emus: &[SiteEmulators], seed: u64) -> Posterior {
    let p = bounds.dim();
    // One residual per training output whatever θ is (the Jacobian differences residual vectors):
    // `None` where the output's emulator cannot predict at θ, which then adds nothing there.
    let parts = |t: &DVector<f64>| -> Vec<Option<f64>> {
        let pred = predict(emus, t.as_slice());
        sites
            .iter()
            .zip(&pred)
            .filter(|(s, _)| s.training)
            .flat_map(|(s, p)| {
                p.iter().enumerate().map(move |(k, &(mu, s2))| {
                    Some((s.observed[k] - mu) / (s.noise[k] + s2).sqrt()).filter(|r| r.is_finite())
                })
            })
            .collect()
    };
    let residuals = |t: &DVector<f64>| {
        let r = parts(t);
        DVector::from_iterator(r.len(), r.into_iter().map(|v| v.unwrap_or(0.0)))
    };
    let around = |mode: DVector<f64>| {
        // Where the model misses the tests (χ² per test above 1 at the mode), θ's posterior under
        // the model alone is too sure of itself: the tests' noise is scaled by that dispersion
        // (quasi-likelihood, McCullagh & Nelder 1989, §9.2), so the runs spread over where an
        // explanation of the misfit may put θ. A model that fits is left as it is.
        let r: Vec<f64> = parts(&mode).into_iter().flatten().collect();
        let phi = (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).max(1.0);
        let cov = laplace(&residuals, &mode, bounds) * phi;
        let draws = proposal_draws(bounds, &mode, &cov, seed);
        let nlp = neg_log_posterior(bounds, sites, emus, &draws, phi);
        let at_mode = neg_log_posterior(
            bounds,
            sites,
            emus,
            &DMatrix::from_row_slice(1, p, mode.as_slice()),
            phi,
        )[0];
        Drawn {
            mode,
            cov,
            draws,
            nlp,
            at_mode,
            phi,
        }
    };
    let centre = DVector::from_iterator(p, (0..p).map(|j| 0.5 * (bounds.lower[j] + bounds.upper[j])));
    let mut drawn = around(optimize::least_squares(&residuals, bounds).map_or(centre, |m| m.theta));
    if let Some(better) = drawn.better_draw() {
        let found = optimize::least_squares_from(&residuals, bounds, &better).map_or(better.clone(), |m| m.theta);
        let both = DMatrix::from_rows(&[found.transpose(), better.transpose()]);
        let nlp = neg_log_posterior(bounds, sites, emus, &both, drawn.phi);
        drawn = around(if nlp[0] <= nlp[1] { found } else { better });
    }
    drawn.weighted()
}

/// Draws from the proposal around a mode, with −ln p at each and at the mode.
struct Drawn {
    mode: DVector<f64>,
    cov: DMatrix<f64>,
    draws: DMatrix<f64>,
    nlp: Vec<f64>,
    at_mode: f64,
    /// The dispersion the tests' noise was scaled by.
    phi: f64,
}

impl Drawn {
    /// The draw of highest posterior density, where the mode lies outside its 95 % region: where
    /// −ln p there is lower than at the mode by more than χ²₁(0.95)/2 = 1.92. Closer, the two
    /// differ only by the slow ln(τ² + s²) near the runs and the mode is in the posterior's bulk.
    fn better_draw(&self) -> Option<DVector<f64>> {
        let (i, best) = self.nlp.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
        (*best < self.at_mode - 1.92).then(|| self.draws.row(i).transpose())
    }

    /// The posterior as importance-weighted draws (weights p/q). Its mode is the search's, or the
    /// best draw where that still beats it clearly after the second search.
    fn weighted(self) -> Posterior {
        let mode = self.better_draw().unwrap_or_else(|| self.mode.clone());
        let logq: Vec<f64> = self
            .draws
            .row_iter()
            .map(|r| log_proposal(&self.mode, &self.cov, &r.transpose()))
            .collect();
        let logw: Vec<f64> = self.nlp.iter().zip(&logq).map(|(n, q)| -n - q).collect();
        let top = logw
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        let raw: Vec<f64> = logw
            .iter()
            .map(|v| if v.is_finite() { (v - top).exp() } else { 0.0 })
            .collect();
        let total: f64 = raw.iter().sum();
        let weights: Vec<f64> = raw.iter().map(|w| w / total.max(f64::MIN_POSITIVE)).collect();
        summarise(self.draws, weights, mode.as_slice().to_vec())
    }
}

/// The Gauss–Newton covariance (JᵀJ)⁻¹ at the mode, inflated where the Jacobian is flat so that the
/// proposal still spans a part of the box. The Jacobian is differenced in the unit cube (the step
/// [`optimize::jacobian`] is made for) and scaled back to the box's units column by column.
fn laplace(residuals: &impl Fn(&DVector<f64>) -> DVector<f64>, mode: &DVector<f64>, bounds: &Bounds) -> DMatrix<f64> {
    let p = mode.len();
    let w = bounds.width();
    let in_cube = |u: &DVector<f64>| residuals(&bounds.from_unit(u));
    let mut j = optimize::jacobian(&in_cube, &bounds.to_unit(mode));
    for (c, wc) in w.iter().enumerate() {
        j.column_mut(c).unscale_mut(*wc);
    }
    let info = j.transpose() * &j;
    let floor = DMatrix::from_fn(p, p, |a, b| if a == b { (4.0 / w[a]).powi(2) } else { 0.0 });
    (info + floor)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_fn(p, p, |a, b| if a == b { (w[a] / 4.0).powi(2) } else { 0.0 }))
}

/// The proposal's spread: the Laplace covariance widened by this factor (in standard deviations),
/// so that the draws cover the posterior's tails as well as its bulk.
const WIDEN: f64 = 2.0;

/// Draws from N(mode, WIDEN² cov), redrawn until inside the box (the truncation's constant cancels
/// in the normalised weights).
fn proposal_draws(bounds: &Bounds, mode: &DVector<f64>, cov: &DMatrix<f64>, seed: u64) -> DMatrix<f64> {
    let p = mode.len();
    let l = cov
        .clone()
        .cholesky()
        .map(|c| c.l())
        .unwrap_or_else(|| DMatrix::from_diagonal(&cov.diagonal().map(f64::sqrt)));
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9057_e410);
    let mut out = DMatrix::zeros(DRAWS, p);
    for i in 0..DRAWS {
        let x = (0..1000)
            .map(|_| {
                let z = DVector::from_fn(p, |_, _| gauss(&mut rng));
                mode + &l * z * WIDEN
            })
            .find(|x| (0..p).all(|j| x[j] >= bounds.lower[j] && x[j] <= bounds.upper[j]))
            .unwrap_or_else(|| mode.clone());
        out.set_row(i, &x.transpose());
    }
    out
}

fn log_proposal(mode: &DVector<f64>, cov: &DMatrix<f64>, x: &DVector<f64>) -> f64 {
    let c = cov * (WIDEN * WIDEN);
    match c.clone().cholesky() {
        Some(ch) => {
            let d = x - mode;
            let z = ch.l().solve_lower_triangular(&d).unwrap_or(d);
            -0.5 * z.norm_squared() - ch.l().diagonal().iter().map(|v| v.ln()).sum::<f64>()
        }
        None => 0.0,
    }
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Weighted mean and 95 % quantile interval per coordinate.
fn summarise(points: DMatrix<f64>, weights: Vec<f64>, mode: Vec<f64>) -> Posterior {
    let p = points.ncols();
    let mean: Vec<f64> = (0..p)
        .map(|j| points.column(j).iter().zip(&weights).map(|(x, w)| x * w).sum())
        .collect();
    let interval = (0..p)
        .map(|j| {
            let mut order: Vec<(f64, f64)> = points.column(j).iter().copied().zip(weights.iter().copied()).collect();
            order.sort_by(|a, b| a.0.total_cmp(&b.0));
            [quantile(&order, 0.025), quantile(&order, 0.975)]
        })
        .collect();
    Posterior {
        points,
        weights,
        mode,
        mean,
        interval,
    }
}

/// The `q` quantile of sorted weighted values.
fn quantile(sorted: &[(f64, f64)], q: f64) -> f64 {
    let mut acc = 0.0;
    for &(x, w) in sorted {
        acc += w;
        if acc >= q {
            return x;
        }
    }
    sorted.last().map_or(f64::NAN, |v| v.0)
}

/// A site's emulator error at the posterior, predicted: √(Σ_e w_e s²(e)/τ²), the largest over its
/// outputs (infinite where an output has no emulator).
pub fn predicted_error(site: &Site, emus: &SiteEmulators, posterior: &Posterior) -> f64 {
    let points = emus.rows(&posterior.points);
    emus.outputs
        .iter()
        .enumerate()
        .map(|(k, e)| {
            let Some(e) = e else { return f64::INFINITY };
            let Some((_, var)) = e.mean_var(&points) else {
                return f64::INFINITY;
            };
            let v: f64 = var.iter().zip(&posterior.weights).map(|(s2, w)| w * s2.max(0.0)).sum();
            (v / site.noise[k]).sqrt()
        })
        .fold(0.0, f64::max)
}

/// The next `q` runs among the `open` sites (module notes, step 3): each open site gets one run
/// before any gets a second, in order of value; each at the candidate of most value. With one
/// emulator across the designs ([`shared::emulators`]) the runs go wherever they are worth most
/// over every open site at once ([`shared`]).
pub fn choose(
    bounds: &Bounds,
    sites: &[Site],
    emus: &[SiteEmulators],
    posterior: &Posterior,
    open: &[bool],
    q: usize,
    seed: u64,
) -> Vec<(usize, Vec<f64>)> {
    if emus.iter().any(|e| !e.at.is_empty()) {
        return shared::choose(bounds, sites, emus, posterior, open, q, seed);
    }
    let (scaled, candidates) = candidates(bounds, posterior, seed);
    let mut gains = site_gains(sites, emus, posterior, open, &candidates);
    let mut picks = space_filling_picks(bounds, sites, open, &gains, &scaled, q);
    let mut given = vec![0usize; sites.len()];
    for (i, _) in &picks {
        given[*i] += 1;
    }
    // A candidate that snaps onto a run the site has, or onto a pick of this batch, would only repeat it.
    let snapped: Vec<Vec<f64>> = candidates
        .row_iter()
        .map(|r| snap(bounds, r.transpose().as_slice()))
        .collect();
    take_repeats(bounds, sites, &picks, &snapped, &mut gains);
    while picks.len() < q {
        let Some((site, (c, v))) = next_best(&gains, &given) else {
            break;
        };
        if v == f64::NEG_INFINITY {
            // Every candidate of the site repeats a run: it gets no more in this batch.
            gains[site] = None;
            continue;
        }
        picks.push((site, snapped[c].clone()));
        given[site] += 1;
        if let Some(g) = gains[site].as_mut() {
            g.condition(c);
            g.take(&snapped, &snapped[c]);
        }
    }
    picks
}

/// Each open site's gain over the `candidates` (`None` for a closed site, or one without
/// emulators), the sites in parallel (independent of one another).
fn site_gains(
    sites: &[Site],
    emus: &[SiteEmulators],
    posterior: &Posterior,
    open: &[bool],
    candidates: &DMatrix<f64>,
) -> Vec<Option<Gain>> {
    use rayon::prelude::*;
    sites
        .par_iter()
        .zip(emus)
        .zip(open)
        .map(|((s, e), &o)| o.then(|| Gain::of_site(s, e, &posterior.weights, candidates)).flatten())
        .collect()
}

/// The first picks of a batch (at most `q`): an open site without emulators (too few runs to fit
/// them) gets a space-filling run first, the candidate of the box (`scaled`) farthest from its runs.
fn space_filling_picks(
    bounds: &Bounds,
    sites: &[Site],
    open: &[bool],
    gains: &[Option<Gain>],
    scaled: &DMatrix<f64>,
    q: usize,
) -> Vec<(usize, Vec<f64>)> {
    let mut picks: Vec<(usize, Vec<f64>)> = Vec::new();
    for (i, s) in sites.iter().enumerate() {
        if open[i] && gains[i].is_none() && picks.len() < q {
            picks.push((i, snap(bounds, &farthest(scaled, &s.x, bounds))));
        }
    }
    picks
}

/// Marks, in each site's gain, the candidates whose `snapped` point is one of the site's runs or
/// one of its `picks` in this batch: they would only repeat it.
fn take_repeats(
    bounds: &Bounds,
    sites: &[Site],
    picks: &[(usize, Vec<f64>)],
    snapped: &[Vec<f64>],
    gains: &mut [Option<Gain>],
) {
    for (i, g) in gains.iter_mut().enumerate() {
        if let Some(g) = g.as_mut() {
            for x in sites[i]
                .x
                .iter()
                .chain(picks.iter().filter(|(s, _)| *s == i).map(|(_, x)| x))
            {
                g.take(snapped, &snap(bounds, x));
            }
        }
    }
}

/// The next pick's site and its best candidate with that candidate's value, among the sites with
/// a gain that have been `given` the fewest runs so far (each site one run before any gets a
/// second; ties to the first site); `None` when no site has a gain left.
fn next_best(gains: &[Option<Gain>], given: &[usize]) -> Option<(usize, (usize, f64))> {
    let round = given
        .iter()
        .zip(gains)
        .filter(|(_, g)| g.is_some())
        .map(|(n, _)| *n)
        .min()?;
    gains
        .iter()
        .enumerate()
        .filter(|(i, g)| g.is_some() && given[*i] == round)
        .filter_map(|(i, g)| g.as_ref().map(|g| (i, g.best())))
        .fold(None, |acc: Option<(usize, (usize, f64))>, (i, b)| match acc {
            Some((_, (_, v))) if v >= b.1 => acc,
            _ => Some((i, b)),
        })
}

/// A batch's candidates (module notes): the seeded space-filling points of the box, and every
/// candidate in order (the posterior's points, then the space-filling ones).
fn candidates(bounds: &Bounds, posterior: &Posterior, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    let fill = latin_hypercube(FILL, bounds.dim(), seed ^ 0xf111);
    let spread = bounds.spread_rows(&fill);
    let scaled = DMatrix::from_fn(FILL, bounds.dim(), |i, j| spread[i][j]);
    let all = stack(&posterior.points, &scaled);
    (scaled, all)
}

/// The row of `candidates` whose nearest run (in units of the box) is farthest (maximin).
fn farthest(candidates: &DMatrix<f64>, runs: &[Vec<f64>], bounds: &Bounds) -> Vec<f64> {
    let w = bounds.width();
    let nearest = |i: usize| {
        runs.iter()
            .map(|r| {
                (0..r.len())
                    .map(|j| ((candidates[(i, j)] - r[j]) / w[j]).powi(2))
                    .sum::<f64>()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let best = (0..candidates.nrows()).fold((0, f64::NEG_INFINITY), |acc, i| {
        let d = nearest(i);
        if d > acc.1 { (i, d) } else { acc }
    });
    candidates.row(best.0).iter().copied().collect()
}

fn stack(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows() + b.nrows(), a.ncols(), |i, j| {
        if i < a.nrows() {
            a[(i, j)]
        } else {
            b[(i - a.nrows(), j)]
        }
    })
}

/// The covariance of the candidates, per output, updated as runs are added; each row and column
/// scaled by 1/τ of its site's output, so that c(a, x*)² / c(x*, x*) is the variance a run at x*
/// removes at a, in units of the tests' noise there. The points the answer depends on (the
/// posterior's, at the sites still open) are candidates too and carry their posterior weight; the
/// other candidates weigh nothing.
struct Gain {
    cov: Vec<DMatrix<f64>>,
    /// Per candidate: its posterior weight, or 0.
    weights: Vec<f64>,
    /// Candidates that would repeat a run (see [`Gain::take`]).
    taken: Vec<bool>,
}

impl Gain {
    fn new(cov: Vec<DMatrix<f64>>, weights: Vec<f64>) -> Gain {
        let n = weights.len();
        Gain {
            cov,
            weights,
            taken: vec![false; n],
        }
    }

    /// One site's gain over the candidates `c`, whose first rows are the posterior's points `w`
    /// weighs.
    fn of_site(site: &Site, emus: &SiteEmulators, w: &[f64], c: &DMatrix<f64>) -> Option<Gain> {
        let rows = emus.rows(c);
        let cov: Option<Vec<DMatrix<f64>>> = emus
            .outputs
            .iter()
            .enumerate()
            .map(|(k, em)| em.as_ref()?.mean_cov(&rows).map(|(_, cv)| cv / site.noise[k]))
            .collect();
        let weights = (0..c.nrows()).map(|i| w.get(i).copied().unwrap_or(0.0)).collect();
        Some(Gain::new(cov?, weights))
    }

    /// Marks every candidate whose snapped point is `x` as taken.
    fn take(&mut self, snapped: &[Vec<f64>], x: &[f64]) {
        for (t, s) in self.taken.iter_mut().zip(snapped) {
            *t |= s.as_slice() == x;
        }
    }

    /// The candidate of most value and that value: Σ_k Σ_e w_e c_k(e, x*)² / c_k(x*, x*).
    fn best(&self) -> (usize, f64) {
        let n = self.weights.len();
        let targets: Vec<usize> = (0..n).filter(|&i| self.weights[i] > 0.0).collect();
        (0..n)
            .map(|c| {
                if self.taken[c] {
                    return (c, f64::NEG_INFINITY);
                }
                let v: f64 = self
                    .cov
                    .iter()
                    .map(|m| {
                        let var = m[(c, c)];
                        if var <= 1e-300 {
                            return 0.0;
                        }
                        let col = m.column(c);
                        targets.iter().map(|&i| self.weights[i] * col[i].powi(2)).sum::<f64>() / var
                    })
                    .sum();
                (c, v)
            })
            .fold(
                (0, f64::NEG_INFINITY),
                |acc, (c, v)| if v > acc.1 { (c, v) } else { acc },
            )
    }

    /// The covariances once a run at candidate `c` is in: c(a, b) − c(a, x*) c(x*, b) / c(x*, x*),
    /// a rank-one update in place.
    fn condition(&mut self, c: usize) {
        for m in &mut self.cov {
            let var = m[(c, c)];
            if var <= 1e-300 {
                continue;
            }
            let col = m.column(c).clone_owned();
            m.ger(-1.0 / var, &col, &col, 1.0);
        }
    }
}

#[cfg(test)]
mod tests;
