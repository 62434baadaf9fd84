//! Sensitivity-based calibration (paper Eqs. 6–7): match slopes, then the level.
//!
//! Eq. 6: min_θ Σ_i [(y_test,i − y_test,i+1) − (y_pre,i(θ) − y_pre,i+1(θ))]² over consecutive
//! training designs in the order the study lists them: a constant model error cancels in each
//! difference, so it cannot bias θ.
//! Eq. 7: min_d Σ_i [y_test,i − y_pre,i(θ*) − d]², whose solution is the mean residual.

use nalgebra::DVector;

use super::{CalibrationError, Discrepancy, Estimate, Problem, optimize};

/// Eq. 6 then Eq. 7. Needs at least two training designs.
pub fn calibrate(problem: &Problem) -> Result<Estimate, CalibrationError> {
    let n = problem.measured.len();
    if n < 2 {
        return Err(CalibrationError::TooFewDesigns {
            method: "sensitivity",
            needed: 2,
            given: n,
        });
    }
    let measured_steps = differences(&problem.measured);
    let residuals = |theta: &DVector<f64>| &measured_steps - differences(&problem.predictions(theta));
    let theta = optimize::least_squares(&residuals, &problem.bounds)?.theta;
    let d = (&problem.measured - problem.predictions(&theta)).mean();
    Ok(Estimate {
        theta,
        discrepancy: Discrepancy::Constant(d),
    })
}

/// y_i − y_{i+1} for consecutive entries.
fn differences(y: &DVector<f64>) -> DVector<f64> {
    DVector::from_iterator(y.len() - 1, y.as_slice().windows(2).map(|w| w[0] - w[1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::testing::cantilever;

    #[test]
    fn two_points_h8_h10_match_the_paper() {
        // Paper Sec. 3.2.2: E = 64,914, d = 0.0189; facts.md: d = 0.018877 (exact from Eqs. 6–7).
        let est = calibrate(&cantilever(&[8.0, 10.0])).unwrap();
        let Discrepancy::Constant(d) = est.discrepancy else {
            panic!("no constant discrepancy")
        };
        assert!((est.theta[0] - 64_914.0).abs() <= 2.0, "E = {}", est.theta[0]);
        assert!((d - 0.018877).abs() <= 2e-6, "d = {d}");
    }

    #[test]
    fn consecutive_pairs_with_more_points() {
        // facts.md: 64,670 / 64,558 / 64,740 for h = {8,10,12}, {8,9,10,12}, {8..12}.
        for (hs, expected) in [
            (&[8.0, 10.0, 12.0][..], 64_670.0),
            (&[8.0, 9.0, 10.0, 12.0][..], 64_558.0),
            (&[8.0, 9.0, 10.0, 11.0, 12.0][..], 64_740.0),
        ] {
            let e = calibrate(&cantilever(hs)).unwrap().theta[0];
            assert!((e - expected).abs() <= 2.0, "h = {hs:?}: E = {e}");
        }
    }

    #[test]
    fn one_design_is_refused() {
        assert!(matches!(
            calibrate(&cantilever(&[8.0])),
            Err(CalibrationError::TooFewDesigns {
                needed: 2,
                given: 1,
                ..
            })
        ));
    }
}
