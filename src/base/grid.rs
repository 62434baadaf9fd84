//! The common stroke grid: two force–displacement curves compared point by point must first be put
//! on the same strokes.
//!
//! A [`StrokeGrid`] is `points` equally spaced strokes from `s0` to `s1` (both included, as numpy's
//! `linspace`). [`resample`] gives a curve's force at each of them by linear interpolation in
//! displacement — the "common abscissa" on which LS-OPT's Mean Squared Error compares a computed curve
//! with its target (LS-OPT User's Manual, curve matching: residuals of the ordinates at the target's
//! abscissae). For that the force must be a function of the stroke over the window: from the last
//! sample before the stroke first passes `s0` up to the first sample at or beyond `s1`, the stroke must
//! increase strictly, or there is no single force to read at a grid stroke.
//!
//! Samples before the stroke first passes `s0` are not used, except the last one. So a record that
//! starts with the machine standing still — `-0.0000,0.003` then `0.0000,0.004` then moving — is
//! accepted when the window starts there: the force at `s0` is the one recorded last before the
//! stroke moved past `s0`. Equal or falling strokes inside the window are an error naming the sample.
//!
//! [`native_grid`] is the uniform grid a curve's own sampling suggests (its median spacing over the
//! loading stroke); the CFC filter ([`super::cfc`]) runs on it.

use std::path::Path;

use super::curve::{ForceDisplacement, data_lines};
use crate::error::InputError;

/// `points` equally spaced strokes from `s0` to `s1` mm, both ends included.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeGrid {
    pub s0: f64,
    pub s1: f64,
    pub points: usize,
}

impl StrokeGrid {
    /// The strokes: `s0 + i · spacing` for `i < points − 1`, then exactly `s1` (as numpy's `linspace`).
    pub fn stroke(&self) -> Vec<f64> {
        let h = self.spacing();
        (0..self.points)
            .map(|i| {
                if i + 1 == self.points {
                    self.s1
                } else {
                    self.s0 + i as f64 * h
                }
            })
            .collect()
    }

    /// Distance between neighbouring strokes, mm: `(s1 − s0) / (points − 1)` (NaN below 2 points).
    pub fn spacing(&self) -> f64 {
        if self.points < 2 {
            return f64::NAN;
        }
        (self.s1 - self.s0) / (self.points - 1) as f64
    }

    /// Checks what [`resample`] relies on: finite `s0 < s1` and at least 2 points.
    pub fn check(&self) -> Result<(), GridError> {
        if self.s0.is_finite() && self.s1.is_finite() && self.s1 > self.s0 && self.points >= 2 {
            return Ok(());
        }
        Err(GridError::BadGrid {
            s0: self.s0,
            s1: self.s1,
            points: self.points,
        })
    }
}

/// Why a curve cannot be put on a stroke grid (or filtered). Samples count from 1 in the curve's
/// order (the data rows of its file); [`to_input_error`] turns them into line numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    #[error("the stroke grid needs finite S0 < S1 and at least 2 points; got {s0}:{s1} mm with {points} point(s)")]
    BadGrid { s0: f64, s1: f64, points: usize },
    #[error("the curve has {displacements} displacement(s) but {forces} force(s)")]
    LengthMismatch { displacements: usize, forces: usize },
    #[error("the curve has {points} point(s); at least 2 are needed")]
    TooFewPoints { points: usize },
    #[error("sample {sample}: the {what} is {value}, not a finite number")]
    NonFinite {
        sample: usize,
        what: &'static str,
        value: f64,
    },
    #[error(
        "the curve's stroke runs from {first} mm to at most {max} mm, which does not cover the window {s0}:{s1} mm"
    )]
    NotCovered {
        first: f64,
        max: f64,
        s0: f64,
        s1: f64,
        /// The sample that limits the cover: the first one when the curve starts after `s0`, else the
        /// one at the largest stroke.
        sample: usize,
    },
    #[error(
        "sample {sample}: the stroke is {stroke} mm after {previous} mm; over the window the stroke must increase strictly (one force per stroke on a common grid)"
    )]
    NotIncreasing { sample: usize, stroke: f64, previous: f64 },
    #[error("the stroke never moves from {stroke} mm")]
    NoStroke { stroke: f64 },
    #[error("{0}")]
    Filter(String),
}

