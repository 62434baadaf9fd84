//! When the final model still misses the tests, its calibrated parameters are only as good as the
//! model: the residuals beyond the noise pull them. How far: the model is fitted again with each
//! training design it misses by more than 2 σ given a free offset of its own (the same as leaving
//! that design out of the fit), and the shift of every parameter is reported in its own units, as
//! a fraction of its value and in standard errors of the fit (the influence of those observations,
//! DFBETAS in the language of Belsley, Kuh & Welsch 1980, for a group of them at once). Where no
//! training design is beyond 2 σ (the misses are at validation designs, which do not pull the fit),
//! the training design with the largest residual stands in.

use nalgebra::DVector;
use serde::{Deserialize, Serialize};

use super::Context;
use super::candidates::Model;
use super::fit::Covariance;

/// How far one parameter moves when the misfit is absorbed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterLimit {
    pub parameter: String,
    pub estimate: f64,
    /// The training designs whose residuals were absorbed (each with its standardised residual).
    pub absorbed: Vec<(String, f64)>,
    /// The estimate with them absorbed.
    pub moved_to: f64,
    /// moved_to / estimate − 1.
    pub relative: f64,
    /// |moved_to − estimate| in standard errors of the fit (absent without its covariance).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub standard_errors: Option<f64>,
}

/// The limits of `m`'s parameters given its standardised residuals `z` (design name → z), largest
/// move first; empty when the refit is not possible (too few designs left).
pub(crate) fn limits(
    cx: &Context,
    m: &Model,
    z: &indexmap::IndexMap<String, f64>,
    cov: Option<&Covariance>,
) -> Vec<ParameterLimit> {
    let absorbed = absorbed(cx, z);
    if absorbed.is_empty() {
        return Vec::new();
    }
    let rest: Vec<usize> = cx
        .train
        .iter()
        .copied()
        .filter(|i| !absorbed.iter().any(|(j, _)| j == i))
        .collect();
    if rest.len() < m.k() {
        return Vec::new();
    }
    let shapes = m.shapes();
    let Ok(refit) = cx.data.fit_from(&shapes, &rest, &m.fit.theta) else {
        return Vec::new();
    };
    let names: Vec<(String, f64)> = absorbed
        .iter()
        .map(|&(i, zi)| (cx.inputs.observations[i].name.clone(), zi))
        .collect();
    let mut out = moves(cx, &m.fit.theta, &refit.theta, cov, &names);
    out.sort_by(|a, b| b.relative.abs().total_cmp(&a.relative.abs()));
    out
}

/// The training designs to absorb: those beyond 2 σ, else the one with the largest |z|.
fn absorbed(cx: &Context, z: &indexmap::IndexMap<String, f64>) -> Vec<(usize, f64)> {
    let train: Vec<(usize, f64)> = cx
        .train
        .iter()
        .filter_map(|&i| z.get(&cx.inputs.observations[i].name).map(|&zi| (i, zi)))
        .collect();
    let beyond: Vec<(usize, f64)> = train.iter().copied().filter(|(_, zi)| zi.abs() > 2.0).collect();
    if !beyond.is_empty() {
        return beyond;
    }
    train
        .into_iter()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .into_iter()
        .collect()
}

fn moves(
    cx: &Context,
    before: &DVector<f64>,
    after: &DVector<f64>,
    cov: Option<&Covariance>,
    absorbed: &[(String, f64)],
) -> Vec<ParameterLimit> {
    cx.inputs
        .space
        .parameter_names
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let se = cov.map(|c| c.matrix[(j, j)].sqrt()).filter(|s| *s > 0.0);
            ParameterLimit {
                parameter: name.clone(),
                estimate: before[j],
                absorbed: absorbed.to_vec(),
                moved_to: after[j],
                relative: after[j] / before[j] - 1.0,
                standard_errors: se.map(|s| (after[j] - before[j]).abs() / s),
            }
        })
        .collect()
}
