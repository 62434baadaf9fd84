//! `lab` calibrates simulation models against tests.
//!
//! The crate is laid out as the pipeline it runs; one typed value flows from each stage to the next:
//!
//! ```text
//! study ──► plan ──► (render ► execute ► extract) ──► fit ──► calibrate ──► diagnose ──► report
//! Study     Plan       run store, responses           Model   Calibration   Diagnosis    results.json
//! ```
//!
//! - [`study`]: the study file and the experiments it names, loaded strictly into a [`study::Study`].
//! - [`model`]: the simulation as a function `y(d, θ)` (a closed-form expression, or surrogates).
//! - [`plan`]: sampling plans (Latin hypercube) for simulation runs.
//! - [`calibrate`]: the paper's three methods and the identifiability check, as pure numerics.
//! - [`report`]: `results.json` and the terminal summary.
//! - [`pipeline`]: wires the stages together for `lab run`.
//!
//! Numerics never read files and never block on I/O; everything else hands them arrays.

pub mod calibrate;
pub mod cli;
pub mod crushsim;
pub mod diagnose;
pub mod error;
pub mod execute;
pub mod extract;
pub mod fit;
pub mod model;
pub mod pipeline;
pub mod plan;
pub mod render;
pub mod report;
pub mod study;
