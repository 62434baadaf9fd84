//! The domain values `lab run` returns beside the calibration and the diagnosis, which the report
//! words, draws and writes into results.json and report-data.json: the calibration on whole
//! curves, and where along the stroke the model errs.

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

/// `curve_calibration`: the grid, the functional emulator, and each method on curves.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CurveCalibrationResult {
    /// The metric calibration minimises and the values below measure.
    pub metric: String,
    pub points: usize,
    /// Stroke window of the grid, mm.
    pub window: [f64; 2],
    /// `{cfc, speed}` when the curves are filtered; `null` otherwise.
    pub filter: Option<CurveFilterResult>,
    pub emulator: CurveEmulatorResult,
    /// Keyed by method name, in the study's order.
    #[serde(flatten)]
    pub methods: IndexMap<String, CurveMethodResult>,
    /// Per parameter: its standard error from the whole curves and from the mean forces alone
    /// (`null`: infinite, the mean forces cannot tell it from the others).
    pub identifiability: Vec<CurvePinned>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CurveFilterResult {
    pub cfc: f64,
    /// Crush speed, m/s.
    pub speed: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CurveEmulatorResult {
    /// Principal components kept, per design.
    pub components: IndexMap<String, usize>,
    /// Largest relative reconstruction error ‖Y − Ŷ‖/‖Y‖ of the runs' curves over the designs.
    pub reconstruction_error: f64,
    /// Largest relative error ‖η − y‖/‖y‖ of the predicted whole curves at the check runs; `null`
    /// without check runs.
    pub check_error: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CurveMethodResult {
    pub parameters: IndexMap<String, f64>,
    /// Bayesian: 95 % posterior intervals.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub intervals: Option<IndexMap<String, [f64; 2]>>,
    /// The metric's mean over the training designs' specimens.
    pub train: Option<f64>,
    /// ... and over the validation designs' specimens (`null` without validation designs).
    pub validation: Option<f64>,
    /// Sensitivity: the offset curve's mean over the stroke (kN).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub offset_mean: Option<f64>,
    /// Bayesian: posterior median of the discrepancy's scale σ_δ (kN).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub discrepancy_sd: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub error: Option<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CurvePinned {
    pub parameter: String,
    pub curves_se: Option<f64>,
    pub mean_force_se: Option<f64>,
}

/// One tested design on the stroke grid of the curve calibration: the specimens' mean and
/// standard deviation at each stroke, the uncorrected simulation's curve at its calibrated
/// parameters (`before`) and the named cause's model (`after`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ResidualCurves {
    pub design: String,
    pub validation: bool,
    pub stroke: Vec<f64>,
    pub test_mean: Vec<f64>,
    /// The specimens' sample standard deviation (0 with one specimen).
    pub test_sd: Vec<f64>,
    pub specimens: usize,
    pub before: Option<Vec<f64>>,
    pub after: Option<Vec<f64>>,
    /// The cause whose model `after` is.
    pub after_label: Option<String>,
}

impl ResidualCurves {
    /// The band of one design: the specimens' pointwise mean and sample standard deviation.
    pub fn band(design: &str, validation: bool, stroke: Vec<f64>, specimens: &[Vec<f64>]) -> ResidualCurves {
        let n = specimens.len();
        let at = |i: usize| specimens.iter().map(move |c| c[i]);
        let mean: Vec<f64> = (0..stroke.len()).map(|i| at(i).sum::<f64>() / n as f64).collect();
        let sd = (0..stroke.len())
            .map(|i| {
                if n < 2 {
                    return 0.0;
                }
                (at(i).map(|v| (v - mean[i]).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
            })
            .collect();
        ResidualCurves {
            design: design.to_string(),
            validation,
            stroke,
            test_mean: mean,
            test_sd: sd,
            specimens: n,
            before: None,
            after: None,
            after_label: None,
        }
    }
}
