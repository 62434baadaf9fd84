//! Planning: which simulations to run. Sampling plans over boxes of variables ([`latin_hypercube`],
//! [`sweep::grid`]) and the run [`Plan`] of a solver study.

pub mod sweep;

pub use crate::base::latin_hypercube;
pub use sweep::{Plan, PlannedRun, RunRole};
