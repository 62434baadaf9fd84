//! Named features of a force–displacement curve on the stroke grid — the parts of the stroke that
//! different physics set, and so where a model's error can be read.
//!
//! - **initial peak**: the largest force before the plateau window (first yield and plate buckling
//!   of the walls set it: the yield stress, not the hardening of the fold hinges);
//! - **plateau level**: the mean force over the plateau window, energy / stroke (the mean crush
//!   force of the response: the flow stress in the fold hinges, yield stress plus hardening);
//! - **plateau slope**: the least-squares slope of the force over the plateau window (hardening
//!   that grows with crush, densification, rate effects as the striker slows);
//! - **fold period**: the dominant period of the plateau's oscillation about its trend, from the
//!   periodogram of the detrended plateau (the fold wavelength: wall thickness, cell size and mesh).
//!   Reported only when the sampling resolves it: the periodogram's peak below 0.8 of the Nyquist
//!   frequency and at least 8 times its mean ordinate (the largest of ~100 ordinates of white noise
//!   is ~4.6 times the mean).
//!
//! The diagnosis compares them in transformed form ([`Features::vector`]): logarithms of the
//! forces and the period (specimen scatter multiplies a curve, so it is additive there) and the
//! slope relative to the level.

use super::crush::Window;
use super::grid::StrokeGrid;

/// The feature names, in the order of [`Features::vector`].
pub const NAMES: [&str; 4] = ["plateau level", "initial peak", "plateau slope", "fold period"];

/// Where the features are read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureSpec {
    pub grid: StrokeGrid,
    /// The plateau window (the response's stroke window).
    pub plateau: Window,
}

/// A curve's features.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Features {
    /// Largest force before the plateau window, kN, and where (mm); `None` when the grid starts at
    /// the plateau.
    pub peak: Option<(f64, f64)>,
    /// Mean force over the plateau window, kN.
    pub plateau: f64,
    /// Slope of the force over the plateau window, kN/mm.
    pub slope: f64,
    /// Fold period, mm, when resolved.
    pub period: Option<f64>,
}

impl Features {
    /// The transformed features the diagnosis compares: ln plateau, ln peak, slope × window /
    /// plateau, ln period — each `None` where it is not available.
    pub fn vector(&self, spec: &FeatureSpec) -> [Option<f64>; 4] {
        let width = spec.plateau.s1 - spec.plateau.s0;
        [
            (self.plateau > 0.0).then(|| self.plateau.ln()),
            self.peak.filter(|p| p.0 > 0.0).map(|p| p.0.ln()),
            (self.plateau > 0.0).then(|| self.slope * width / self.plateau),
            self.period.map(f64::ln),
        ]
    }
}

/// The features of `force`, sampled at `spec.grid`'s strokes.
pub fn measure(spec: &FeatureSpec, force: &[f64]) -> Features {
    measure_with(spec, force, true)
}

/// [`measure`], with the fold period only when `with_period` (the periodogram is most of the cost,
/// and the diagnosis reads it only where every specimen resolves it). Allocation-free but for the
/// period: this runs inside the diagnosis's numerical Jacobians, many thousand times.
pub fn measure_with(spec: &FeatureSpec, force: &[f64], with_period: bool) -> Features {
    let g = spec.grid;
    let n = force.len().min(g.points);
    let h = g.spacing();
    let at = |k: usize| g.s0 + h * k as f64;
    let (p0, p1) = (spec.plateau.s0, spec.plateau.s1);
    let peak = (0..n)
        .take_while(|&k| at(k) < p0)
        .max_by(|&a, &b| force[a].total_cmp(&force[b]))
        .map(|k| (force[k], at(k)));
    let first = (0..n).find(|&k| at(k) >= p0 - 1e-9).unwrap_or(n);
    let last = (first..n)
        .take_while(|&k| at(k) <= p1 + 1e-9)
        .last()
        .map_or(first, |k| k + 1);
    let inside = || (first..last).map(|k| (at(k), force[k]));
    let period = if with_period {
        let points: Vec<(f64, f64)> = inside().collect();
        period(&points, h)
    } else {
        None
    };
    Features {
        peak,
        plateau: mean_over(&at, &force[..n], p0, p1),
        slope: slope(inside()),
        period,
    }
}

/// ∫ f ds / (b − a) over [a, b] of the piecewise-linear curve through (s(k), f[k]).
fn mean_over(s: &dyn Fn(usize) -> f64, f: &[f64], a: f64, b: f64) -> f64 {
    let mut area = 0.0;
    for k in 0..f.len().saturating_sub(1) {
        let (x0, x1) = (s(k), s(k + 1));
        let (lo, hi) = (x0.max(a), x1.min(b));
        if hi <= lo {
            continue;
        }
        let y = |x: f64| f[k] + (x - x0) / (x1 - x0) * (f[k + 1] - f[k]);
        area += 0.5 * (y(lo) + y(hi)) * (hi - lo);
    }
    area / (b - a)
}

