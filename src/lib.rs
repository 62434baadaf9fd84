//! `lab` calibrates simulation models against tests.
//!
//! The crate is laid out as the pipeline it runs; one typed value flows from each stage to the next:
//!
//! ```text
//! study ──► plan ──► render ──► execute ──► extract ──► fit ──► calibrate ──► diagnose ──► report
//! Study     Plan     inputs     RunRecord   response    Model   Calibration   Diagnosis    results.json
//! ```
//!
//! - [`study`]: the study file and the experiments it names, loaded strictly into a [`study::Study`].
//! - [`plan`]: which runs to make: parameter samples per design (Latin hypercube or grid) and checks.
//! - [`render`]: Tera templates into each run's input files (and LS-DYNA fields, meshes).
//! - [`execute`]: the run engine: a content-addressed run store, a lock, the local executor.
//! - [`extract`]: solver outputs to numbers (LS-DYNA ASCII files, crush force).
//! - [`fit`]: per-design surrogates over the parameters; [`model`]: closed-form simulations.
//! - [`calibrate`]: the paper's three methods and the identifiability check, as pure numerics.
//! - [`diagnose`]: what the simulation gets wrong, its likely cause, the extended model.
//! - [`report`]: `results.json`, the terminal summary, the HTML report.
//! - [`pipeline`]: `lab run` as one function of named stages ([`pipeline::run`]: read it first);
//!   [`cli`] is the command line around it.
//!
//! The stand-in crush solver `crushsim` is its own crate (`crushsim/`): a program lab runs, never links.
//!
//! Numerics never read files and never block on I/O; everything else hands them arrays.

pub mod base;
pub mod calibrate;
pub mod cli;
pub mod diagnose;
pub mod emulate;
pub mod error;
pub mod execute;
pub mod extract;
pub mod pipeline;
pub mod plan;
pub mod render;
pub mod report;
pub mod study;
