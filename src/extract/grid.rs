//! The common stroke grid: simulated and measured force–displacement curves resampled onto the
//! same strokes, so that they can be compared point by point (LS-OPT's Mean Squared Error works on
//! the target's abscissae in the same way).
//!
//! Linear interpolation in displacement. The stroke must increase over the window: a curve whose
//! stroke goes back (a rebound, a non-monotonic record) has no single force at a stroke there, and
//! the comparison would be meaningless. Repeated strokes (a record that pauses) keep their last
//! force.

use super::crush::ForceDisplacement;

/// `points` strokes, equally spaced from `s0` to `s1` (both included), mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeGrid {
    pub s0: f64,
    pub s1: f64,
    pub points: usize,
}

impl StrokeGrid {
    pub fn stroke(&self) -> Vec<f64> {
        (0..self.points)
            .map(|i| self.s0 + (self.s1 - self.s0) * i as f64 / (self.points - 1).max(1) as f64)
            .collect()
    }

    pub fn spacing(&self) -> f64 {
        (self.s1 - self.s0) / (self.points - 1).max(1) as f64
    }
}

/// Why a curve cannot be put on the grid, in words an engineer acts on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct GridError(pub String);

/// The curve's force at each stroke of the grid.
pub fn resample(curve: &ForceDisplacement, grid: &StrokeGrid) -> Result<Vec<f64>, GridError> {
    let (d, f) = (&curve.displacement, &curve.force);
    if d.len() < 2 || d.len() != f.len() {
        return Err(GridError("a curve needs at least two points".into()));
    }
    if let Some(i) = d.iter().chain(f).position(|v| !v.is_finite()) {
        return Err(GridError(format!("non-finite value at point {}", i % d.len() + 1)));
    }
    let top = d.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if d[0] > grid.s0 || top < grid.s1 {
        return Err(GridError(format!(
            "the curve's stroke runs from {} to {} mm, which does not cover the window {}..{} mm",
            d[0], top, grid.s0, grid.s1
        )));
    }
    // The stretch that covers the window: from the last point at or before s0 to the first point
    // at or after s1; the stroke must not go back inside it.
    let start = d.iter().rposition(|&x| x <= grid.s0).unwrap_or(0);
    let end = start
        + d[start..]
            .iter()
            .position(|&x| x >= grid.s1)
            .unwrap_or(d.len() - 1 - start);
    let mut xs: Vec<f64> = Vec::with_capacity(end - start + 1);
    let mut ys: Vec<f64> = Vec::with_capacity(end - start + 1);
    for i in start..=end {
        match xs.last() {
            Some(&x) if d[i] < x => {
                return Err(GridError(format!(
                    "the stroke goes back from {x} to {} mm at point {} inside the window {}..{} mm: a \
                     curve compared point by point needs a stroke that does not decrease there",
                    d[i],
                    i + 1,
                    grid.s0,
                    grid.s1
                )));
            }
            Some(&x) if d[i] == x => *ys.last_mut().expect("a point") = f[i],
            _ => {
                xs.push(d[i]);
                ys.push(f[i]);
            }
        }
    }
    Ok(grid.stroke().iter().map(|&s| interpolate(&xs, &ys, s)).collect())
}

/// Linear interpolation on increasing `xs` (`s` inside their range).
fn interpolate(xs: &[f64], ys: &[f64], s: f64) -> f64 {
    let j = xs.partition_point(|&x| x < s);
    if j == 0 {
        return ys[0];
    }
    if j >= xs.len() {
        return ys[xs.len() - 1];
    }
    let t = (s - xs[j - 1]) / (xs[j] - xs[j - 1]);
    ys[j - 1] + t * (ys[j] - ys[j - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(d: &[f64], f: &[f64]) -> ForceDisplacement {
        ForceDisplacement {
            displacement: d.to_vec(),
            force: f.to_vec(),
        }
    }

    #[test]
    fn a_straight_line_resamples_exactly() {
        let c = curve(&[-0.0, 0.7, 1.9, 3.0, 10.0], &[1.0, 2.4, 4.8, 7.0, 21.0]);
        let g = StrokeGrid {
            s0: 0.0,
            s1: 10.0,
            points: 11,
        };
        let y = resample(&c, &g).unwrap();
        for (s, v) in g.stroke().iter().zip(&y) {
            assert!((v - (1.0 + 2.0 * s)).abs() < 1e-12, "{s}: {v}");
        }
    }

    #[test]
    fn a_short_or_receding_curve_is_refused_with_reasons() {
        let g = StrokeGrid {
            s0: 0.0,
            s1: 5.0,
            points: 6,
        };
        let short = resample(&curve(&[0.0, 1.0, 4.0], &[0.0, 1.0, 2.0]), &g).unwrap_err();
        assert!(short.0.contains("does not cover the window"), "{short}");
        let back = resample(&curve(&[0.0, 2.0, 1.5, 6.0], &[0.0, 1.0, 1.0, 2.0]), &g).unwrap_err();
        assert!(back.0.contains("goes back from 2 to 1.5 mm at point 3"), "{back}");
        // A rebound after the window does not matter.
        assert!(resample(&curve(&[0.0, 3.0, 6.0, 5.0], &[0.0, 1.0, 2.0, 1.0]), &g).is_ok());
    }
}
