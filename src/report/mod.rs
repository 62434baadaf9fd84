//! What `lab` hands back: `results.json` (the contract), the terminal summary, the HTML report
//! (drawn from `results.json` plus `report-data.json`, both recorded by `lab run`).

pub mod answer;
pub mod curves;
pub mod data;
pub mod html;
pub mod markup;
pub mod plots;
pub mod results;
pub mod run;
pub mod solvers;
pub mod summary;

pub use results::Results;

/// Atomic file writes (temp file, fsync, rename), shared with the run store.
pub use crate::execute::store::write_atomic;
