//! Step 8a: the residuals of the uncorrected model at every design, and their structure.
//!
//! Each residual is standardised by σ of the mean measurement, σ_i/√n_i. The structure is a rank
//! correlation (Spearman) and a linear trend of the standardised residuals against each design
//! variable and against the prediction. With replicate noise the standardised residuals have unit
//! variance under no model error, so the slope's standard error is 1/√Sxx (normal test); without,
//! the scatter about the trend line gives it (t test, n − 2 degrees of freedom). `significant` uses
//! the same α as the verdict.

use super::fit::Fit;
use super::{Context, NoiseModel, Residual, TestMean, Trend, stats};

pub(crate) fn table(cx: &Context, fit: &Fit, noise: &NoiseModel) -> Vec<Residual> {
    let inputs = cx.inputs;
    inputs
        .observations
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let predicted = cx.data.predict(&[], fit.theta.as_slice(), &[], &cx.data.designs[i]);
            let residual = o.mean - predicted;
            let sigma = noise.sigma_at(o.mean).max(f64::MIN_POSITIVE) / (o.count.max(1) as f64).sqrt();
            Residual {
                design: o.name.clone(),
                role: o.role,
                values: inputs.space.design_at(&o.design),
                predicted,
                residual,
                relative_error: cx.relative_error(i, predicted).filter(|e| e.is_finite()),
                sigma,
                z: residual / sigma,
                test: TestMean {
                    measured: o.mean,
                    count: o.count,
                    std_dev: o.std_dev,
                },
            }
        })
        .collect()
}

pub(crate) fn trends(cx: &Context, residuals: &[Residual]) -> Vec<Trend> {
    let inputs = cx.inputs;
    let z: Vec<f64> = residuals.iter().map(|r| r.z).collect();
    let mut against: Vec<(String, Vec<f64>)> = inputs
        .space
        .design_names
        .iter()
        .enumerate()
        .map(|(j, name)| (name.clone(), inputs.observations.iter().map(|o| o.design[j]).collect()))
        .collect();
    against.push((
        "prediction".to_string(),
        residuals.iter().map(|r| r.predicted).collect(),
    ));
    let n = z.len();
    against
        .into_iter()
        .filter(|(_, x)| n >= 3 && x.iter().any(|&v| v != x[0]))
        .map(|(name, x)| trend(cx, name, &x, &z))
        .collect()
}

fn trend(cx: &Context, against: String, x: &[f64], z: &[f64]) -> Trend {
    let nf = z.len() as f64;
    let (rho, rho_p) = stats::spearman(x, z);
    let (mx, mz) = (x.iter().sum::<f64>() / nf, z.iter().sum::<f64>() / nf);
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    let slope = x.iter().zip(z).map(|(a, b)| (a - mx) * (b - mz)).sum::<f64>() / sxx;
    let slope_p = if cx.known() {
        stats::normal_two_sided(slope * sxx.sqrt())
    } else {
        let ss: f64 = x.iter().zip(z).map(|(a, b)| (b - mz - slope * (a - mx)).powi(2)).sum();
        let se = (ss / (nf - 2.0) / sxx).sqrt();
        if se > 0.0 {
            stats::t_two_sided(slope / se, nf - 2.0)
        } else {
            0.0
        }
    };
    Trend {
        against,
        rank_correlation: rho,
        rank_p_value: rho_p,
        slope,
        slope_p_value: slope_p,
        significant: rho_p < cx.alpha() || slope_p < cx.alpha(),
    }
}
