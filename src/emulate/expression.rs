//! The simulation as a function `y(d, θ)` — Dakota's *model*.
//!
//! A closed-form study evaluates its expression; solver studies answer from per-design
//! surrogates fitted to runs ([`crate::emulate::SurrogateModel`]). Either way the numerics see a [`crate::emulate::Model`].

use super::Model;
use crate::study::{Expression, Simulation, Study};

/// A closed-form simulation bound to the study's constants.
pub struct ExpressionModel {
    expr: Expression,
    n_design: usize,
    n_theta: usize,
    constants: Vec<f64>,
}

impl ExpressionModel {
    /// The closed form of `study`, or `None` when its simulation is a solver.
    pub fn new(study: &Study) -> Option<Self> {
        let Simulation::Expression(expr) = &study.simulation else {
            return None;
        };
        Some(ExpressionModel {
            expr: expr.clone(),
            n_design: study.design.len(),
            n_theta: study.parameters.len(),
            constants: study.constants.iter().map(|(_, v)| *v).collect(),
        })
    }
}

impl Model for ExpressionModel {
    fn predict(&self, design: &[f64], theta: &[f64]) -> f64 {
        debug_assert_eq!((design.len(), theta.len()), (self.n_design, self.n_theta));
        // Symbol order is fixed by `Study::symbols`: design, parameters, constants.
        let values: Vec<f64> = design.iter().chain(theta).chain(&self.constants).copied().collect();
        self.expr.eval(&values)
    }
}
