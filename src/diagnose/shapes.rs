//! Candidate causes of model error: additive discrepancy shapes `g(d, θ, y)` with a free amplitude γ,
//! `y_true(d) = y(d, θ) + γ · g(d, θ, y(d, θ))`.

use std::fmt;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::study::expr::ExprError;
use crate::study::{Expression, Hypothesis, Study, Symbols};

/// Where a candidate comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Origin {
    /// One of the study's `diagnosis.hypotheses`: a cause the user named.
    Study,
    /// One of the shapes every diagnosis tries (offset, scale error, linear trends).
    BuiltIn,
}

type ShapeFn = dyn Fn(&[f64], &[f64], f64) -> f64 + Send + Sync;

/// A discrepancy shape `g(design, θ, y)`; its amplitude is fitted with θ.
#[derive(Clone)]
pub struct Shape {
    pub name: String,
    /// The term as the user would write it (`1/h`, `y`, `t`).
    pub term: String,
    pub origin: Origin,
    f: Arc<ShapeFn>,
}

impl fmt::Debug for Shape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Shape")
            .field("name", &self.name)
            .field("term", &self.term)
            .field("origin", &self.origin)
            .finish()
    }
}

impl Shape {
    pub fn new(
        name: impl Into<String>,
        term: impl Into<String>,
        origin: Origin,
        f: impl Fn(&[f64], &[f64], f64) -> f64 + Send + Sync + 'static,
    ) -> Shape {
        Shape { name: name.into(), term: term.into(), origin, f: Arc::new(f) }
    }

    /// `g(design, θ, y)`, where `y` is the simulation's prediction at `design` and `θ`.
    pub fn eval(&self, design: &[f64], theta: &[f64], y: f64) -> f64 {
        (self.f)(design, theta, y)
    }

    /// A study hypothesis: its term is evaluated over design variables, parameters, constants and
    /// `y`, in the order of [`Study::term_symbols`].
    pub fn from_hypothesis(hypothesis: &Hypothesis, study: &Study) -> Shape {
        let expr = hypothesis.term.clone();
        let constants: Vec<f64> = study.constants.iter().map(|(_, v)| *v).collect();
        Shape::new(hypothesis.name.clone(), expr.text().to_string(), Origin::Study, move |d, theta, y| {
            let values: Vec<f64> = d.iter().chain(theta).chain(&constants).copied().chain(std::iter::once(y)).collect();
            expr.eval(&values)
        })
    }

    /// A term written as in a study file, compiled over `design_names`, `parameter_names`, the
    /// constants' names and `y` (the order of [`Study::term_symbols`]).
    pub fn from_term(
        name: impl Into<String>,
        term: &str,
        design_names: &[String],
        parameter_names: &[String],
        constants: &[(String, f64)],
    ) -> Result<Shape, ExprError> {
        let symbols = Symbols::new(
            design_names
                .iter()
                .chain(parameter_names)
                .chain(constants.iter().map(|(n, _)| n))
                .cloned()
                .chain(["y".to_string()]),
        );
        let expr = Expression::compile(term, &symbols)?;
        let values: Vec<f64> = constants.iter().map(|(_, v)| *v).collect();
        Ok(Shape::new(name, term, Origin::Study, move |d, theta, y| {
            let all: Vec<f64> = d.iter().chain(theta).chain(&values).copied().chain(std::iter::once(y)).collect();
            expr.eval(&all)
        }))
    }

    /// The shapes every diagnosis tries: a constant offset, an error proportional to the prediction
    /// (a scale error), and a term proportional to each design variable.
    pub fn built_ins(design_names: &[String]) -> Vec<Shape> {
        let mut shapes = vec![
            Shape::new("constant offset", "1", Origin::BuiltIn, |_, _, _| 1.0),
            Shape::new("scale error", "y", Origin::BuiltIn, |_, _, y| y),
        ];
        for (j, name) in design_names.iter().enumerate() {
            shapes.push(Shape::new(format!("linear in {name}"), name.clone(), Origin::BuiltIn, move |d, _, _| d[j]));
        }
        shapes
    }
}
