//! A real solver's crush curves beside the stand-in's on the same decks: what differs between
//! OpenRadioss and `crushsim` (the repository's closed-form stand-in for LS-DYNA) in the initial
//! peak, the fold period and the plateau's noise.
//!
//! An `openradioss` study names the stand-in's recordings of its own rendered decks
//! (`solver.openradioss.standin`: `<dir>/<run key>/rcforc` and `nodout`, made by the fixture
//! script running crushsim on each recorded run's deck). For every successful sample or check run
//! of the baseline that has both, both curves are read and measured alike on a common stroke grid
//! (0.05 mm, from 0 to the end of the response's window):
//!
//! - **initial peak**: the largest force before the window (kN) and where (mm);
//! - **plateau**: the mean force over the window (the response);
//! - **peak / plateau**: how far the first fold's load stands above the crush load;
//! - **plateau noise**: the RMS of the force about its least-squares line over the window,
//!   divided by the plateau (fold oscillation and contact noise together);
//! - **fold period**: the mean distance between successive upward crossings of that line by the
//!   force (a crossing counts once the force has been below the line by a fifth of the RMS since
//!   the last one), when the window holds two or more; with a window of a few folds it is a rough
//!   figure, and the number of folds seen is kept with it.

use serde::{Deserialize, Serialize};

use crate::extract::crush::{self, ForceDisplacement, Window};
use crate::extract::grid::{self, StrokeGrid};
use crate::plan::RunRole;
use crate::report::curves::RunOutputs;
use crate::report::data::Curve;
use crate::study::{Response, SolverSimulation};

/// Grid spacing of the comparison, mm.
const SPACING: f64 = 0.05;

/// One curve's measures (see the module note).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct CurveMeasures {
    pub peak: Option<f64>,
    pub peak_at: Option<f64>,
    pub plateau: f64,
    pub noise: f64,
    pub period: Option<f64>,
    /// Folds seen in the window (upward crossings minus one).
    pub folds: usize,
}

/// One design: every compared run's measures (real solver, stand-in), and one run's two curves.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct DesignComparison {
    pub design: String,
    pub real: Vec<CurveMeasures>,
    pub standin: Vec<CurveMeasures>,
    /// The first compared run's curves: real solver, stand-in (thinned for drawing).
    pub example: Option<(Curve, Curve)>,
}

/// The comparison of a study (report-data.json `solver_comparison`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SolverComparison {
    /// The real solver (`OpenRadioss`) and the stand-in (`crushsim`).
    pub solver: String,
    pub standin: String,
    pub window: [f64; 2],
    pub designs: Vec<DesignComparison>,
}

/// The comparison for an `openradioss` study naming the stand-in's recordings; `None` otherwise.
pub fn compare(sim: &SolverSimulation, runs: &RunOutputs) -> Option<SolverComparison> {
    let dir = sim.openradioss.as_ref()?.standin.clone()?;
    let Response::CrushForce { window, .. } = &sim.response else {
        return None;
    };
    let source = crush::SimSource::honeycomb_striker();
    let mut designs: Vec<DesignComparison> = Vec::new();
    for (i, run) in runs.plan.runs.iter().enumerate() {
        if !matches!(run.role, RunRole::Sample | RunRole::Check) || runs.responses.get(i).copied().flatten().is_none() {
            continue;
        }
        let key = &runs.keys[i];
        let (Some(real), Some(standin)) = (
            crate::extract::adapters::run_curve(sim, &runs.dirs, key),
            crush::read_run(std::slice::from_ref(&dir), key, &source),
        ) else {
            continue;
        };
        let (Some(m_real), Some(m_standin)) = (measure(&real, *window), measure(&standin, *window)) else {
            continue;
        };
        let at = match designs.iter().position(|d| d.design == run.design) {
            Some(at) => at,
            None => {
                designs.push(DesignComparison {
                    design: run.design.clone(),
                    real: Vec::new(),
                    standin: Vec::new(),
                    example: Some((drawn("OpenRadioss", &real), drawn("crushsim (stand-in)", &standin))),
                });
                designs.len() - 1
            }
        };
        designs[at].real.push(m_real);
        designs[at].standin.push(m_standin);
    }
    (!designs.is_empty()).then(|| SolverComparison {
        solver: "OpenRadioss".into(),
        standin: "crushsim".into(),
        window: [window.s0, window.s1],
        designs,
    })
}

fn drawn(label: &str, curve: &ForceDisplacement) -> Curve {
    let (displacement, force) = crate::report::curves::decimate(&curve.displacement, &curve.force, 300);
    Curve {
        label: label.into(),
        displacement,
        force,
        parameters: Vec::new(),
        mean_force: None,
        points: curve.displacement.len(),
    }
}

