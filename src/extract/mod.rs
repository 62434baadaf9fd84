//! From solver outputs (and test-machine files) to numbers: the `extract` stage of the pipeline.
//!
//! - [`lsdyna`]: typed readers for LS-DYNA ASCII outputs (rcforc, glstat, nodout, bndout, secforc,
//!   spcforc) and the termination line.
//! - [`crush`]: force–displacement curves and the average crush force over a stroke window, from
//!   contact force + striker displacement, or from a test machine's CSV.

pub mod calculix;
pub mod cfc;
pub mod crush;
pub mod features;
pub mod grid;
pub mod lsdyna;
