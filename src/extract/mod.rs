//! From solver outputs (and test-machine files) to numbers: the `extract` stage of the pipeline.
//!
//! - [`lsdyna`]: typed readers for LS-DYNA ASCII outputs (rcforc, glstat, nodout, bndout, secforc,
//!   spcforc) and the termination line; [`radioss`]: OpenRadioss's listings and its time history.
//! - [`crush`]: force–displacement curves and the average crush force over a stroke window, from
//!   contact force + striker displacement, or from a test machine's CSV.
//! - [`grid`]: the common stroke grid curves are compared on; [`cfc`]: the SAE J211 CFC filter;
//!   [`metrics`]: curve metrics (LS-OPT MSE, partial curve mapping, Fréchet, DTW, area), `lab compare`;
//!   [`features`]: the measured features of a crush curve (initial peak, plateau, slope, fold period).

pub mod adapters;
pub mod calculix;
pub mod cfc;
pub mod crush;
pub mod features;
pub use crate::base::grid;
pub mod lsdyna;
pub mod metrics;
pub mod radioss;
