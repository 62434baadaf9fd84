//! SAE J211-1 Channel Frequency Class (CFC) filter: the 2-pole Butterworth low-pass of J211-1
//! Appendix C (ISO 6487 gives the same), run forward then backward over the record — phaseless and
//! 4-pole overall.
//!
//! Coefficients, for a sampling interval `T` seconds:
//!
//! ```text
//! wd = 2π · CFC · 2.0775          wa = tan(wd · T / 2)          D = 1 + √2·wa + wa²
//! a0 = wa² / D    a1 = 2·a0    a2 = a0
//! b1 = −2·(wa² − 1) / D          b2 = (−1 + √2·wa − wa²) / D
//! y[n] = a0·x[n] + a1·x[n−1] + a2·x[n−2] + b1·y[n−1] + b2·y[n−2]
//! ```
//!
//! checked against published statements of J211-1 Appendix C: docs.websat.io/signal-operation/BW
//! (the same wd, wa = sin/cos, a0..a2, b1, b2) and Weisang's FlexPro documentation of the CFC
//! algorithm (weisang.com/en/documentation/cfcalgorithm_de: 2-pole difference equation passed forward
//! and backward); two public implementations read for comparison (a MATLAB `SaeJ211Filter` and a
//! C# `CFCFilters`) use the same a, b (with scipy's sign convention `[1, −b1, −b2]`).
//!
//! It is the bilinear transform of the analogue Butterworth `1/(s² + √2 s + 1)` with its cutoff
//! pre-warped to `fc = 2.0775 · CFC` Hz, so one pass has `|H|² = 1 / (1 + r⁴)` with
//! `r = tan(π f T) / wa`, and forward + backward squares it: `|H_fb| = 1 / (1 + r⁴)`. The −3 dB
//! point (`|H_fb| = 1/√2`) is at `r = (√2 − 1)^¼ = 0.80225`, i.e. [`minus_3db_frequency`]
//! `= atan(0.80225 · wa) / (π T)`, which tends to `0.80225 · 2.0775 · CFC = 5/3 · CFC` — J211's
//! F_H — as the sampling gets fine (CFC 60 at 10 kHz: 100.0 Hz; CFC 600 at 10 kHz: 1017 Hz, 1.7 %
//! above 1000 Hz, because of the pre-warping). The tests check this numerically on sinusoids.
//!
//! Start-up: J211 asks for pre-event data (Altair's `saefilt95` pads ≥ 10 ms for it). A test machine's
//! crush record starts at rest, so this filter takes the record as extended by its first value
//! before it and its last value after it: each pass starts in the steady state of its first input
//! (`x[−1] = x[−2] = y[−1] = y[−2] = x[0]`, the same as scipy's `lfilter` with
//! `zi = lfilter_zi(b, a) · x[0]`). The DC gain is exactly 1 (`a0+a1+a2 = 1 − b1 − b2`), so a
//! constant passes unchanged and a step at the start is not smeared into a ramp from zero.
//!
//! A test machine samples in stroke, not time: [`filter_curve`] resamples the curve uniformly in
//! stroke at its median spacing ([`super::grid::native_grid`]) and states that spacing in time with
//! the crush speed, `T = Δs / v`.

use super::crush::ForceDisplacement;
use super::grid::{GridError, native_grid, resample};

/// J211-1 Appendix C: the 2-pole design frequency is 2.0775 × CFC Hz.
const DESIGN_FACTOR: f64 = 2.0775;

/// The difference-equation coefficients (J211 names: `y = a0 x + a1 x₋₁ + a2 x₋₂ + b1 y₋₁ + b2 y₋₂`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficients {
    pub a0: f64,
    pub a1: f64,
    pub a2: f64,
    pub b1: f64,
    pub b2: f64,
}