impl GridError {
    /// The sample (from 1) the error is about, when it is about one.
    pub fn sample(&self) -> Option<usize> {
        match self {
            GridError::NonFinite { sample, .. }
            | GridError::NotCovered { sample, .. }
            | GridError::NotIncreasing { sample, .. } => Some(*sample),
            _ => None,
        }
    }
}

/// The error as bad input in `file`: at the line of the sample it is about when `text` (the file's
/// text as read by [`super::curve::parse_test_csv`]) has that data row, else about the whole file.
pub fn to_input_error(err: &GridError, file: &Path, text: &str) -> InputError {
    let line = err
        .sample()
        .and_then(|k| data_lines(text).get(k.checked_sub(1)?).copied());
    match line {
        Some(line) => InputError::at(file, text, line, 1, err.to_string()),
        None => InputError::file(file, err.to_string()),
    }
}

/// The curve's force at each stroke of `grid`, interpolated linearly in displacement between the
/// samples around it (see the module doc for which samples count).
pub fn resample(curve: &ForceDisplacement, grid: &StrokeGrid) -> Result<Vec<f64>, GridError> {
    grid.check()?;
    check_curve(curve)?;
    let (a, b) = window_samples(&curve.displacement, grid.s0, grid.s1)?;
    let (d, f) = (&curve.displacement[a..=b], &curve.force[a..=b]);
    Ok(grid.stroke().into_iter().map(|s| interp(d, f, s)).collect())
}

