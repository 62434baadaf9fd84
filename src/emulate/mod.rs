//! Emulators: the simulation as a function y(d, θ) — a closed form, or emulators fitted to solver
//! runs — and where the next runs go so that the emulators learn what the answer depends on.
//!
//! - [`Model`]: what the numerics call, `y(d, θ)`; [`expression`] the closed form of a study.
//! - [`surrogate`]: per-design surrogates (polynomial, Gaussian process, a slice of one across the
//!   designs) over the parameters; [`functional`] the curve emulators; [`gp`] the Gaussian process
//!   itself.
//! - [`sequential`]: the sequential design of solver runs over these emulators.

pub mod expression;
pub mod functional;
pub mod gp;
pub mod sequential;
pub mod surrogate;

pub use expression::ExpressionModel;
pub use surrogate::{CheckError, DesignSurrogate, FitError, Surrogate, SurrogateModel};

/// The simulation as the numerics see it: a response `y(d, θ)` at design `d` and parameters `θ`.
///
/// Implemented by closed-form expressions and by surrogates fitted to solver runs.
pub trait Model: Sync {
    fn predict(&self, design: &[f64], theta: &[f64]) -> f64;
}

impl<F: Fn(&[f64], &[f64]) -> f64 + Sync> Model for F {
    fn predict(&self, design: &[f64], theta: &[f64]) -> f64 {
        self(design, theta)
    }
}
