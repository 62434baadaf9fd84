//! Measured tests: a CSV with a `design` column, one column per design variable and the response.
//! Rows with the same `design` are replicates: averaged, their scatter kept as the noise estimate.

use std::path::{Path, PathBuf};

use crate::error::InputError;

/// All tested designs of a study, in the order they first appear in the CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiments {
    pub file: PathBuf,
    /// The CSV column holding the measured response.
    pub response: String,
    pub designs: Vec<TestDesign>,
}

/// One tested design and its replicate measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct TestDesign {
    pub name: String,
    /// Design-variable values, in the study's design-variable order.
    pub values: Vec<f64>,
    /// Every replicate measurement, in file order.
    pub replicates: Vec<f64>,
}

impl TestDesign {
    pub fn mean(&self) -> f64 {
        self.replicates.iter().sum::<f64>() / self.replicates.len() as f64
    }

    /// Sample standard deviation of the replicates; `None` with a single test.
    pub fn std_dev(&self) -> Option<f64> {
        let n = self.replicates.len();
        (n > 1).then(|| {
            let m = self.mean();
            (self.replicates.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        })
    }
}

impl Experiments {
    pub fn get(&self, name: &str) -> Option<&TestDesign> {
        self.designs.iter().find(|d| d.name == name)
    }
}

/// Reads the experiments CSV. `design_variables` are the study's design-variable names: each must be
/// a column, as must `design` and `response`.
pub fn read(_file: &Path, _response: &str, _design_variables: &[String]) -> Result<Experiments, InputError> {
    todo!("experiments::read")
}