/// The measures of `curve` on the grid from 0 to the window's end; `None` when the curve does not
/// cover it.
pub fn measure(curve: &ForceDisplacement, window: Window) -> Option<CurveMeasures> {
    let points = ((window.s1 / SPACING).round() as usize).max(2) + 1;
    let g = StrokeGrid {
        s0: 0.0,
        s1: window.s1,
        points,
    };
    let start = curve.displacement.first().copied()?;
    // A curve that starts after 0 (the striker's first output) is measured from its first point.
    let g = if start > 0.0 {
        StrokeGrid {
            s0: start,
            points: (((window.s1 - start) / SPACING).round() as usize).max(2) + 1,
            ..g
        }
    } else {
        g
    };
    let force = grid::resample(curve, &g).ok()?;
    let stroke = g.stroke();
    let before: Vec<usize> = (0..stroke.len()).filter(|&k| stroke[k] < window.s0).collect();
    let peak_k = before.iter().copied().max_by(|&a, &b| force[a].total_cmp(&force[b]));
    let inside: Vec<(f64, f64)> = (0..stroke.len())
        .filter(|&k| stroke[k] >= window.s0 - 1e-9)
        .map(|k| (stroke[k], force[k]))
        .collect();
    let plateau = crush::crush_force(curve, window).ok()?.mean_force;
    let (residual, rms) = detrended(&inside);
    let (period, folds) = fold_period(&inside, &residual, rms);
    Some(CurveMeasures {
        peak: peak_k.map(|k| force[k]),
        peak_at: peak_k.map(|k| stroke[k]),
        plateau,
        noise: if plateau > 0.0 { rms / plateau } else { f64::NAN },
        period,
        folds,
    })
}

/// Residuals about the least-squares line, and their RMS.
fn detrended(points: &[(f64, f64)]) -> (Vec<f64>, f64) {
    let n = points.len() as f64;
    if n < 2.0 {
        return (vec![0.0; points.len()], 0.0);
    }
    let (mx, my) = points.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
    let (sxx, sxy) = points.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx).powi(2), a.1 + (p.0 - mx) * (p.1 - my))
    });
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let r: Vec<f64> = points.iter().map(|p| p.1 - my - b * (p.0 - mx)).collect();
    let rms = (r.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    (r, rms)
}

/// Mean distance between successive upward crossings of the trend (with hysteresis), and the folds.
fn fold_period(points: &[(f64, f64)], residual: &[f64], rms: f64) -> (Option<f64>, usize) {
    let hysteresis = 0.2 * rms;
    let mut armed = false;
    let mut ups: Vec<f64> = Vec::new();
    for k in 1..residual.len() {
        if residual[k] < -hysteresis {
            armed = true;
        }
        if armed && residual[k - 1] < 0.0 && residual[k] >= 0.0 {
            let (s0, s1) = (points[k - 1].0, points[k].0);
            let g = residual[k - 1] / (residual[k - 1] - residual[k]);
            ups.push(s0 + g * (s1 - s0));
            armed = false;
        }
    }
    match ups.len() {
        0 | 1 => (None, 0),
        n => (Some((ups[n - 1] - ups[0]) / (n - 1) as f64), n - 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A peak of 0.3 kN at 0.4 mm, then a plateau of 0.1 kN with folds of 1.2 mm, amplitude 0.02.
    fn curve() -> ForceDisplacement {
        let s: Vec<f64> = (0..=1000).map(|k| 5.0 * k as f64 / 1000.0).collect();
        let f = s
            .iter()
            .map(|&x| {
                let plateau = 0.1 + 0.02 * (2.0 * std::f64::consts::PI * x / 1.2).sin();
                if x < 0.4 {
                    0.75 * x
                } else {
                    plateau + (0.3 - plateau) * (-(x - 0.4) / 0.1).exp()
                }
            })
            .collect();
        ForceDisplacement {
            displacement: s,
            force: f,
        }
    }

    #[test]
    fn measures_of_a_known_curve() {
        let m = measure(&curve(), Window { s0: 1.0, s1: 4.6 }).unwrap();
        assert!(
            (m.peak.unwrap() - 0.3).abs() < 0.005 && (m.peak_at.unwrap() - 0.4).abs() < 0.06,
            "{m:?}"
        );
        // Three whole folds in 3.6 mm: the mean over the window is the plateau, within a few %.
        assert!((m.plateau - 0.1).abs() < 0.003, "{m:?}");
        // A sine of amplitude 0.02 has RMS 0.02/√2 = 0.0141; relative 0.141.
        assert!((m.noise - 0.141).abs() < 0.01, "{m:?}");
        assert!((m.period.unwrap() - 1.2).abs() < 0.02 && m.folds == 2, "{m:?}");
    }
}