/// Least-squares slope of the points.
fn slope(points: impl Iterator<Item = (f64, f64)> + Clone) -> f64 {
    let (n, sx, sy) = points
        .clone()
        .fold((0.0, 0.0, 0.0), |a, p| (a.0 + 1.0, a.1 + p.0, a.2 + p.1));
    if n == 0.0 {
        return 0.0;
    }
    let (mx, my) = (sx / n, sy / n);
    let (sxx, sxy) = points.fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx).powi(2), a.1 + (p.0 - mx) * (p.1 - my))
    });
    if sxx > 0.0 { sxy / sxx } else { 0.0 }
}

/// The dominant period of the detrended points (equally spaced by `spacing`), when resolved.
fn period(points: &[(f64, f64)], spacing: f64) -> Option<f64> {
    let n = points.len();
    if n < 16 {
        return None;
    }
    let b = slope(points.iter().copied());
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 / n as f64, a.1 + p.1 / n as f64));
    let r: Vec<f64> = points.iter().map(|p| p.1 - my - b * (p.0 - mx)).collect();
    // Periodogram at the Fourier frequencies k / (n spacing), k = 3 .. n/2 (periods up to a third
    // of the window).
    // The phase turns by a fixed step: one sin_cos per frequency, the rest by rotation (this runs
    // inside the diagnosis's numerical Jacobians, many thousand times).
    let power = |k: usize| {
        let (sw, cw) = (2.0 * std::f64::consts::PI * k as f64 / n as f64).sin_cos();
        let (mut co, mut si, mut c, mut s) = (1.0, 0.0, 0.0, 0.0);
        for v in &r {
            c += v * co;
            s += v * si;
            (co, si) = (co * cw - si * sw, si * cw + co * sw);
        }
        (c * c + s * s) / n as f64
    };
    let ks: Vec<usize> = (3..=n / 2).collect();
    let p: Vec<f64> = ks.iter().map(|&k| power(k)).collect();
    let mean = p.iter().sum::<f64>() / p.len() as f64;
    let (best, top) = p.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    let k = ks[best] as f64;
    (k < 0.8 * n as f64 / 2.0 && *top >= 8.0 * mean && mean > 0.0).then(|| n as f64 * spacing / k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> FeatureSpec {
        FeatureSpec {
            grid: StrokeGrid {
                s0: 0.0,
                s1: 60.0,
                points: 601,
            },
            plateau: Window { s0: 5.0, s1: 60.0 },
        }
    }

    /// A crush-like curve: a peak of 9 at 0.5 mm decaying to a plateau 3 + 0.01 s with folds of
    /// period 2.5 mm and amplitude 0.3.
    fn crush(s: f64) -> f64 {
        let plateau = 3.0 + 0.01 * s + 0.3 * (2.0 * std::f64::consts::PI * s / 2.5).sin();
        if s < 0.5 {
            18.0 * s
        } else {
            plateau + (9.0 - plateau) * (-(s - 0.5) / 0.3).exp()
        }
    }

    #[test]
    fn features_of_a_known_curve() {
        let sp = spec();
        let f: Vec<f64> = sp.grid.stroke().iter().map(|&s| crush(s)).collect();
        let x = measure(&sp, &f);
        let (peak, at) = x.peak.unwrap();
        assert!((peak - 9.0).abs() < 1e-9 && (at - 0.5).abs() < 1e-9, "{peak} at {at}");
        // Plateau mean of 3 + 0.01 s over 5..60 is 3.325; 22 fold periods leave at most 0.3·2.5/(π·55).
        assert!((x.plateau - 3.325).abs() < 0.005, "{}", x.plateau);
        assert!((x.slope - 0.01).abs() < 0.002, "{}", x.slope);
        assert!((x.period.unwrap() - 2.5).abs() < 0.1, "{:?}", x.period);
    }

    #[test]
    fn an_unresolved_oscillation_has_no_period() {
        let sp = FeatureSpec {
            grid: StrokeGrid {
                s0: 0.0,
                s1: 60.0,
                points: 121,
            },
            plateau: Window { s0: 5.0, s1: 60.0 },
        };
        // Period 1.05 mm sampled every 0.5 mm: just above Nyquist (1 mm), not resolved.
        let f: Vec<f64> = sp
            .grid
            .stroke()
            .iter()
            .map(|&s| 3.0 + 0.3 * (2.0 * std::f64::consts::PI * s / 1.05).sin())
            .collect();
        assert_eq!(measure(&sp, &f).period, None);
    }
}