/// The coefficients for sampling interval `dt` seconds and class `cfc`; an error unless both are
/// positive and finite and the design frequency 2.0775·CFC lies below the Nyquist frequency.
pub fn coefficients(dt: f64, cfc: f64) -> Result<Coefficients, GridError> {
    if !(dt.is_finite() && dt > 0.0 && cfc.is_finite() && cfc > 0.0) {
        return Err(GridError::Filter(format!(
            "the CFC filter needs a positive class and sampling interval; got CFC {cfc}, dt {dt} s"
        )));
    }
    let half_angle = std::f64::consts::PI * DESIGN_FACTOR * cfc * dt; // wd · T / 2
    if half_angle >= std::f64::consts::FRAC_PI_2 {
        return Err(GridError::Filter(format!(
            "CFC {cfc} needs its design frequency {} Hz below the Nyquist frequency {} Hz of the sampling (dt = {dt} s): sample finer or filter at a lower class",
            DESIGN_FACTOR * cfc,
            0.5 / dt
        )));
    }
    let wa = half_angle.tan();
    let sqrt2 = std::f64::consts::SQRT_2;
    let d = 1.0 + sqrt2 * wa + wa * wa;
    let a0 = wa * wa / d;
    Ok(Coefficients {
        a0,
        a1: 2.0 * a0,
        a2: a0,
        b1: -2.0 * (wa * wa - 1.0) / d,
        b2: (-1.0 + sqrt2 * wa - wa * wa) / d,
    })
}

/// The signal (sampled every `dt` seconds) filtered at class `cfc`, forward then backward. With a
/// `dt` or `cfc` that [`coefficients`] refuses, every output is NaN — the mistake shows instead of
/// passing the signal through unfiltered; check with [`coefficients`] first to get the reason.
pub fn filter(signal: &[f64], dt: f64, cfc: f64) -> Vec<f64> {
    match coefficients(dt, cfc) {
        Ok(c) => filter_with(signal, &c),
        Err(_) => vec![f64::NAN; signal.len()],
    }
}

/// Forward then backward with given coefficients.
pub fn filter_with(signal: &[f64], c: &Coefficients) -> Vec<f64> {
    let mut y = pass(signal.iter().copied(), c);
    y = pass(y.into_iter().rev(), c);
    y.reverse();
    y
}

/// One pass of the difference equation, started in the steady state of its first input.
fn pass(x: impl Iterator<Item = f64>, c: &Coefficients) -> Vec<f64> {
    let mut x = x.peekable();
    let Some(&x0) = x.peek() else { return Vec::new() };
    let (mut x1, mut x2, mut y1, mut y2) = (x0, x0, x0, x0);
    x.map(|xn| {
        let yn = c.a0 * xn + c.a1 * x1 + c.a2 * x2 + c.b1 * y1 + c.b2 * y2;
        (x2, x1, y2, y1) = (x1, xn, y1, yn);
        yn
    })
    .collect()
}

/// |H| of the forward-backward filter at `f` Hz: `1 / (1 + (tan(π f T) / wa)⁴)` (NaN when
/// [`coefficients`] refuses `dt`, `cfc`).
pub fn gain(f: f64, dt: f64, cfc: f64) -> f64 {
    if coefficients(dt, cfc).is_err() {
        return f64::NAN;
    }
    let wa = (std::f64::consts::PI * DESIGN_FACTOR * cfc * dt).tan();
    let r = (std::f64::consts::PI * f * dt).tan() / wa;
    1.0 / (1.0 + r.powi(4))
}

/// The frequency, Hz, where the forward-backward filter's gain is 1/√2 (−3 dB):
/// `atan((√2 − 1)^¼ · wa) / (π T)`; J211's F_H = 5/3 · CFC in the limit of fine sampling.
pub fn minus_3db_frequency(dt: f64, cfc: f64) -> f64 {
    if coefficients(dt, cfc).is_err() {
        return f64::NAN;
    }
    let wa = (std::f64::consts::PI * DESIGN_FACTOR * cfc * dt).tan();
    ((std::f64::consts::SQRT_2 - 1.0).powf(0.25) * wa).atan() / (std::f64::consts::PI * dt)
}

