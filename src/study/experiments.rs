//! Measured tests: a CSV with a `design` column, one column per design variable and the response.
//! Rows with the same `design` are replicates: averaged, their scatter kept as the noise estimate.
//! Optionally the response's unit and, per design, the test machine's force–displacement curves of
//! its specimens (`experiments.unit`, `experiments.curves`; checked by the study loader).

use std::path::{Path, PathBuf};

use crate::error::InputError;
use crate::extract::crush::ForceDisplacement;

/// All tested designs of a study, in the order they first appear in the CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiments {
    pub file: PathBuf,
    /// The CSV column holding the measured response.
    pub response: String,
    /// The response's unit (`experiments.unit`), for labels.
    pub unit: Option<String>,
    pub designs: Vec<TestDesign>,
    /// `experiments.curves`: the specimens' force–displacement curves, per tested design that has
    /// any, in the experiments' design order.
    pub curves: Vec<SpecimenCurves>,
}

/// The test-machine curves of one tested design (mm, kN, compression positive).
#[derive(Debug, Clone, PartialEq)]
pub struct SpecimenCurves {
    pub design: String,
    /// (file, its curve), in file-name order.
    pub specimens: Vec<(PathBuf, ForceDisplacement)>,
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
///
/// Errors name the CSV file and the line (and, for a bad value, the column) of the offending row.
pub fn read(file: &Path, response: &str, design_variables: &[String]) -> Result<Experiments, InputError> {
    let source = std::fs::read_to_string(file)
        .map_err(|e| InputError::file(file, format!("cannot read the experiments file: {e}")))?;
    let at = |line: usize, column: usize, message: String| InputError::at(file, &source, line, column, message);

    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(source.as_bytes());
    let header = reader.headers().map_err(|e| csv_error(file, &source, &e))?.clone();
    if header.iter().all(str::is_empty) {
        return Err(InputError::file(
            file,
            format!(
                "the experiments file is empty: expected a header row with `design`, {}and `{response}`",
                design_variables.iter().map(|v| format!("`{v}`, ")).collect::<String>()
            ),
        ));
    }
    let header_line = header.position().map_or(1, |p| p.line() as usize);
    let listed = header.iter().map(|h| format!("`{h}`")).collect::<Vec<_>>().join(", ");
    let column_of = |name: &str| -> Result<usize, InputError> {
        let mut found = header.iter().enumerate().filter(|(_, h)| *h == name).map(|(i, _)| i);
        let first = found.next().ok_or_else(|| {
            at(
                header_line,
                1,
                format!("missing column `{name}`; the header has: {listed}"),
            )
        })?;
        if let Some(again) = found.next() {
            return Err(at(
                header_line,
                field_column(source_line(&source, header_line), again),
                format!("column `{name}` appears twice in the header"),
            ));
        }
        Ok(first)
    };
    let design_col = column_of("design")?;
    let value_cols = design_variables
        .iter()
        .map(|v| column_of(v).map(|c| (v.as_str(), c)))
        .collect::<Result<Vec<_>, _>>()?;
    let response_col = column_of(response)?;

    let mut designs: Vec<TestDesign> = Vec::new();
    // Line of the row that first set each design's values, for the replicate-mismatch message.
    let mut first_lines: Vec<usize> = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err(csv_error(file, &source, &e)),
        }
        let line = record.position().map_or(0, |p| p.line() as usize);
        let text = source_line(&source, line);
        if record.len() != header.len() {
            return Err(at(
                line,
                1,
                format!(
                    "this row has {} fields but the header has {}",
                    record.len(),
                    header.len()
                ),
            ));
        }
        let name = &record[design_col];
        if name.is_empty() {
            return Err(at(
                line,
                field_column(text, design_col),
                "empty design name".to_string(),
            ));
        }
        let number = |column: &str, index: usize| -> Result<f64, InputError> {
            let raw = &record[index];
            match raw.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(at(
                    line,
                    field_column(text, index),
                    format!("column `{column}`: expected a finite number, found `{raw}`"),
                )),
            }
        };
        let values = value_cols
            .iter()
            .map(|&(v, c)| number(v, c))
            .collect::<Result<Vec<_>, _>>()?;
        let measured = number(response, response_col)?;
        match designs.iter().position(|d| d.name == name) {
            Some(k) => {
                let known = &designs[k];
                if let Some(j) = (0..values.len()).find(|&j| !same(values[j], known.values[j])) {
                    let (var, col) = value_cols[j];
                    return Err(at(
                        line,
                        field_column(text, col),
                        format!(
                            "replicate of design `{name}` has {var} = {}, but line {} has {var} = {}; \
                             rows of one design must agree on the design variables",
                            values[j], first_lines[k], known.values[j]
                        ),
                    ));
                }
                designs[k].replicates.push(measured);
            }
            None => {
                designs.push(TestDesign {
                    name: name.to_string(),
                    values,
                    replicates: vec![measured],
                });
                first_lines.push(line);
            }
        }
    }
    if designs.is_empty() {
        return Err(at(
            header_line,
            1,
            "no data rows after the header: expected one row per test".to_string(),
        ));
    }
    Ok(Experiments {
        file: file.to_path_buf(),
        response: response.to_string(),
        unit: None,
        designs,
        curves: Vec::new(),
    })
}

/// Equal up to rounding of the printed values.
fn same(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
}

/// Line `line` (from 1) of `source`, or "" past the end.
fn source_line(source: &str, line: usize) -> &str {
    line.checked_sub(1).and_then(|i| source.lines().nth(i)).unwrap_or("")
}

/// Character column (from 1) where field `index` of a CSV line starts, skipping leading blanks.
/// Commas inside double quotes do not separate fields.
fn field_column(line: &str, index: usize) -> usize {
    let mut field = 0;
    let mut quoted = false;
    let mut start = 0;
    for (i, c) in line.chars().enumerate() {
        if field == index {
            start = i;
            break;
        }
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => {
                field += 1;
                start = i + 1;
            }
            _ => {}
        }
    }
    if field < index {
        return line.chars().count() + 1;
    }
    let skipped = line.chars().skip(start).take_while(|c| *c == ' ' || *c == '\t').count();
    start + skipped + 1
}

/// A CSV-level error (bad quoting, invalid UTF-8) at its line when the csv crate knows it.
fn csv_error(file: &Path, source: &str, error: &csv::Error) -> InputError {
    let message = match error.kind() {
        csv::ErrorKind::Utf8 { .. } => "invalid UTF-8 text".to_string(),
        _ => format!("malformed CSV: {error}"),
    };
    match error.position() {
        Some(p) if p.line() > 0 => InputError::at(file, source, p.line() as usize, 1, message),
        _ => InputError::file(file, message),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn field_columns_follow_commas_outside_quotes() {
        assert_eq!(field_column("a,bb,c", 0), 1);
        assert_eq!(field_column("a,bb,c", 2), 6);
        assert_eq!(field_column("\"x,y\", 2", 1), 8);
        assert_eq!(field_column("a", 3), 2);
    }
}
