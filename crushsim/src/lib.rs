//! `crushsim`: a stand-in for LS-DYNA on the honeycomb crush deck, so the run engine can be
//! exercised and recordings made without a licence. It says so in its banner and its d3hsp.
//!
//! - [`model`] / [`assemble`]: read the rendered deck (parameters, includes, MAT_003, sections,
//!   striker, times, outputs) into a [`model::Model`], with file:line errors;
//! - [`physics`]: the force–crush history from super-folding-element theory (formulas there);
//! - [`output`]: rcforc, glstat, nodout, d3hsp, messag in LS-DYNA's ASCII formats;
//! - [`binout`]: the histories a deck sends to binout (BINARY 2 or 3), through the `lsda` crate;
//! - [`run`]: the command line (`crushsim i=main.k [ncpu=N] [memory=...]`) and the test-only
//!   failure switch `*CRUSHSIM_TEST` (see there).

pub mod assemble;
pub mod binout;
pub mod model;
pub mod output;
pub mod physics;
pub mod run;