/// A test machine's curve filtered at class `cfc`: resampled uniformly in stroke at its median
/// spacing Δs over its loading stroke (first sample to largest stroke), that spacing taken as the
/// time step `Δs / v` at the crush speed `v` mm/s, filtered; returns the uniform curve.
pub fn filter_curve(curve: &ForceDisplacement, speed_mm_per_s: f64, cfc: f64) -> Result<ForceDisplacement, GridError> {
    if !(speed_mm_per_s.is_finite() && speed_mm_per_s > 0.0) {
        return Err(GridError::Filter(format!(
            "the crush speed must be positive and finite to state the stroke sampling in time; got {speed_mm_per_s} mm/s"
        )));
    }
    let grid = native_grid(curve)?;
    let force = resample(curve, &grid)?;
    let c = coefficients(grid.spacing() / speed_mm_per_s, cfc)?;
    Ok(ForceDisplacement {
        displacement: grid.stroke(),
        force: filter_with(&force, &c),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_1_SQRT_2, PI};

    const DT: f64 = 1e-4; // 10 kHz

    /// Amplitude of the sinusoid at `f` Hz in `y` over its middle half, by least squares on sin
    /// and cos (the ends carry the filter's start-up).
    fn amplitude(y: &[f64], f: f64, dt: f64) -> f64 {
        let n = y.len();
        let (mut ss, mut cc, mut sc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (i, v) in y.iter().enumerate().take(3 * n / 4).skip(n / 4) {
            let (s, c) = (2.0 * PI * f * i as f64 * dt).sin_cos();
            (ss, cc, sc, ys, yc) = (ss + s * s, cc + c * c, sc + s * c, ys + v * s, yc + v * c);
        }
        let det = ss * cc - sc * sc;
        let (a, b) = ((ys * cc - yc * sc) / det, (yc * ss - ys * sc) / det);
        a.hypot(b)
    }

    /// The measured gain of a 4-second sinusoid at `f` through the filter.
    fn measured_gain(f: f64, cfc: f64) -> f64 {
        let x: Vec<f64> = (0..40_000).map(|i| (2.0 * PI * f * i as f64 * DT).sin()).collect();
        amplitude(&filter(&x, DT, cfc), f, DT) / amplitude(&x, f, DT)
    }

    #[test]
    fn the_coefficients_are_the_bilinear_butterworth() {
        // DC gain 1: a0 + a1 + a2 = 1 − b1 − b2 (to rounding, 1e-15).
        for (dt, cfc) in [(1e-4, 60.0), (1e-4, 600.0), (1e-5, 1000.0), (1e-3, 10.0)] {
            let c = coefficients(dt, cfc).unwrap();
            assert!((c.a0 + c.a1 + c.a2 - (1.0 - c.b1 - c.b2)).abs() < 1e-15, "{c:?}");
        }
        // CFC 60 at 10 kHz, by hand: wa = tan(0.0391601) = 0.0391601 + 0.0391601³/3 + ... = 0.0391801
        let wa = (PI * 2.0775 * 60.0 * 1e-4_f64).tan();
        let c = coefficients(1e-4, 60.0).unwrap();
        let d = 1.0 + 2f64.sqrt() * wa + wa * wa;
        assert!((c.a0 - wa * wa / d).abs() < 1e-18 && (c.b2 - (-1.0 + 2f64.sqrt() * wa - wa * wa) / d).abs() < 1e-15);
        assert!((wa - 0.039_180).abs() < 1e-6, "{wa}");
    }

    #[test]
    fn a_constant_passes_unchanged() {
        for cfc in [60.0, 180.0, 600.0, 1000.0] {
            let y = filter(&[12.5; 5000], DT, cfc);
            let worst = y.iter().map(|v| (v - 12.5).abs() / 12.5).fold(0.0, f64::max);
            assert!(worst < 1e-12, "CFC {cfc}: relative change {worst:e}");
        }
    }

    #[test]
    fn the_gain_is_one_over_root_two_at_the_derived_minus_3db_frequency() {
        for cfc in [60.0, 180.0, 600.0] {
            let f3 = minus_3db_frequency(DT, cfc);
            let g = measured_gain(f3, cfc);
            assert!((g / FRAC_1_SQRT_2 - 1.0).abs() < 0.01, "CFC {cfc}: gain {g} at {f3} Hz");
            // The derivation itself: the measured gain follows 1/(1 + r⁴) at 0.3, 1 and 2 × f3 (0.1 %).
            for k in [0.3, 1.0, 2.0] {
                let (m, a) = (measured_gain(k * f3, cfc), gain(k * f3, DT, cfc));
                assert!(
                    (m / a - 1.0).abs() < 1e-3,
                    "CFC {cfc} at {} Hz: measured {m}, derived {a}",
                    k * f3
                );
            }
            // J211's F_H = 5/3 CFC is the fine-sampling limit: within 2 % at 10 kHz up to CFC 600.
            let fh = cfc * 5.0 / 3.0;
            assert!((f3 / fh - 1.0).abs() < 0.02, "CFC {cfc}: {f3} Hz vs {fh} Hz");
        }
        assert!((minus_3db_frequency(1e-7, 60.0) / 100.0 - 1.0).abs() < 1e-4);
    }

    #[test]
    fn passes_well_below_and_stops_well_above_the_cutoff() {
        for cfc in [60.0, 180.0, 600.0] {
            let fh = cfc * 5.0 / 3.0;
            let low = measured_gain(0.1 * fh, cfc);
            assert!((low - 1.0).abs() < 1e-3, "CFC {cfc}: gain {low} at F_H/10");
            let high = measured_gain(4.0 * fh, cfc); // 4 kHz for CFC 600, below Nyquist 5 kHz
            assert!(high < 0.02, "CFC {cfc}: gain {high} at 4 F_H");
        }
    }

    #[test]
    fn a_symmetric_pulse_keeps_its_peak_in_place() {
        let n = 4001;
        let centre = 2000;
        let x: Vec<f64> = (0..n)
            .map(|i| (-((i as f64 - centre as f64) * DT / 2e-3).powi(2)).exp())
            .collect();
        let y = filter(&x, DT, 60.0);
        let peak = (0..n).max_by(|&i, &j| y[i].total_cmp(&y[j])).unwrap();
        assert_eq!(peak, centre);
        assert!(
            y[centre] < 0.99 && y[centre] > 0.5,
            "attenuated, not destroyed: {}",
            y[centre]
        );
        for k in 1..1000 {
            assert!((y[centre - k] - y[centre + k]).abs() < 1e-9, "asymmetric at ±{k}");
        }
        // One pass alone delays it: the check above can fail.
        let c = coefficients(DT, 60.0).unwrap();
        let once = pass(x.iter().copied(), &c);
        let late = (0..n).max_by(|&i, &j| once[i].total_cmp(&once[j])).unwrap();
        assert!(late > centre + 10, "forward pass peak at {late}");
    }

    #[test]
    fn bad_parameters_are_refused() {
        assert!(coefficients(0.0, 60.0).is_err());
        assert!(coefficients(1e-4, -60.0).is_err());
        assert!(coefficients(1e-4, f64::NAN).is_err());
        // 2.0775 · 2500 = 5194 Hz > Nyquist 5000 Hz.
        let e = coefficients(1e-4, 2500.0).unwrap_err();
        assert!(e.to_string().contains("Nyquist"), "{e}");
        assert!(filter(&[1.0, 2.0], 1e-4, 2500.0).iter().all(|v| v.is_nan()));
        assert!(filter(&[], 1e-4, 60.0).is_empty());
    }

    #[test]
    fn a_crush_curve_is_filtered_in_the_time_its_stroke_was_sampled_at() {
        // Non-uniform stroke samples over 0-50 mm at about 0.05 mm; a 3 kHz ripple in time at
        // 1000 mm/s (ripple period 1/3 mm) on a 20 kN plateau.
        let v = 1000.0;
        let mut d = vec![-0.0, 0.0];
        while d[d.len() - 1] < 50.0 {
            let k = d.len() as f64;
            d.push(d[d.len() - 1] + 0.05 * (1.0 + 0.3 * (k * 0.7).sin()));
        }
        let f: Vec<f64> = d
            .iter()
            .map(|s| 20.0 + 2.0 * (2.0 * PI * 3000.0 * s / v).sin())
            .collect();
        let curve = ForceDisplacement {
            displacement: d.clone(),
            force: f,
        };
        let out = filter_curve(&curve, v, 60.0).unwrap();
        let h = out.displacement[1] - out.displacement[0];
        assert!((h / 0.05 - 1.0).abs() < 0.1, "spacing {h}");
        assert_eq!(out.displacement[0], 0.0);
        // CFC 60 (F_H 100 Hz) removes the 3 kHz ripple: the middle stays within 0.01 kN of 20.
        let n = out.force.len();
        let worst = out.force[n / 4..3 * n / 4]
            .iter()
            .map(|y| (y - 20.0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.01, "ripple left {worst}");
        // A constant-force curve comes back unchanged.
        let flat = ForceDisplacement {
            displacement: d,
            force: vec![7.0; curve.force.len()],
        };
        let out = filter_curve(&flat, v, 60.0).unwrap();
        assert!(out.force.iter().all(|y| (y - 7.0).abs() < 1e-12));
        // Errors: speed, a stroke that goes back.
        assert!(filter_curve(&curve, 0.0, 60.0).is_err());
        let back = ForceDisplacement {
            displacement: vec![0.0, 1.0, 0.5, 2.0],
            force: vec![0.0; 4],
        };
        assert_eq!(filter_curve(&back, v, 60.0).unwrap_err().sample(), Some(3));
    }
}
