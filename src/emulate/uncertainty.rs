//! The emulators' own error where a decision reads them, as one value: measured on runs they were
//! not fitted to, and kept apart from the tests' noise (more specimens do not reduce it).

use super::SurrogateModel;

/// The emulators' error at each observation a decision reads, as a variance in the response's
/// units (Kennedy & O'Hagan 2001 count the code's uncertainty in the likelihood; here it is
/// measured at check runs, not modelled). Empty: no emulator (a closed form), or none measured.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Uncertainty {
    variance: Vec<f64>,
}

impl Uncertainty {
    /// Per-design surrogates' error at observations `at` (each its design and its level): the mean
    /// square relative error at the design's check runs times the level squared (0 where a design
    /// has no check runs).
    pub fn of_surrogates<'a>(model: &SurrogateModel, at: impl IntoIterator<Item = (&'a [f64], f64)>) -> Uncertainty {
        let variance = at
            .into_iter()
            .map(|(design, level)| {
                model
                    .designs
                    .iter()
                    .find(|d| d.values == design)
                    .and_then(|d| d.check.mean_square_relative)
                    .map_or(0.0, |m| m * level * level)
            })
            .collect();
        Uncertainty { variance }
    }

    /// The variance at observation `i` (0 where none was measured).
    pub fn variance(&self, i: usize) -> f64 {
        self.variance.get(i).copied().unwrap_or(0.0)
    }
}
