//! The shared leaves below every stage: a box of variables ([`Bounds`]), Latin hypercubes, bounded
//! least squares, a bounded memo, the numerics' error, and how numbers are written in words.
//! Nothing here imports any other module of the crate.

pub mod bounds;
pub mod curve;
pub mod deck;
pub mod dyna_filters;
pub mod format;
pub mod grid;
mod lhs;
pub mod memo;
pub mod number;
pub mod optim;
pub mod optimize;
pub mod template;

pub use bounds::{Bounds, LOG_SPREAD_RATIO};
pub use lhs::latin_hypercube;

/// Why a method could not produce an estimate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error("{method} needs at least {needed} training designs, the study gives {given}")]
    TooFewDesigns {
        method: &'static str,
        needed: usize,
        given: usize,
    },
    #[error("the model returned a non-finite value at the starting point ({0})")]
    NonFinite(String),
    #[error("{0}")]
    Numerics(String),
}
