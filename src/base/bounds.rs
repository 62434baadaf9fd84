//! A box of variables: parameters, designs, or both.

use nalgebra::{DMatrix, DVector};

/// A box `lower ≤ x ≤ upper`, one interval per coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    pub lower: DVector<f64>,
    pub upper: DVector<f64>,
}

impl Bounds {
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Self {
        assert_eq!(lower.len(), upper.len(), "bounds need as many lower as upper values");
        Bounds {
            lower: DVector::from_vec(lower),
            upper: DVector::from_vec(upper),
        }
    }

    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    pub fn width(&self) -> DVector<f64> {
        &self.upper - &self.lower
    }

    pub fn center(&self) -> DVector<f64> {
        (&self.upper + &self.lower) / 2.0
    }

    /// Maps `x` into the unit cube.
    pub fn to_unit(&self, x: &DVector<f64>) -> DVector<f64> {
        (x - &self.lower).component_div(&self.width())
    }

    /// Maps a point of the unit cube back into the box.
    pub fn from_unit(&self, u: &DVector<f64>) -> DVector<f64> {
        &self.lower + u.component_mul(&self.width())
    }

    /// Whether coordinate `k` is spread uniformly in ln x ([`Bounds::spread`]): a positive range
    /// wider than [`LOG_SPREAD_RATIO`].
    pub fn spread_in_ln(&self, k: usize) -> bool {
        self.lower[k] > 0.0 && self.upper[k] > LOG_SPREAD_RATIO * self.lower[k]
    }

    /// The point of the box a sampling design puts at `u` of the unit cube: linearly, except over a
    /// positive range wider than a decade, where uniformly in ln x. Such a variable (a Cowper–Symonds
    /// C from 1,000 to 40,000 /s, a stiffness over decades) acts per decade, not per unit: spread
    /// linearly, 24 runs would put one in its lowest decade, where (ε̇/C)^(1/p) changes most.
    pub fn spread(&self, u: &[f64]) -> Vec<f64> {
        (0..self.dim())
            .map(|k| {
                let (lo, hi) = (self.lower[k], self.upper[k]);
                if self.spread_in_ln(k) {
                    (lo.ln() + u[k] * (hi.ln() - lo.ln())).exp().clamp(lo, hi)
                } else {
                    lo + u[k] * (hi - lo)
                }
            })
            .collect()
    }

    /// [`Bounds::spread`] of every row of `unit` (a sampling design in the unit cube).
    pub fn spread_rows(&self, unit: &DMatrix<f64>) -> Vec<Vec<f64>> {
        unit.row_iter()
            .map(|u| self.spread(&u.iter().copied().collect::<Vec<_>>()))
            .collect()
    }
}

/// Upper/lower ratio above which a positive range is spread uniformly in ln x ([`Bounds::spread`]).
pub const LOG_SPREAD_RATIO: f64 = 10.0;
