//! SAE J211-1 channel frequency class (CFC) filter: a 2-pole Butterworth low-pass run forward, then
//! backward over the result (phaseless; 4-pole overall), with the coefficients of J211-1
//! Appendix C:
//!
//! ```text
//! ωd = 2π · CFC · 2.0775,  ωa = tan(ωd T / 2)
//! a0 = ωa² / (1 + √2 ωa + ωa²),  a1 = 2 a0,  a2 = a0
//! b1 = −2 (ωa² − 1) / (1 + √2 ωa + ωa²),  b2 = (−1 + √2 ωa − ωa²) / (1 + √2 ωa + ωa²)
//! y[n] = a0 x[n] + a1 x[n−1] + a2 x[n−2] + b1 y[n−1] + b2 y[n−2]
//! ```
//!
//! One pass has |H|² = 1 / (1 + (f/fc)⁴) with fc = 2.0775 CFC (pre-warped by the tangent); the two
//! passes square it, so the −3 dB point is where 1 + (f/fc)⁴ = √2: f = (√2 − 1)^¼ · 2.0775 CFC
//! ≈ 1.667 CFC, the J211 F_H = 5/3 CFC. Start-up: each pass starts from rest at the signal's first
//! value (x[−1] = x[−2] = y[−1] = y[−2] = x[0]), so a constant passes unchanged.
//!
//! A test machine's curve is sampled in stroke; at crush speed v a stroke step Δs is a time step
//! Δs / v, which is how [`filter_curve`] states the filter in time.

use super::crush::ForceDisplacement;
use super::grid::{GridError, StrokeGrid, resample};

/// The CFC filter of `signal` sampled every `dt` seconds.
pub fn filter(signal: &[f64], dt: f64, cfc: f64) -> Vec<f64> {
    if signal.len() < 3 {
        return signal.to_vec();
    }
    let wd = 2.0 * std::f64::consts::PI * cfc * 2.0775;
    let wa = (wd * dt / 2.0).tan();
    let r2 = std::f64::consts::SQRT_2;
    let den = 1.0 + r2 * wa + wa * wa;
    let a0 = wa * wa / den;
    let (a1, a2) = (2.0 * a0, a0);
    let b1 = -2.0 * (wa * wa - 1.0) / den;
    let b2 = (-1.0 + r2 * wa - wa * wa) / den;
    let pass = |x: &[f64]| -> Vec<f64> {
        let mut y = Vec::with_capacity(x.len());
        let (mut x1, mut x2, mut y1, mut y2) = (x[0], x[0], x[0], x[0]);
        for &x0 in x {
            let y0 = a0 * x0 + a1 * x1 + a2 * x2 + b1 * y1 + b2 * y2;
            y.push(y0);
            (x2, x1, y2, y1) = (x1, x0, y1, y0);
        }
        y
    };
    let mut forward = pass(signal);
    forward.reverse();
    let mut back = pass(&forward);
    back.reverse();
    back
}

/// A stroke-sampled curve filtered at `cfc` with the crush speed `speed` (mm/s): resampled
/// uniformly at its median stroke step, filtered, and returned on that uniform stroke.
pub fn filter_curve(curve: &ForceDisplacement, speed: f64, cfc: f64) -> Result<ForceDisplacement, GridError> {
    let d = &curve.displacement;
    let mut steps: Vec<f64> = d.windows(2).map(|w| w[1] - w[0]).filter(|s| *s > 0.0).collect();
    if steps.is_empty() {
        return Err(GridError("a curve needs an increasing stroke to be filtered".into()));
    }
    steps.sort_by(f64::total_cmp);
    let step = steps[steps.len() / 2];
    let (lo, hi) = (d[0], d.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let grid = StrokeGrid {
        s0: lo,
        s1: hi,
        points: ((hi - lo) / step).round() as usize + 1,
    };
    let force = resample(curve, &grid)?;
    Ok(ForceDisplacement {
        displacement: grid.stroke(),
        force: filter(&force, grid.spacing() / speed, cfc),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sampling interval of the tests: 100 kHz, far above F_H, where the pre-warped digital filter
    /// meets the analog −3 dB point to a fraction of a percent.
    const DT: f64 = 1e-5;

    /// The amplitude a long sinusoid of frequency `f` keeps (the middle third, away from the ends).
    fn gain(f: f64, cfc: f64) -> f64 {
        let dt = DT;
        let n = 200_000;
        let x: Vec<f64> = (0..n)
            .map(|i| (2.0 * std::f64::consts::PI * f * i as f64 * dt).sin())
            .collect();
        let y = filter(&x, dt, cfc);
        let mid = n / 3..2 * n / 3;
        let rms = |v: &[f64]| (v.iter().map(|a| a * a).sum::<f64>() / v.len() as f64).sqrt();
        rms(&y[mid.clone()]) / rms(&x[mid])
    }

    #[test]
    fn the_minus_three_decibel_point_is_five_thirds_of_the_class() {
        for cfc in [60.0, 180.0, 600.0] {
            let f3 = (2f64.sqrt() - 1.0).powf(0.25) * 2.0775 * cfc;
            assert!((f3 / cfc - 5.0 / 3.0).abs() < 0.01, "{f3}");
            let g = gain(f3, cfc);
            // At 100 kHz the digital −3 dB point sits within 0.1 % of 5/3 CFC.
            assert!((g - 0.5f64.sqrt()).abs() < 0.01 * 0.5f64.sqrt(), "CFC {cfc}: gain {g}");
            // The whole response: each pass |H|² = 1 / (1 + (tan(π f T) / tan(π fc T))⁴), so two
            // passes give 1 / (1 + ...), from the passband to the stopband.
            let fc = 2.0775 * cfc;
            for f in [cfc / 10.0, cfc / 2.0, cfc, 2.0 * cfc, 5.0 * cfc, 10.0 * cfc] {
                let t = |x: f64| (std::f64::consts::PI * x * DT).tan();
                let exact = 1.0 / (1.0 + (t(f) / t(fc)).powi(4));
                let g = gain(f, cfc);
                assert!(
                    (g - exact).abs() < 0.01 * exact + 1e-6,
                    "CFC {cfc}, {f} Hz: {g} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn a_constant_passes_and_a_symmetric_pulse_stays_in_place() {
        let c = filter(&[2.5; 100], 1e-4, 60.0);
        assert!(c.iter().all(|v| (v - 2.5).abs() < 1e-12));
        let n = 4001;
        let x: Vec<f64> = (0..n)
            .map(|i| (-(((i as f64) - 2000.0) / 50.0).powi(2)).exp())
            .collect();
        let y = filter(&x, 1e-4, 180.0);
        let at = (0..n).max_by(|&a, &b| y[a].total_cmp(&y[b])).unwrap();
        assert_eq!(at, 2000, "phaseless");
    }
}
