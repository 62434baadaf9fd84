//! The emulators' error where a decision reads them, as one value: measured on runs they were
//! not fitted to, and kept apart from the tests' noise (more specimens do not reduce it).

use nalgebra::{DMatrix, DVector};

use super::SurrogateModel;

/// The emulators' error at each observation a decision reads, in the response's units (Kennedy &
/// O'Hagan 2001 count the code's uncertainty in the likelihood; here it is measured at check runs,
/// not modelled). Empty: no emulator (a closed form), or none measured.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Uncertainty {
    /// Per observation, the mean square error at its design's check runs.
    variance: Vec<f64>,
    /// The error across the observations at each check point every observation's design was
    /// checked at (a fixed design checks every design at the same points): the error's shape
    /// across designs, whose second moment is its covariance.
    paired: Vec<DVector<f64>>,
    /// Where no check point is shared (a sequential design checks each design at its own latest
    /// runs, near the posterior): each observation's mean error over its check runs, the shape
    /// across designs those runs share; the spread about it is the rest of `variance`.
    means: Option<DVector<f64>>,
}

impl Uncertainty {
    /// Per-design surrogates' error at observations `at` (each its design and its level): the
    /// relative errors at the design's check runs times the level (none where a design has no
    /// check runs).
    pub fn of_surrogates<'a>(model: &SurrogateModel, at: impl IntoIterator<Item = (&'a [f64], f64)>) -> Uncertainty {
        let errors: Vec<Vec<(&[f64], f64)>> = at
            .into_iter()
            .map(|(design, level)| {
                let checks = model.designs.iter().find(|d| d.values == design);
                let signed = checks.map_or(&[][..], |d| d.check.signed.as_slice());
                signed.iter().map(|(theta, e)| (theta.as_slice(), e * level)).collect()
            })
            .collect();
        Uncertainty::of_errors(&errors).with_means(&errors)
    }

    /// Errors measured at check runs in several outputs, `checks` each (design, θ, the error in
    /// every output), read at observations `at` (design, output); without shared check points,
    /// split by each observation's mean error as [`Self::of_surrogates`]'.
    pub fn of_outputs(at: &[(&[f64], usize)], checks: &[(&[f64], &[f64], DVector<f64>)]) -> Uncertainty {
        let errors: Vec<Vec<(&[f64], f64)>> = at
            .iter()
            .map(|(design, k)| {
                checks
                    .iter()
                    .filter(|(d, _, e)| d == design && *k < e.len())
                    .map(|(_, theta, e)| (*theta, e[*k]))
                    .collect()
            })
            .collect();
        Uncertainty::of_errors(&errors).with_means(&errors)
    }

    /// From each observation's errors at its check points (θ, error): their mean square, and the
    /// error vectors at the points every observation has.
    fn of_errors(errors: &[Vec<(&[f64], f64)>]) -> Uncertainty {
        let variance = errors
            .iter()
            .map(|e| match e.len() {
                0 => 0.0,
                n => e.iter().map(|(_, x)| x * x).sum::<f64>() / n as f64,
            })
            .collect();
        let at = |theta: &[f64], e: &Vec<(&[f64], f64)>| e.iter().find(|(t, _)| *t == theta).map(|(_, x)| *x);
        let paired = errors
            .first()
            .map_or(&[][..], |e| e.as_slice())
            .iter()
            .filter_map(|(theta, _)| {
                let column: Option<Vec<f64>> = errors.iter().map(|e| at(theta, e)).collect();
                column.map(DVector::from_vec)
            })
            .collect();
        Uncertainty {
            variance,
            paired,
            means: None,
        }
    }

    /// Errors known as each observation's mean square `mean_square` and mean `means` over its own
    /// check runs (a sequential screening's held-out batches): the mean errors are the shape across
    /// the observations, split by [`Self::beyond`] as a sequential study's are.
    pub fn of_means(mean_square: Vec<f64>, means: DVector<f64>) -> Uncertainty {
        Uncertainty {
            variance: mean_square,
            paired: Vec::new(),
            means: Some(means),
        }
    }

    /// Without shared check points, each observation's mean error over its own check runs as the
    /// error's shape across designs, as the sequential screening reads its absorbed errors
    /// (docs/sampling.md, "When it stops"), where every observation's error was measured.
    /// `errors` as in [`Self::of_errors`].
    fn with_means(mut self, errors: &[Vec<(&[f64], f64)>]) -> Uncertainty {
        if self.paired.is_empty() && errors.iter().all(|e| !e.is_empty()) {
            let mean = |e: &Vec<(&[f64], f64)>| e.iter().map(|(_, x)| x).sum::<f64>() / e.len() as f64;
            self.means = Some(DVector::from_iterator(errors.len(), errors.iter().map(mean)));
        }
        self
    }

    /// Whether the errors are paired across the observations at some check point: their shape
    /// across designs is known.
    pub fn is_paired(&self) -> bool {
        !self.paired.is_empty()
    }

    /// Whether the error's shape across designs is known, from shared check points or from each
    /// observation's mean error over its own ([`Self::beyond`] then splits it).
    pub fn has_shape(&self) -> bool {
        self.is_paired() || self.means.is_some()
    }

    /// No error was measured at any observation.
    pub fn is_empty(&self) -> bool {
        self.variance.iter().all(|&v| v == 0.0)
    }

    /// The variance at observation `i` (0 where none was measured).
    pub fn variance(&self, i: usize) -> f64 {
        self.variance.get(i).copied().unwrap_or(0.0)
    }

    /// Per observation, the emulators' error a fit of the parameters cannot absorb. At each shared
    /// check point the error vector e is split into its least-squares projection on the model's
    /// Jacobian `jacobian` (rows: observations; columns: parameters) over the `fitted` observations
    /// in the metric `weights` (1/σ of each), and the rest r = e − J(WJ)⁺We. An error in the span
    /// of J moves the fitted parameters and leaves the misfit as it was (the generalised
    /// least-squares residual is unchanged by a covariance J A Jᵀ, Rao 1967), so it cannot excuse a
    /// misfit. Each observation's measured variance is counted in the share Σr²/Σe² of its error
    /// the shared points leave beyond the parameters (the variance itself draws on every check
    /// run, shared or not). Without shared check points, the observations' mean errors are split
    /// so instead, and the spread about each mean (not a shift of the design's predictions) is
    /// counted whole beside the mean's rest. Without either, the error's shape across designs is
    /// unknown, and its whole variance is counted ([`Self::variance`]).
    pub fn beyond(&self, jacobian: &DMatrix<f64>, weights: &[f64], fitted: &[usize]) -> Vec<f64> {
        let n = self.variance.len();
        let Some((shapes, shifts)) = self.shifts(jacobian, weights, fitted) else {
            return self.variance.clone();
        };
        let (mut rest, mut whole) = (vec![0.0; n], vec![0.0; n]);
        for (e, delta) in shapes.iter().zip(&shifts) {
            let r = e - jacobian * delta;
            for i in 0..n {
                rest[i] += r[i] * r[i];
                whole[i] += e[i] * e[i];
            }
        }
        (0..n)
            .map(|i| match (&self.means, whole[i] > 0.0) {
                (Some(_), _) => (self.variance[i] - whole[i]).max(0.0) + rest[i],
                (None, true) => self.variance[i] * rest[i] / whole[i],
                (None, false) => self.variance[i],
            })
            .collect()
    }

    /// The covariance of the parameters' shift the emulators' error causes, mean δδᵀ over the
    /// shared check points (or δδᵀ of the mean errors without them), δ = (WJ)⁺We (see
    /// [`Self::beyond`]): the part of the error a fit absorbs moves the fitted parameters by δ, an
    /// uncertainty of theirs that more tests do not reduce. `None` where the error's shape across
    /// designs, hence the shift, is unknown.
    pub fn parameter_covariance(
        &self,
        jacobian: &DMatrix<f64>,
        weights: &[f64],
        fitted: &[usize],
    ) -> Option<DMatrix<f64>> {
        let (_, shifts) = self.shifts(jacobian, weights, fitted)?;
        let p = jacobian.ncols();
        let sum = shifts
            .iter()
            .fold(DMatrix::zeros(p, p), |acc, d| acc + d * d.transpose());
        Some(sum / shifts.len() as f64)
    }

    /// The error vectors whose shape across designs is known (the shared check points', else the
    /// mean errors), each with the parameters' least-squares shift that absorbs it, δ = (WJ)⁺We
    /// over the `fitted` observations.
    fn shifts(&self, jacobian: &DMatrix<f64>, weights: &[f64], fitted: &[usize]) -> Option<Split<'_>> {
        let shapes = match &self.means {
            Some(m) => std::slice::from_ref(m),
            None => self.paired.as_slice(),
        };
        if shapes.is_empty() || jacobian.nrows() != self.variance.len() || fitted.is_empty() {
            return None;
        }
        Some((shapes, absorbing_shifts(jacobian, weights, fitted, shapes)))
    }
}

