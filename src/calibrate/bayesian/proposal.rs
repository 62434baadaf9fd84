//! The independence proposal of the sampler's main run: a multivariate Student t fitted to earlier
//! draws, mixed with the uniform density on the sampling box.
//!
//! In coordinates where the posterior is nearly Gaussian ([`super::coords`]), a t with the draws'
//! mean and covariance as location and scale proposes points the posterior accepts most of the
//! time, each proposal independent of the walker's position, so the chain forgets its past in a
//! step or two instead of the tens a local move needs. The t's tails (ν = 5, variance 5/3 of the
//! scale) and the uniform share (the defensive mixture of Hesterberg 1995, *Technometrics* 37:185)
//! keep the ratio posterior / proposal bounded over the box, which makes independence
//! Metropolis–Hastings uniformly ergodic (Mengersen & Tweedie 1996, Thm 2.1): a proposal that fits
//! badly costs speed, which the convergence checks see, never correctness.

use nalgebra::{DMatrix, DVector};
use rand::Rng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use statrs::function::gamma::ln_gamma;

/// Degrees of freedom of the kernels and of the wide component.
const NU: f64 = 5.0;
const NU_WIDE: f64 = 3.0;
/// Share of the wide component and its scale relative to the draws' spread.
const WIDE: f64 = 0.2;
const WIDE_SCALE: f64 = 2.0;
/// Share of the uniform density on the unit box.
const DEFENSIVE: f64 = 0.05;
/// Most kernels: the draws are thinned evenly to this many centres.
const MAX_CENTRES: usize = 1000;

/// A multivariate Student t family member with location(s) and a lower-triangular scale:
/// one location for the wide component, one per centre for the kernel estimate.
#[derive(Debug, Clone)]
struct StudentT {
    nu: f64,
    /// Lower-triangular scale S (the covariance is ν/(ν−2) SSᵀ).
    scale: DMatrix<f64>,
    /// The locations whitened, S⁻¹ c_j, one column each.
    centres: DMatrix<f64>,
    /// ln of one member's normalising constant (ln|S| included) minus ln of the number of centres.
    log_norm: f64,
    chi2: ChiSquared<f64>,
}

impl StudentT {
    fn new(nu: f64, scale: DMatrix<f64>, locations: &[&[f64]]) -> Option<Self> {
        let p = scale.nrows();
        let raw = DMatrix::from_fn(p, locations.len(), |k, j| locations[j][k]);
        let centres = scale.solve_lower_triangular(&raw)?;
        let log_det: f64 = scale.diagonal().iter().map(|d| d.ln()).sum();
        let pf = p as f64;
        let log_norm = ln_gamma((nu + pf) / 2.0)
            - ln_gamma(nu / 2.0)
            - pf / 2.0 * (nu * std::f64::consts::PI).ln()
            - log_det
            - (locations.len() as f64).ln();
        log_norm.is_finite().then_some(StudentT {
            nu,
            scale,
            centres,
            log_norm,
            chi2: ChiSquared::new(nu).ok()?,
        })
    }

    /// A centre at random, then c_j + S g √(ν/w), g ~ N(0, I), w ~ χ²_ν.
    fn sample(&self, rng: &mut impl Rng) -> DVector<f64> {
        let j = rng.random_range(0..self.centres.ncols());
        let g = DVector::from_fn(self.scale.nrows(), |_, _| rng.sample::<f64, _>(StandardNormal));
        let w = self.chi2.sample(rng);
        &self.scale * (self.centres.column(j) + g * (self.nu / w).sqrt())
    }

    /// ln of the equal-weight mixture over the centres (log-sum-exp).
    fn log_density(&self, x: &DVector<f64>) -> f64 {
        let y = self.scale.solve_lower_triangular(x).expect("positive diagonal");
        let power = -(self.nu + self.scale.nrows() as f64) / 2.0;
        let terms: Vec<f64> = self
            .centres
            .column_iter()
            .map(|c| power * ((c - &y).norm_squared() / self.nu).ln_1p())
            .collect();
        let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        self.log_norm + top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln()
    }
}

fn in_box(z: &[f64]) -> bool {
    z.iter().all(|v| (0.0..=1.0).contains(v))
}

/// q(z) ∝ (1 − ω − ε) K(z) + ω T(z) + ε on the unit box: K the kernel estimate of the draws
/// (Student-t kernels, bandwidth by Scott's rule, scale the draws' covariance), T a wide t over
/// the draws' mean and covariance, ε the uniform density.
#[derive(Debug, Clone)]
pub struct Proposal {
    kernels: StudentT,
    wide: StudentT,
}

impl Proposal {
    /// The proposal of the draws (points of the unit box); `None` with fewer draws than twice the
    /// dimension or a covariance that is not positive definite.
    pub fn fit(draws: &[Vec<f64>]) -> Option<Self> {
        let p = draws.first()?.len();
        let n = draws.len();
        if n < 2 * p.max(1) {
            return None;
        }
        let x = DMatrix::from_fn(n, p, |i, k| draws[i][k]);
        let mean: Vec<f64> = x.row_mean().iter().copied().collect();
        let centred = DMatrix::from_fn(n, p, |i, k| x[(i, k)] - mean[k]);
        let chol = (centred.tr_mul(&centred) / (n as f64 - 1.0)).cholesky()?.l();
        let kept: Vec<&[f64]> = draws
            .iter()
            .step_by(n.div_ceil(MAX_CENTRES))
            .map(Vec::as_slice)
            .collect();
        // Scott's rule, h = N^(−1/(d+4)), for N centres in d dimensions.
        let h = (kept.len() as f64).powf(-1.0 / (p as f64 + 4.0));
        Some(Proposal {
            kernels: StudentT::new(NU, &chol * h, &kept)?,
            wide: StudentT::new(NU_WIDE, chol * WIDE_SCALE, &[&mean])?,
        })
    }

