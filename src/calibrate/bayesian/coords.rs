//! Sampling coordinates: per parameter a power of θ (the Box–Cox family θ^λ, ln θ at λ = 0) in
//! which the posterior is least curved.
//!
//! An affine-invariant ensemble mixes fast on any posterior that is an affine image of a round one,
//! and slowly on a curved ridge. Many physical parameters enter a response through their reciprocal
//! (a compliance, 1/E) or their logarithm, so the ridge that is curved in θ is often straight in
//! θ^λ. The change of variables carries its Jacobian, so the posterior sampled is the same in any
//! coordinates: the choice changes only the speed. It is made from a pilot run by the curvature of
//! the pilot's draws: whitened, how much of each principal direction a quadratic in the others
//! explains (Σ R², zero for a Gaussian).

use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// The powers tried (reciprocal, inverse root, logarithm, root, identity).
const POWERS: [f64; 5] = [-1.0, -0.5, 0.0, 0.5, 1.0];

/// Per parameter its power and bounds; maps between θ's unit box (u) and the sampling box (z).
#[derive(Debug, Clone, PartialEq)]
pub struct Coords {
    pub power: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

fn g(power: f64, theta: f64) -> f64 {
    if power == 0.0 { theta.ln() } else { theta.powf(power) }
}

fn g_inv(power: f64, v: f64) -> f64 {
    if power == 0.0 { v.exp() } else { v.powf(1.0 / power) }
}

impl Coords {
    /// θ's own unit box.
    pub fn identity(lower: &[f64], upper: &[f64]) -> Self {
        Coords {
            power: vec![1.0; lower.len()],
            lower: lower.to_vec(),
            upper: upper.to_vec(),
        }
    }

    /// Whether parameter k may take a power other than 1 (its box is positive).
    fn may_bend(&self, k: usize) -> bool {
        self.lower[k] > 0.0
    }

    fn theta(&self, k: usize, u: f64) -> f64 {
        self.lower[k] + u * (self.upper[k] - self.lower[k])
    }

    /// z of θ's unit coordinates u.
    pub fn to_z(&self, u: &[f64]) -> Vec<f64> {
        (0..u.len())
            .map(|k| {
                let p = self.power[k];
                if p == 1.0 {
                    return u[k];
                }
                let (a, b) = (g(p, self.lower[k]), g(p, self.upper[k]));
                (g(p, self.theta(k, u[k])) - a) / (b - a)
            })
            .collect()
    }

    /// θ's unit coordinates at z, and ln |∂u/∂z| up to a constant: Σ (1 − λ_k) ln θ_k.
    pub fn to_u(&self, z: &[f64]) -> (Vec<f64>, f64) {
        let mut log_jacobian = 0.0;
        let u = (0..z.len())
            .map(|k| {
                let p = self.power[k];
                if p == 1.0 {
                    return z[k];
                }
                let (a, b) = (g(p, self.lower[k]), g(p, self.upper[k]));
                let theta = g_inv(p, a + z[k] * (b - a));
                log_jacobian += (1.0 - p) * theta.ln();
                ((theta - self.lower[k]) / (self.upper[k] - self.lower[k])).clamp(0.0, 1.0)
            })
            .collect();
        (u, log_jacobian)
    }

    /// The coordinates in which `draws` (θ's unit coordinates) are least curved, by cyclic search
    /// over each parameter's power (two sweeps, identity kept unless another power is straighter).
    pub fn choose(lower: &[f64], upper: &[f64], draws: &[Vec<f64>]) -> Self {
        let mut best = Coords::identity(lower, upper);
        let mut best_curvature = curvature(&best.mapped(draws));
        let bendable: Vec<usize> = (0..lower.len()).filter(|&k| best.may_bend(k)).collect();
        for _ in 0..2 {
            for &k in &bendable {
                for p in POWERS {
                    let mut c = best.clone();
                    c.power[k] = p;
                    let value = curvature(&c.mapped(draws));
                    if value < best_curvature - 1e-3 {
                        (best, best_curvature) = (c, value);
                    }
                }
            }
        }
        best
    }