/// Error vectors across the observations, each with the parameters' shift that absorbs it.
type Split<'a> = (&'a [DVector<f64>], Vec<DVector<f64>>);

/// For each error vector e (one entry per row of `jacobian`), the parameters' least-squares shift
/// that absorbs it, δ = (WJ)⁺We over the `fitted` rows in the metric `weights` (1/σ of each row):
/// e − Jδ is the part no fit of the parameters takes ([`Uncertainty::beyond`]).
pub fn absorbing_shifts(
    jacobian: &DMatrix<f64>,
    weights: &[f64],
    fitted: &[usize],
    errors: &[DVector<f64>],
) -> Vec<DVector<f64>> {
    let a = DMatrix::from_fn(fitted.len(), jacobian.ncols(), |r, c| {
        weights[fitted[r]] * jacobian[(fitted[r], c)]
    });
    let svd = a.svd(true, true);
    let tol = 1e-12 * svd.singular_values.max().max(f64::MIN_POSITIVE);
    let shift = |e: &DVector<f64>| {
        let b = DVector::from_iterator(fitted.len(), fitted.iter().map(|&i| weights[i] * e[i]));
        svd.solve(&b, tol).unwrap_or_else(|_| DVector::zeros(jacobian.ncols()))
    };
    errors.iter().map(shift).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulate::{CheckError, DesignSurrogate, Surrogate};
    use crate::study::SurrogateKind;

    /// The clamped beam's case: a surrogate of y = a(h)/E off by the same relative error at every
    /// design (tip ∝ 1/E) is an error in the span of ∂y/∂E; a fit of E absorbs it all.
    #[test]
    fn an_error_the_parameter_absorbs_is_not_counted() {
        let levels = [1.0, 0.6, 0.4, 0.3, 0.25];
        let jacobian = DMatrix::from_fn(5, 1, |i, _| -levels[i] / 70_000.0);
        let relative = [0.004, -0.006, 0.002];
        let u = Uncertainty {
            means: None,
            variance: levels.iter().map(|y| y * y * 0.004f64.powi(2)).collect(),
            paired: relative
                .iter()
                .map(|r| DVector::from_iterator(5, levels.iter().map(|y| r * y)))
                .collect(),
        };
        let weights = [30.0, 50.0, 80.0, 100.0, 120.0];
        let beyond = u.beyond(&jacobian, &weights, &[0, 1, 2, 3]);
        // Exact up to rounding: the error is J times a scalar at every point.
        for (b, y) in beyond.iter().zip(levels) {
            assert!(b.abs() < 1e-24 * y * y + 1e-30, "{beyond:?}");
        }
        // Absorbed, the error moves E instead: y(1 + r) = a/E' with a/E = y gives E' − E ≈ −rE,
        // exactly δ = r·(−E) along ∂y/∂E = −y/E, so the shift's variance is E² times the mean r².
        let cov = u.parameter_covariance(&jacobian, &weights, &[0, 1, 2, 3]).unwrap();
        let want = 70_000f64.powi(2) * relative.iter().map(|r| r * r).sum::<f64>() / 3.0;
        assert!((cov[(0, 0)] - want).abs() < 1e-9 * want, "{} vs {want}", cov[(0, 0)]);
    }

    /// An error with a part the parameters cannot take (a trend across designs): that part is
    /// counted in full, checked against its own construction (Gram–Schmidt in the weighted metric,
    /// not the SVD the code uses).
    #[test]
    fn the_part_beyond_the_parameters_is_counted_in_full() {
        let n = 6;
        let w: Vec<f64> = (0..n).map(|i| 1.0 + 0.3 * i as f64).collect();
        let j = DMatrix::from_fn(
            n,
            2,
            |i, k| if k == 0 { 1.0 + i as f64 } else { (i as f64).sin() + 2.0 },
        );
        // A direction W-orthogonal to both columns over the fitted rows (all of them here).
        let inner = |a: &DVector<f64>, b: &DVector<f64>| (0..n).map(|i| w[i] * w[i] * a[i] * b[i]).sum::<f64>();
        let mut q: Vec<DVector<f64>> = Vec::new();
        for c in 0..2 {
            let mut v = j.column(c).into_owned();
            for u in &q {
                v -= u * (inner(&v, u) / inner(u, u));
            }
            q.push(v);
        }
        let mut trend = DVector::from_iterator(n, (0..n).map(|i| (i as f64 - 2.5).powi(2) * 1e-3));
        for u in &q {
            trend -= u * (inner(&trend, u) / inner(u, u));
        }
        let scales = [1.0, -2.0, 0.5];
        let paired: Vec<DVector<f64>> = scales
            .iter()
            .enumerate()
            .map(|(k, s)| &trend * *s + j.column(0) * (0.01 * k as f64) - j.column(1) * 0.02)
            .collect();
        let variance = (0..n)
            .map(|i| paired.iter().map(|e| e[i] * e[i]).sum::<f64>() / 3.0)
            .collect();
        let u = Uncertainty {
            variance,
            paired,
            means: None,
        };
        let all: Vec<usize> = (0..n).collect();
        let beyond = u.beyond(&j, &w, &all);
        let ms = scales.iter().map(|s| s * s).sum::<f64>() / 3.0;
        for i in 0..n {
            let want = trend[i] * trend[i] * ms;
            assert!(
                (beyond[i] - want).abs() <= 1e-12 * want.max(1e-12),
                "{i}: {} vs {want}",
                beyond[i]
            );
        }
    }

    /// A design's check runs: (θ, signed relative error) each.
    type Checks = Vec<(Vec<f64>, f64)>;

    /// Designs at one design variable's `values`, each with its check runs (θ, signed relative
    /// error), on one linear surrogate (the errors are given, not computed from it).
    fn checked_at(designs: Vec<(f64, Checks)>) -> SurrogateModel {
        let samples: Vec<(Vec<f64>, f64)> = (0..4).map(|i| (vec![1.0 + i as f64], 2.0 + i as f64)).collect();
        let bounds = crate::base::Bounds::new(vec![1.0], vec![4.0]);
        let surrogate = Surrogate::fit(SurrogateKind::Linear, &samples, &bounds).unwrap();
        let designs = (designs.into_iter())
            .map(|(v, checks)| DesignSurrogate {
                design: format!("d{v}"),
                values: vec![v],
                surrogate: surrogate.clone(),
                check: CheckError::signed(checks),
                samples: 4,
            })
            .collect();
        SurrogateModel { designs }
    }

    /// Errors are paired across designs only at check points every design was checked at; without
    /// such points the whole variance is counted.
    #[test]
    fn errors_are_paired_at_shared_check_points_only() {
        let model = checked_at(vec![
            (1.0, vec![(vec![1.5], 0.01), (vec![2.5], -0.02)]),
            (2.0, vec![(vec![2.5], 0.03), (vec![3.5], 0.01)]),
        ]);
        let at = [(&[1.0][..], 10.0), (&[2.0][..], 20.0)];
        let u = Uncertainty::of_surrogates(&model, at);
        assert_eq!(u.paired.len(), 1, "only θ = 2.5 is shared");
        assert!((u.paired[0][0] + 0.2).abs() < 1e-12 && (u.paired[0][1] - 0.6).abs() < 1e-12);
        assert!((u.variance(0) - (0.01f64.powi(2) + 0.02f64.powi(2)) / 2.0 * 100.0).abs() < 1e-12);
        let alone = Uncertainty {
            paired: Vec::new(),
            ..u.clone()
        };
        let j = DMatrix::from_element(2, 1, 1.0);
        assert_eq!(
            alone.beyond(&j, &[1.0, 1.0], &[0, 1]),
            vec![u.variance(0), u.variance(1)]
        );
        // The shared point's errors (−0.2, 0.6) have the shape (−1, 3): in the span of J = (−1, 3),
        // all of every check run's variance is absorbed; in the span of (1, 1), the share left is
        // that of the rest (−0.4, 0.4) at each observation: 0.16/0.04 and 0.16/0.36.
        let along = DMatrix::from_column_slice(2, 1, &[-1.0, 3.0]);
        assert!(u.beyond(&along, &[1.0, 1.0], &[0, 1]).iter().all(|v| v.abs() < 1e-15));
        let beyond = u.beyond(&j, &[1.0, 1.0], &[0, 1]);
        assert!((beyond[0] - u.variance(0) * 0.16 / 0.04).abs() < 1e-12, "{beyond:?}");
        assert!((beyond[1] - u.variance(1) * 0.16 / 0.36).abs() < 1e-12, "{beyond:?}");
    }

    /// A sequential design checks each design at its own runs: no point is shared, and the mean
    /// errors carry the shape across designs. Worked by hand: means (0.03, 0.06, 0.09), the first
    /// design's spread about its mean 1e-4.
    #[test]
    fn unpaired_errors_are_split_by_their_means_and_their_spread_is_kept() {
        let model = checked_at(vec![
            (1.0, vec![(vec![1.0], 0.02), (vec![1.1], 0.04)]),
            (2.0, vec![(vec![2.0], 0.06), (vec![2.2], 0.06)]),
            (3.0, vec![(vec![3.0], 0.09)]),
        ]);
        let at = [(&[1.0][..], 1.0), (&[2.0][..], 1.0), (&[3.0][..], 1.0)];
        let u = Uncertainty::of_surrogates(&model, at);
        assert!(!u.is_paired());
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-15);
        // Along J = (1, 2, 3) the means are all absorbed (δ = 0.03): the spread alone is left.
        let along = DMatrix::from_column_slice(3, 1, &[1.0, 2.0, 3.0]);
        let beyond = u.beyond(&along, &[1.0; 3], &[0, 1, 2]);
        assert!(close(&beyond, &[1e-4, 0.0, 0.0]), "{beyond:?}");
        let cov = u.parameter_covariance(&along, &[1.0; 3], &[0, 1, 2]).unwrap();
        assert!((cov[(0, 0)] - 9e-4).abs() < 1e-15, "{cov}");
        // Along (1, 1, 1): δ = 0.06, the means' rest (−0.03, 0, 0.03), the spread beside it.
        let flat = DMatrix::from_element(3, 1, 1.0);
        let beyond = u.beyond(&flat, &[1.0; 3], &[0, 1, 2]);
        assert!(close(&beyond, &[1e-3, 0.0, 9e-4]), "{beyond:?}");
    }

    /// A curve emulator's checks in two outputs, each design at its own θ (a sequential study's):
    /// read per (design, output), split by their means as a response's are; with one design
    /// unchecked the shape is unknown and the whole variance counts. Worked by hand as above.
    #[test]
    fn unpaired_errors_in_several_outputs_are_split_by_their_means() {
        let (d1, d2) = ([1.0], [2.0]);
        let (t1, t2, t3) = ([10.0], [11.0], [20.0]);
        let e = |a: f64, b: f64| DVector::from_vec(vec![a, b]);
        let checks = [
            (&d1[..], &t1[..], e(0.02, 0.1)),
            (&d1[..], &t2[..], e(0.04, 0.1)),
            (&d2[..], &t3[..], e(0.06, -0.2)),
        ];
        let at = [(&d1[..], 0), (&d2[..], 0), (&d1[..], 1), (&d2[..], 1)];
        let u = Uncertainty::of_outputs(&at, &checks);
        assert!(!u.is_paired() && u.has_shape());
        // Along J = (1, 2, 0, 0) the first output's means (0.03, 0.06) are absorbed, its spread
        // about the first design's mean (1e-4) is left; the second output's is kept whole.
        let j = DMatrix::from_column_slice(4, 1, &[1.0, 2.0, 0.0, 0.0]);
        let beyond = u.beyond(&j, &[1.0; 4], &[0, 1, 2, 3]);
        let expected = [1e-4, 0.0, 0.01, 0.04];
        assert!(
            beyond.iter().zip(expected).all(|(b, x)| (b - x).abs() < 1e-15),
            "{beyond:?}"
        );
        let unchecked = Uncertainty::of_outputs(&[(&d1[..], 0), (&[3.0][..], 0)], &checks);
        assert!(!unchecked.has_shape());
        let whole = unchecked.beyond(&j.rows(0, 2).into_owned(), &[1.0; 2], &[0, 1]);
        assert!((whole[0] - 1e-3).abs() < 1e-15 && whole[1] == 0.0, "{whole:?}");
    }
}
