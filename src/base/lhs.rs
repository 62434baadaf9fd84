//! Latin hypercube sampling in the unit cube.

use nalgebra::DMatrix;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `n` points in `[0, 1]^dim`, one per row, such that every column has exactly one point in each
/// of the `n` equal strata. The same seed always gives the same plan.
pub fn latin_hypercube(n: usize, dim: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut plan = DMatrix::zeros(n, dim);
    for j in 0..dim {
        let mut strata: Vec<usize> = (0..n).collect();
        strata.shuffle(&mut rng);
        for (i, s) in strata.into_iter().enumerate() {
            plan[(i, j)] = (s as f64 + rng.random::<f64>()) / n as f64;
        }
    }
    plan
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_point_per_stratum_in_every_column() {
        let plan = latin_hypercube(24, 3, 7);
        for j in 0..3 {
            let mut strata: Vec<usize> = plan.column(j).iter().map(|v| (v * 24.0).floor() as usize).collect();
            strata.sort();
            assert_eq!(strata, (0..24).collect::<Vec<_>>());
        }
    }

    #[test]
    fn seeded_and_reproducible() {
        assert_eq!(latin_hypercube(10, 2, 3), latin_hypercube(10, 2, 3));
        assert_ne!(latin_hypercube(10, 2, 3), latin_hypercube(10, 2, 4));
    }
}
