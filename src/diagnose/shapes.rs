//! Candidate causes of model error: additive discrepancy shapes `g(d, θ, y)` with a free amplitude γ,
//! `y_true(d) = y(d, θ) + γ · g(d, θ, y(d, θ))`.
//!
//! A model extension (a hypothesis with `extension:`, solver studies) is a shape too:
//! `g(d, θ) = y_ext(d, θ) − y(d, θ)`, where `y_ext` is the surrogate of the extension's runs (the
//! templates rendered with its extra variables). γ = 1 is the extension exactly as specified, γ = 0
//! the baseline. This linearises the extension around the baseline: `y + γ (y_ext − y)` is the
//! response with the extension variable moved a fraction γ of the way from its baseline value to
//! the specified one, which is exact when the response is linear in that variable (so then, with a
//! baseline of 0, γ × value is the value the tests want) and a first-order approximation otherwise.

use std::fmt;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::base::format::num;
use crate::emulate::Model;
use crate::study::expr::ExprError;
use crate::study::{Expression, Hypothesis, HypothesisKind, Study, Symbols};

/// Where a candidate comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Origin {
    /// One of the study's `diagnosis.hypotheses`: a cause the user named.
    Study,
    /// One of the shapes every diagnosis tries (offset, scale error, linear trends).
    BuiltIn,
    /// A shape of the discovery library ([`super::library`]): found by search, not listed.
    Search,
}

type ShapeFn = dyn Fn(&[f64], &[f64], f64) -> f64 + Send + Sync;

/// A discrepancy shape `g(design, θ, y)`; its amplitude is fitted with θ.
#[derive(Clone)]
pub struct Shape {
    pub name: String,
    /// The term as the user would write it (`1/h`, `y`, `t`).
    pub term: String,
    pub origin: Origin,
    /// The template variables of a model extension (`None` for a term).
    pub extension: Option<Vec<(String, f64)>>,
    /// The ranges the study declares for a model extension's variables (name, min, max): what its
    /// amplitude can physically be.
    pub ranges: Vec<(String, f64, f64)>,
    f: Arc<ShapeFn>,
}

impl fmt::Debug for Shape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Shape")
            .field("name", &self.name)
            .field("term", &self.term)
            .field("origin", &self.origin)
            .field("extension", &self.extension)
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
        Shape {
            name: name.into(),
            term: term.into(),
            origin,
            extension: None,
            ranges: Vec::new(),
            f: Arc::new(f),
        }
    }

    /// `g(design, θ, y)`, where `y` is the simulation's prediction at `design` and `θ`.
    pub fn eval(&self, design: &[f64], theta: &[f64], y: f64) -> f64 {
        (self.f)(design, theta, y)
    }

    /// A study hypothesis: its term is evaluated over design variables, parameters, constants and
    /// `y`, in the order of [`Study::term_symbols`]. A model extension needs the surrogate of its
    /// runs ([`Shape::from_extension`]); without one its shape is NaN everywhere, which the
    /// diagnosis skips with a note.
    pub fn from_hypothesis(hypothesis: &Hypothesis, study: &Study) -> Shape {
        let expr = match &hypothesis.kind {
            HypothesisKind::Term(expr) => expr.clone(),
            HypothesisKind::Extension(extension) => {
                let missing: Arc<dyn Model + Send> = Arc::new(|_: &[f64], _: &[f64]| f64::NAN);
                return Shape::from_extension(hypothesis.name.clone(), &extension.screening, missing);
            }
        };
        let constants: Vec<f64> = study.constants.iter().map(|(_, v)| *v).collect();
        Shape::new(
            hypothesis.name.clone(),
            expr.text().to_string(),
            Origin::Study,
            move |d, theta, y| {
                let values: Vec<f64> = d
                    .iter()
                    .chain(theta)
                    .chain(&constants)
                    .copied()
                    .chain(std::iter::once(y))
                    .collect();
                expr.eval(&values)
            },
        )
    }

    /// A model extension: `g(d, θ, y) = y_ext(d, θ) − y`, where `extension` predicts the response
    /// of the extension's runs (NaN where it has none). Its term reads `y[shear = 1] − y`.
    pub fn from_extension(
        name: impl Into<String>,
        variables: &[(String, f64)],
        extension: Arc<dyn Model + Send>,
    ) -> Shape {
        let set = setting(variables);
        let mut shape = Shape::new(name, format!("y[{set}] - y"), Origin::Study, move |d, theta, y| {
            extension.predict(d, theta) - y
        });
        shape.extension = Some(variables.to_vec());
        shape
    }

    /// A model extension's effect as a candidate for *another* base model: `g(d, θ) = y_ext(d, θ₀) −
    /// y(d, θ₀)`, with θ₀ the first `p` entries of θ (the study's parameters) and `baseline` the
    /// study's own simulation. Used where the base is a loop model with more parameters, whose own
    /// prediction must not enter the shape.
    pub fn effect(
        name: impl Into<String>,
        variables: &[(String, f64)],
        extension: Arc<dyn Model + Send>,
        baseline: Arc<dyn Model + Send>,
        p: usize,
    ) -> Shape {
        let mut shape = Shape::from_extension(name, variables, extension.clone());
        shape.f = Arc::new(move |d, theta, _| {
            let t = &theta[..p.min(theta.len())];
            extension.predict(d, t) - baseline.predict(d, t)
        });
        shape
    }

    /// What a fitted amplitude γ of this extension means, in words (`None` for a term).
    pub fn amplitude_meaning(&self, gamma: f64) -> Option<String> {
        let variables = self.extension.as_ref()?;
        let set = setting(variables);
        let g = num(gamma);
        let mut s = format!(
            "γ = {g}: the tests want {g} × the effect of the extension as specified ({set}); γ = 1 is the \
             extension exactly, γ = 0 the baseline. The extension enters linearised around the baseline, exact when \
             the response is linear in the extension's variables"
        );
        if let [(k, v)] = variables.as_slice() {
            s.push_str(&format!(
                ": then, with {k} = 0 in the baseline, the tests want {k} ≈ γ × {} = {}",
                num(*v),
                num(gamma * v)
            ));
        }
        s.push('.');
        Some(s)
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
            let all: Vec<f64> = d
                .iter()
                .chain(theta)
                .chain(&values)
                .copied()
                .chain(std::iter::once(y))
                .collect();
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
            shapes.push(Shape::new(
                format!("linear in {name}"),
                name.clone(),
                Origin::BuiltIn,
                move |d, _, _| d[j],
            ));
        }
        shapes
    }
}

/// An extension's template variables as set: `shear = 1, etan = 200`.
pub(crate) fn setting(variables: &[(String, f64)]) -> String {
    variables
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}