    pub fn dim(&self) -> usize {
        self.kernels.scale.nrows()
    }

    /// One draw of q on the unit box: the mixture is drawn again until its draw falls inside (the
    /// uniform share alone does one time in 1/ε). The density of what is returned is q(z)/Q(box),
    /// a constant that cancels in the Metropolis–Hastings ratio, so [`Proposal::log_density`]
    /// serves it unchanged, and no move is spent on a point outside the box.
    pub fn sample(&self, rng: &mut impl Rng) -> Vec<f64> {
        loop {
            let pick = rng.random::<f64>();
            if pick < DEFENSIVE {
                return (0..self.dim()).map(|_| rng.random::<f64>()).collect();
            }
            let z = if pick < DEFENSIVE + WIDE {
                self.wide.sample(rng)
            } else {
                self.kernels.sample(rng)
            };
            if in_box(z.as_slice()) {
                return z.iter().copied().collect();
            }
        }
    }

    /// ln q(z) (up to the box's mass).
    pub fn log_density(&self, z: &[f64]) -> f64 {
        let x = DVector::from_column_slice(z);
        let k = (1.0 - DEFENSIVE - WIDE) * self.kernels.log_density(&x).exp();
        let t = WIDE * self.wide.log_density(&x).exp();
        let u = if in_box(z) { DEFENSIVE } else { 0.0 };
        (k + t + u).ln()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use statrs::distribution::{Continuous, StudentsT};

    fn gaussian_draws(n: usize, mean: &[f64], sd: &[f64], seed: u64) -> Vec<Vec<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                mean.iter()
                    .zip(sd)
                    .map(|(m, s)| m + s * rng.sample::<f64, _>(StandardNormal))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn one_dimensional_density_is_the_statrs_mixture() {
        // An independent implementation of the t density (statrs): kernels at every draw with
        // scale h·s (s the draws' sd, h = 500^(−1/5) by Scott's rule), the wide t at their mean
        // with scale 2s, the uniform share inside the box.
        let draws = gaussian_draws(500, &[0.4], &[0.05], 1);
        let q = Proposal::fit(&draws).unwrap();
        let n = draws.len() as f64;
        let mean = draws.iter().map(|d| d[0]).sum::<f64>() / n;
        let sd = (draws.iter().map(|d| (d[0] - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let h = n.powf(-0.2);
        let kernels: Vec<StudentsT> = draws
            .iter()
            .map(|c| StudentsT::new(c[0], h * sd, 5.0).unwrap())
            .collect();
        let wide = StudentsT::new(mean, 2.0 * sd, 3.0).unwrap();
        for x in [0.2, 0.37, 0.4, 0.55, 0.9, 1.3] {
            let uniform = if x <= 1.0 { 0.05 } else { 0.0 };
            let kde = kernels.iter().map(|t| t.pdf(x)).sum::<f64>() / n;
            let expected = (0.75 * kde + 0.2 * wide.pdf(x) + uniform).ln();
            let got = q.log_density(&[x]);
            assert!((got - expected).abs() < 1e-10, "{x}: {got} vs {expected}");
        }
    }

    /// q's mass over [lo, hi] by the midpoint rule on a `cells`² grid.
    fn mass(q: &Proposal, lo: [f64; 2], hi: [f64; 2], cells: usize) -> f64 {
        let (dx, dy) = ((hi[0] - lo[0]) / cells as f64, (hi[1] - lo[1]) / cells as f64);
        (0..cells * cells)
            .map(|c| {
                let x = [
                    lo[0] + (c % cells) as f64 * dx + dx / 2.0,
                    lo[1] + (c / cells) as f64 * dy + dy / 2.0,
                ];
                q.log_density(&x).exp() * dx * dy
            })
            .sum()
    }

    #[test]
    fn draws_follow_the_density_restricted_to_the_box() {
        // The share of 40,000 draws in a sub-box against the density's mass there over its mass
        // in the unit box (the draws are q restricted to the box): equal within 4 binomial
        // standard errors. Every draw lies in the box.
        let draws = gaussian_draws(400, &[0.5, 0.3], &[0.1, 0.05], 2);
        let q = Proposal::fit(&draws).unwrap();
        let (lo, hi) = ([0.45, 0.28], [0.65, 0.40]);
        let share = mass(&q, lo, hi, 200) / mass(&q, [0.0; 2], [1.0; 2], 800);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 40_000;
        let sample: Vec<Vec<f64>> = (0..n).map(|_| q.sample(&mut rng)).collect();
        assert!(sample.iter().all(|x| in_box(x)));
        let inside = sample
            .iter()
            .filter(|x| (0..2).all(|k| (lo[k]..hi[k]).contains(&x[k])))
            .count() as f64
            / n as f64;
        let se = (share * (1.0 - share) / n as f64).sqrt();
        assert!((inside - share).abs() < 4.0 * se, "share {inside} vs {share} (se {se})");
    }

    #[test]
    fn too_few_or_degenerate_draws_give_no_proposal() {
        assert!(Proposal::fit(&gaussian_draws(3, &[0.5, 0.5], &[0.1, 0.1], 4)).is_none());
        let flat: Vec<Vec<f64>> = (0..50).map(|i| vec![i as f64 / 50.0, 0.5]).collect();
        assert!(Proposal::fit(&flat).is_none());
    }
}
