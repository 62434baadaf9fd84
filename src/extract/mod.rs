//! From solver outputs (and test-machine files) to numbers: the `extract` stage of the pipeline.
//!
//! - [`lsdyna`]: typed readers for LS-DYNA ASCII outputs (rcforc, glstat, nodout, bndout, secforc,
//!   spcforc) and the termination line.


pub mod lsdyna;