/// The uniform grid over the curve's loading stroke — from its first sample to its largest stroke —
/// at the median spacing of its samples there (rounded to a whole number of steps). The stroke must
/// increase strictly over that range, as for [`resample`].
pub fn native_grid(curve: &ForceDisplacement) -> Result<StrokeGrid, GridError> {
    check_curve(curve)?;
    let d = &curve.displacement;
    let (s0, s1) = (d[0], d.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    if s1 <= s0 {
        return Err(GridError::NoStroke { stroke: s0 });
    }
    let (a, b) = window_samples(d, s0, s1)?;
    let h = median(d[a..=b].windows(2).map(|w| w[1] - w[0]).collect());
    let steps = ((s1 - s0) / h).round().max(1.0);
    // A few huge gaps among dense samples would ask for a grid far finer than the record: refuse
    // rather than allocate without bound.
    let limit = 100 * (b - a + 1).max(100);
    if steps >= limit as f64 {
        return Err(GridError::Filter(format!(
            "the samples are too unevenly spaced for a uniform grid: median spacing {h} mm over {} mm of stroke would need {steps} points",
            s1 - s0
        )));
    }
    Ok(StrokeGrid {
        s0,
        s1,
        points: steps as usize + 1,
    })
}

/// Equal lengths, at least 2 points, finite values.
fn check_curve(curve: &ForceDisplacement) -> Result<(), GridError> {
    let (d, f) = (&curve.displacement, &curve.force);
    if d.len() != f.len() {
        return Err(GridError::LengthMismatch {
            displacements: d.len(),
            forces: f.len(),
        });
    }
    if d.len() < 2 {
        return Err(GridError::TooFewPoints { points: d.len() });
    }
    for (i, (&x, &y)) in d.iter().zip(f).enumerate() {
        let bad = |what, value| GridError::NonFinite {
            sample: i + 1,
            what,
            value,
        };
        if !x.is_finite() {
            return Err(bad("displacement", x));
        }
        if !y.is_finite() {
            return Err(bad("force", y));
        }
    }
    Ok(())
}

/// The indices `a..=b` of the samples that span `[s0, s1]`: `a` is the last sample before the stroke
/// first passes `s0`, `b` the first one at or beyond `s1`; the stroke must increase strictly between.
fn window_samples(d: &[f64], s0: f64, s1: f64) -> Result<(usize, usize), GridError> {
    let (max_at, max) =
        d.iter().copied().enumerate().fold(
            (0, f64::NEG_INFINITY),
            |best, (i, x)| if x > best.1 { (i, x) } else { best },
        );
    let not_covered = |sample| GridError::NotCovered {
        first: d[0],
        max,
        s0,
        s1,
        sample,
    };
    if d[0] > s0 {
        return Err(not_covered(1));
    }
    let past = d.iter().position(|&x| x > s0).ok_or(not_covered(max_at + 1))?;
    let b = (past..d.len()).find(|&i| d[i] >= s1).ok_or(not_covered(max_at + 1))?;
    let a = past - 1;
    if let Some(i) = (a..b).find(|&i| d[i + 1] <= d[i]) {
        return Err(GridError::NotIncreasing {
            sample: i + 2,
            stroke: d[i + 1],
            previous: d[i],
        });
    }
    Ok((a, b))
}

/// Linear interpolation at `s` in strictly increasing `d` (ends held outside `[d0, dn]`).
fn interp(d: &[f64], f: &[f64], s: f64) -> f64 {
    let j = d.partition_point(|&x| x <= s);
    if j == 0 {
        return f[0];
    }
    if j == d.len() {
        return f[d.len() - 1];
    }
    let g = (s - d[j - 1]) / (d[j] - d[j - 1]);
    f[j - 1] + g * (f[j] - f[j - 1])
}

/// The median of positive spacings (the mean of the middle two for an even count).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
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

    fn grid(s0: f64, s1: f64, points: usize) -> StrokeGrid {
        StrokeGrid { s0, s1, points }
    }

    #[test]
    fn stroke_is_uniform_with_both_ends() {
        let g = grid(5.0, 60.0, 12);
        let s = g.stroke();
        assert_eq!(s.len(), 12);
        assert_eq!((s[0], s[11]), (5.0, 60.0));
        assert_eq!(g.spacing(), 5.0);
        for w in s.windows(2) {
            assert!((w[1] - w[0] - 5.0).abs() < 1e-12, "{w:?}");
        }
    }

    #[test]
    fn a_linear_curve_resamples_exactly() {
        // F = 2 d + 1 sampled unevenly: linear interpolation is exact (to rounding, 1e-12).
        let d = [0.0, 0.3, 1.7, 2.0, 4.5, 9.0, 10.0];
        let f: Vec<f64> = d.iter().map(|x| 2.0 * x + 1.0).collect();
        let g = grid(0.0, 10.0, 41);
        let got = resample(&curve(&d, &f), &g).unwrap();
        for (s, y) in g.stroke().iter().zip(&got) {
            assert!((y - (2.0 * s + 1.0)).abs() < 1e-12, "{s}: {y}");
        }
    }

    #[test]
    fn a_standing_start_is_tolerated_and_its_last_sample_used() {
        // The machine stands at 0 (written -0.0000 then 0.0000) before it moves.
        let c = curve(&[-0.0, 0.0, 1.0, 2.0], &[0.003, 0.5, 1.5, 2.5]);
        let got = resample(&c, &grid(0.0, 2.0, 3)).unwrap();
        assert_eq!(got, vec![0.5, 1.5, 2.5]);
    }

    #[test]
    fn jitter_before_the_window_does_not_matter() {
        let c = curve(&[0.0, 0.2, 0.1, 1.0, 2.0, 3.0], &[0.0, 1.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(resample(&c, &grid(1.0, 3.0, 3)).unwrap(), vec![2.0, 3.0, 4.0]);
        // ... but inside the window it does: sample 3 (0.1 after 0.2).
        let e = resample(&c, &grid(0.0, 3.0, 3)).unwrap_err();
        assert_eq!(
            e,
            GridError::NotIncreasing {
                sample: 3,
                stroke: 0.1,
                previous: 0.2
            }
        );
        assert!(e.to_string().contains("increase strictly"), "{e}");
    }

    #[test]
    fn a_rebound_inside_the_window_is_an_error_even_when_it_comes_back() {
        // 0 → 6 → 3 → 9 with window 5:8: the stroke passes 5 twice.
        let c = curve(&[0.0, 6.0, 3.0, 9.0], &[0.0, 1.0, 2.0, 3.0]);
        let e = resample(&c, &grid(5.0, 8.0, 4)).unwrap_err();
        assert_eq!(e.sample(), Some(3), "{e}");
    }

    #[test]
    fn a_window_outside_the_curve_says_both_ranges() {
        let c = curve(&[1.0, 2.0, 30.0, 25.0], &[0.0; 4]);
        let e = resample(&c, &grid(0.0, 10.0, 5)).unwrap_err();
        assert_eq!(e.sample(), Some(1));
        let e = resample(&c, &grid(5.0, 40.0, 5)).unwrap_err();
        assert_eq!(e.sample(), Some(3), "the sample at the largest stroke");
        let text = e.to_string();
        assert!(
            text.contains("from 1 mm to at most 30 mm") && text.contains("5:40 mm"),
            "{text}"
        );
    }

    #[test]
    fn bad_curves_and_grids_are_errors() {
        let ok = curve(&[0.0, 1.0], &[0.0, 1.0]);
        assert!(matches!(
            resample(&curve(&[0.0], &[0.0]), &grid(0.0, 1.0, 2)),
            Err(GridError::TooFewPoints { points: 1 })
        ));
        assert!(matches!(
            resample(&curve(&[0.0, 1.0], &[0.0]), &grid(0.0, 1.0, 2)),
            Err(GridError::LengthMismatch { .. })
        ));
        let e = resample(&curve(&[0.0, 1.0, 2.0], &[0.0, f64::NAN, 1.0]), &grid(0.0, 1.0, 2)).unwrap_err();
        assert_eq!(e.sample(), Some(2));
        for g in [grid(1.0, 1.0, 5), grid(0.0, 1.0, 1), grid(f64::NAN, 1.0, 5)] {
            assert!(matches!(resample(&ok, &g), Err(GridError::BadGrid { .. })), "{g:?}");
        }
    }

    #[test]
    fn the_error_names_the_line_of_the_sample() {
        let text = "# machine 7\ndisplacement [mm],force [kN]\n0,0\n1,1\n\n0.5,2\n2,3\n";
        let c = super::super::curve::parse_test_csv(Path::new("t.csv"), text, Default::default()).unwrap();
        let e = resample(&c, &grid(0.0, 2.0, 3)).unwrap_err();
        let input = to_input_error(&e, Path::new("t.csv"), text);
        assert_eq!(input.span.as_ref().map(|s| s.line), Some(6), "{input}");
        assert!(input.to_string().contains("0.5,2"), "{input}");
    }

    #[test]
    fn native_grid_uses_the_median_spacing() {
        // Spacings 0.1 (x8) and 1.0 (x2): median 0.1 over 2.8 mm → 28 steps.
        let mut d = vec![0.0];
        for h in [0.1, 0.1, 0.1, 1.0, 0.1, 0.1, 0.1, 1.0, 0.1, 0.1] {
            d.push(d[d.len() - 1] + h);
        }
        let g = native_grid(&curve(&d, &vec![1.0; d.len()])).unwrap();
        assert_eq!((g.s0, g.points), (0.0, 29));
        assert!((g.s1 - 2.8).abs() < 1e-12 && (g.spacing() - 0.1).abs() < 1e-12, "{g:?}");
        assert!(matches!(
            native_grid(&curve(&[1.0, 1.0], &[0.0, 0.0])),
            Err(GridError::NoStroke { .. })
        ));
    }
}
