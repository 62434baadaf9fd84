//! A run's physical-sanity figures as its record keeps them, and the quality gates that flag a
//! run `suspect` (the figures are computed from the solver's outputs by the extract stage:
//! `crate::extract::lsdyna::quality`).

use serde::{Deserialize, Serialize};

use crate::study::settings::Gates;

/// The figures of one run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Quality {
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub hourglass_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub energy_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub added_mass_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub kinetic_ratio: Option<f64>,
}

/// One broken gate, with the figure and the limit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Flag {
    /// `hourglass`, `energy`, `added_mass` or `kinetic`.
    pub gate: String,
    pub value: f64,
    pub limit: f64,
    /// A sentence for tables and logs.
    pub text: String,
}

impl Gates {
    /// The gates `q` breaks (empty: the run is sound, or glstat reported nothing to check).
    pub fn flags(&self, q: &Quality) -> Vec<Flag> {
        let mut out = Vec::new();
        let pct = |v: f64| format!("{:.1} %", 100.0 * v);
        if let Some(v) = q.hourglass_ratio.filter(|v| exceeds(*v, self.hourglass)) {
            out.push(Flag {
                gate: "hourglass".into(),
                value: v,
                limit: self.hourglass,
                text: format!(
                    "hourglass energy {} of internal energy (limit {})",
                    pct(v),
                    pct(self.hourglass)
                ),
            });
        }
        if let Some(v) = q.energy_error.filter(|v| exceeds(v.abs(), self.energy)) {
            out.push(Flag {
                gate: "energy".into(),
                value: v,
                limit: self.energy,
                text: format!(
                    "total energy {:+.1} % off initial energy + external work (limit ± {})",
                    100.0 * v,
                    pct(self.energy)
                ),
            });
        }
        if let Some(v) = q.added_mass_ratio.filter(|v| exceeds(*v, self.added_mass)) {
            out.push(Flag {
                gate: "added_mass".into(),
                value: v,
                limit: self.added_mass,
                text: format!("added mass {} (limit {})", pct(v), pct(self.added_mass)),
            });
        }
        if let Some(v) = q.kinetic_ratio.filter(|v| exceeds(*v, self.kinetic)) {
            out.push(Flag {
                gate: "kinetic".into(),
                value: v,
                limit: self.kinetic,
                text: format!(
                    "kinetic energy {} of internal energy: not quasi-static (limit {})",
                    pct(v),
                    pct(self.kinetic)
                ),
            });
        }
        out
    }
}

/// Whether a figure breaks its limit (NaN does: a non-finite figure must not pass a gate).
fn exceeds(value: f64, limit: f64) -> bool {
    value.is_nan() || value > limit
}