    fn mapped(&self, draws: &[Vec<f64>]) -> Vec<Vec<f64>> {
        draws.iter().map(|u| self.to_z(u)).collect()
    }
}

/// Σ over principal directions of the whitened draws of the R² of a least-squares fit of that
/// direction by the products of the others (linear terms explain nothing: the directions are
/// uncorrelated). 0 for a Gaussian, up to the dimension for draws on a parabola.
pub fn curvature(draws: &[Vec<f64>]) -> f64 {
    let (n, d) = (draws.len(), draws.first().map_or(0, Vec::len));
    if d < 2 || n < 10 * d * d {
        return 0.0;
    }
    let x = DMatrix::from_fn(n, d, |i, k| draws[i][k]);
    let mean = x.row_mean();
    let centred = DMatrix::from_fn(n, d, |i, k| x[(i, k)] - mean[k]);
    let cov = centred.transpose() * &centred / (n as f64 - 1.0);
    let eig = SymmetricEigen::new(cov);
    if eig.eigenvalues.iter().any(|&v| v <= 0.0 || !v.is_finite()) {
        return 0.0;
    }
    let scale = DMatrix::from_diagonal(&eig.eigenvalues.map(|v| 1.0 / v.sqrt()));
    let z = centred * eig.eigenvectors * scale;
    (0..d).map(|k| explained_by_products(&z, k)).sum()
}

/// R² of column k of z regressed on a constant and the products z_i z_j of the other columns.
fn explained_by_products(z: &DMatrix<f64>, k: usize) -> f64 {
    let others: Vec<usize> = (0..z.ncols()).filter(|&j| j != k).collect();
    let pairs: Vec<(usize, usize)> = others
        .iter()
        .enumerate()
        .flat_map(|(a, &i)| others[a..].iter().map(move |&j| (i, j)))
        .collect();
    let a = DMatrix::from_fn(z.nrows(), pairs.len() + 1, |r, c| {
        if c == 0 {
            1.0
        } else {
            z[(r, pairs[c - 1].0)] * z[(r, pairs[c - 1].1)]
        }
    });
    let y = DVector::from_fn(z.nrows(), |r, _| z[(r, k)]);
    let Ok(fit) = a.clone().svd(true, true).solve(&y, 1e-12) else {
        return 0.0;
    };
    let residual = (y.clone() - a * fit).norm_squared();
    let total = y.map(|v| v - y.mean()).norm_squared();
    if total > 0.0 { 1.0 - residual / total } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn gauss(rng: &mut ChaCha8Rng) -> f64 {
        let (u, v): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    #[test]
    fn maps_round_trip_with_the_jacobian_of_the_power() {
        let c = Coords {
            power: vec![-1.0, 0.0, 0.5, 1.0],
            lower: vec![50_000.0, 15_000.0, 1.0, -1.0],
            upper: vec![80_000.0, 40_000.0, 9.0, 1.0],
        };
        let u = [0.3, 0.7, 0.1, 0.4];
        let (back, lj) = c.to_u(&c.to_z(&u));
        for k in 0..4 {
            assert!((back[k] - u[k]).abs() < 1e-12, "{k}: {back:?}");
        }
        // ∂u/∂z by central differences, against the analytic ln-Jacobian up to its constant:
        // the difference of ln |∂u/∂z| between two points must match.
        let numeric = |z: &[f64]| -> f64 {
            (0..4)
                .map(|k| {
                    let (mut a, mut b) = (z.to_vec(), z.to_vec());
                    a[k] -= 1e-6;
                    b[k] += 1e-6;
                    ((c.to_u(&b).0[k] - c.to_u(&a).0[k]) / 2e-6).abs().ln()
                })
                .sum()
        };
        let (z1, z2) = (c.to_z(&u), c.to_z(&[0.8, 0.2, 0.6, 0.9]));
        let analytic = c.to_u(&z1).1 - c.to_u(&z2).1;
        assert!((numeric(&z1) - numeric(&z2) - analytic).abs() < 1e-6, "{lj}");
    }

    #[test]
    fn a_gaussian_has_no_curvature_and_a_parabola_has_much() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let round: Vec<Vec<f64>> = (0..4000).map(|_| (0..3).map(|_| gauss(&mut rng)).collect()).collect();
        assert!(curvature(&round) < 0.02, "{}", curvature(&round));
        let bent: Vec<Vec<f64>> = round
            .iter()
            .map(|v| vec![v[0], v[0] * v[0] + 0.1 * v[1], v[2]])
            .collect();
        assert!(curvature(&bent) > 0.9, "{}", curvature(&bent));
    }

    /// Draws that are Gaussian in (1/x, ln y, w) with a seeded random correlation, seen in the
    /// unit box of (x, y, w): the search must find the reciprocal and the logarithm, and keep w
    /// (its box is not positive).
    #[test]
    fn finds_the_powers_in_which_a_hidden_gaussian_is_straight() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let (lower, upper) = ([1.0, 1.0, -1.0], [10.0, 20.0, 1.0]);
        let rho: f64 = rng.random_range(0.6..0.9);
        let draws: Vec<Vec<f64>> = (0..3000)
            .map(|_| {
                let (a, b, c) = (gauss(&mut rng), gauss(&mut rng), gauss(&mut rng));
                let recip = 0.5 + 0.15 * a;
                let log_y = 1.5 + 0.45 * (rho * a + (1.0 - rho * rho).sqrt() * b);
                let w = 0.2 * (a + c) / 2.0;
                vec![1.0 / recip, log_y.exp(), w]
            })
            .filter(|t| (0..3).all(|k| (lower[k]..=upper[k]).contains(&t[k])))
            .map(|t| (0..3).map(|k| (t[k] - lower[k]) / (upper[k] - lower[k])).collect())
            .collect();
        let c = Coords::choose(&lower, &upper, &draws);
        assert_eq!(c.power, vec![-1.0, 0.0, 1.0]);
    }
}
