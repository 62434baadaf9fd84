//! Physical sanity of a run from its glstat: the figures crash analysts check before they trust a
//! run, and the gates that flag a run `suspect`.
//!
//! Figures (each the worst over the run's output steps; `None` when glstat does not report it):
//! - **hourglass ratio** = hourglass energy / internal energy, over the steps whose internal energy
//!   is at least [`SIGNIFICANT_INTERNAL`] of its largest value (before that the ratio of two tiny
//!   numbers says nothing);
//! - **energy error** = (total energy − (initial total energy + external work)) / (initial total
//!   energy + external work): energy created or lost by the numerics; signed, the largest in size;
//! - **added mass ratio** = glstat's `percentage increase` / 100 (reported only when mass scaling
//!   adds mass);
//! - **kinetic ratio** = kinetic / internal energy, over the same steps as the hourglass ratio: a
//!   quasi-static crush must keep it small (reported by the `openradioss` adapter, whose time
//!   history has both; see [`crate::extract::radioss::history`]).
//!
//! The figures depend only on the outputs; the gates ([`Gates`]) are study settings applied
//! afterwards, so changing a gate re-judges runs without rerunning them.

use super::glstat::Glstat;
pub use crate::execute::quality::{Flag, Quality};
pub use crate::study::settings::Gates;

/// Steps whose internal energy is below this fraction of its largest value are left out of the
/// hourglass ratio.
pub const SIGNIFICANT_INTERNAL: f64 = 0.05;

/// The figures of a parsed glstat.
pub fn figures(gl: &Glstat) -> Quality {
    Quality {
        hourglass_ratio: hourglass_ratio(gl),
        energy_error: energy_error(gl),
        added_mass_ratio: gl
            .series("percentage increase")
            .and_then(|p| worst(p.iter().map(|v| v / 100.0))),
        kinetic_ratio: None,
    }
}

/// The value largest in size (NaN wins: a non-finite figure must not pass a gate).
pub(crate) fn worst(values: impl Iterator<Item = f64>) -> Option<f64> {
    values.fold(None, |acc: Option<f64>, v| match acc {
        Some(a) if a.is_nan() || (!v.is_nan() && a.abs() >= v.abs()) => Some(a),
        _ => Some(v),
    })
}

fn hourglass_ratio(gl: &Glstat) -> Option<f64> {
    let (hg, ie) = (gl.series("hourglass energy")?, gl.internal_energy()?);
    let peak = ie.iter().copied().fold(0.0, f64::max);
    if peak <= 0.0 {
        return worst(hg.iter().map(|h| if *h == 0.0 { 0.0 } else { f64::NAN }));
    }
    worst(
        hg.iter()
            .zip(&ie)
            .filter(|(_, i)| **i >= SIGNIFICANT_INTERNAL * peak)
            .map(|(h, i)| h / i),
    )
}

fn energy_error(gl: &Glstat) -> Option<f64> {
    let total = gl.series("total energy")?;
    let external = gl.series("external work")?;
    let initial = *total.first()?;
    worst(total.iter().zip(&external).filter_map(|(t, w)| {
        let reference = initial + w;
        (reference != 0.0).then(|| (t - reference) / reference.abs())
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::lsdyna::glstat;
    use std::path::Path;

    fn glstat_text(rows: &[(f64, f64, f64, f64, f64)]) -> String {
        let mut s = String::from("t\n ls-dyna (version x)  date 1\n");
        for (t, ie, hg, total, ext) in rows {
            s += &format!(
                " time........ {t:e}\n internal energy..... {ie:e}\n hourglass energy.... {hg:e}\n total energy.... {total:e}\n external work.... {ext:e}\n"
            );
        }
        s
    }

    #[test]
    fn figures_and_flags_with_their_numbers() {
        // Internal energy grows; hourglass 12 % of it once significant; total drifts 6 % above
        // initial (100) + external work.
        let rows = [
            (0.0, 0.0, 0.0, 100.0, 0.0),
            (0.1, 1.0, 1.0, 100.0, 0.0), // below 5 % of the peak: left out of the ratio
            (0.2, 50.0, 6.0, 153.0, 50.0),
            (0.3, 100.0, 12.0, 212.0, 100.0),
        ];
        let gl = glstat::parse(Path::new("glstat"), &glstat_text(&rows)).unwrap();
        let q = figures(&gl);
        assert!((q.hourglass_ratio.unwrap() - 0.12).abs() < 1e-12, "{q:?}");
        assert!((q.energy_error.unwrap() - 0.06).abs() < 1e-12, "{q:?}");
        assert_eq!(q.added_mass_ratio, None);
        let flags = Gates::default().flags(&q);
        let gates: Vec<&str> = flags.iter().map(|f| f.gate.as_str()).collect();
        assert_eq!(gates, ["hourglass", "energy"]);
        assert!(flags[0].text.contains("12.0 %"), "{}", flags[0].text);
        let lenient = Gates {
            hourglass: 0.2,
            energy: 0.1,
            ..Gates::default()
        };
        assert!(lenient.flags(&q).is_empty());
    }

    #[test]
    fn a_nan_figure_never_passes() {
        let q = Quality {
            hourglass_ratio: Some(f64::NAN),
            ..Quality::default()
        };
        assert_eq!(Gates::default().flags(&q).len(), 1);
        assert!(worst([1.0, f64::NAN, -3.0].into_iter()).unwrap().is_nan());
        assert_eq!(worst([1.0, -3.0, 2.0].into_iter()), Some(-3.0));
    }
}
