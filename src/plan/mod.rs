//! Planning: which simulations to run. Sampling plans over boxes of variables.

mod lhs;

pub use lhs::latin_hypercube;
