//! Measured tests: a CSV with a `design` column, one column per design variable and the response.
//! Rows with the same `design` are replicates: averaged, their scatter kept as the noise estimate.
//! Optionally the response's unit and, per design, the test machine's force–displacement curves of
//! its specimens (`experiments.unit`, `experiments.curves`; checked by the study loader).

use std::path::{Path, PathBuf};

use crate::base::curve::ForceDisplacement;
use crate::error::InputError;

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
    /// `experiments.uncertainty`: the measurement's uncertainty of one test, `[absolute, relative]`
    /// (σ² = a² + (b·y)²), the noise where the tests have no replicates.
    pub uncertainty: Option<[f64; 2]>,
    /// Known parameter values (`truth`: synthetic tests), by parameter name, in parameter order.
    pub truth: Vec<(String, f64)>,
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
        mean_sd(&self.replicates).0
    }

    /// Sample standard deviation of the replicates; `None` with a single test.
    pub fn std_dev(&self) -> Option<f64> {
        mean_sd(&self.replicates).1
    }
}

/// The mean of `v` and its sample standard deviation (`None` with fewer than two values).
pub fn mean_sd(v: &[f64]) -> (f64, Option<f64>) {
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n as f64;
    let sd = (n > 1).then(|| (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt());
    (mean, sd)
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
    let csv = Csv { file, source: &source };
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(source.as_bytes());
    let header = reader.headers().map_err(|e| csv_error(file, &source, &e))?.clone();
    let columns = csv.columns(&header, response, design_variables)?;
    let mut designs = Designs::default();
    let mut record = csv::StringRecord::new();
    while reader
        .read_record(&mut record)
        .map_err(|e| csv_error(file, &source, &e))?
    {
        let row = csv.row(&record, &header, &columns)?;
        designs.add(row, &csv, &columns)?;
    }
    if designs.designs.is_empty() {
        return Err(csv.at(
            columns.header_line,
            1,
            "no data rows after the header: expected one row per test".to_string(),
        ));
    }
    Ok(Experiments {
        file: file.to_path_buf(),
        response: response.to_string(),
        unit: None,
        designs: designs.designs,
        curves: Vec::new(),
        uncertainty: None,
        truth: Vec::new(),
    })
}

/// The experiments file and its text, for located errors.
struct Csv<'a> {
    file: &'a Path,
    source: &'a str,
}

/// Where the columns a study needs are in the header.
struct Columns<'a> {
    header_line: usize,
    design: usize,
    /// Each design variable's name and column, in the study's order.
    values: Vec<(&'a str, usize)>,
    response: (&'a str, usize),
}

/// One data row, checked: its line, design name, design-variable values and measurement.
struct Row {
    line: usize,
    text: String,
    name: String,
    values: Vec<f64>,
    measured: f64,
}

/// The designs read so far, with the line that first set each one's values.
#[derive(Default)]
struct Designs {
    designs: Vec<TestDesign>,
    first_lines: Vec<usize>,
}

impl Csv<'_> {
    fn at(&self, line: usize, column: usize, message: String) -> InputError {
        InputError::at(self.file, self.source, line, column, message)
    }

    /// The header's columns for `design`, each design variable and the response: each present once.
    fn columns<'a>(
        &self,
        header: &csv::StringRecord,
        response: &'a str,
        design_variables: &'a [String],
    ) -> Result<Columns<'a>, InputError> {
        if header.iter().all(str::is_empty) {
            return Err(InputError::file(
                self.file,
                format!(
                    "the experiments file is empty: expected a header row with `design`, {}and `{response}`",
                    design_variables.iter().map(|v| format!("`{v}`, ")).collect::<String>()
                ),
            ));
        }
        let header_line = header.position().map_or(1, |p| p.line() as usize);
        let column_of = |name: &str| self.column_of(header, header_line, name);
        Ok(Columns {
            header_line,
            design: column_of("design")?,
            values: design_variables
                .iter()
                .map(|v| column_of(v).map(|c| (v.as_str(), c)))
                .collect::<Result<Vec<_>, _>>()?,
            response: (response, column_of(response)?),
        })
    }

    /// The column named `name`: present, and only once.
    fn column_of(&self, header: &csv::StringRecord, header_line: usize, name: &str) -> Result<usize, InputError> {
        let mut found = header.iter().enumerate().filter(|(_, h)| *h == name).map(|(i, _)| i);
        let first = found.next().ok_or_else(|| {
            let listed = header.iter().map(|h| format!("`{h}`")).collect::<Vec<_>>().join(", ");
            self.at(
                header_line,
                1,
                format!("missing column `{name}`; the header has: {listed}"),
            )
        })?;
        if let Some(again) = found.next() {
            return Err(self.at(
                header_line,
                field_column(source_line(self.source, header_line), again),
                format!("column `{name}` appears twice in the header"),
            ));
        }
        Ok(first)
    }

    /// A data row: as many fields as the header, a design name, finite numbers.
    fn row(
        &self,
        record: &csv::StringRecord,
        header: &csv::StringRecord,
        columns: &Columns,
    ) -> Result<Row, InputError> {
        let line = record.position().map_or(0, |p| p.line() as usize);
        let text = source_line(self.source, line);
        if record.len() != header.len() {
            return Err(self.at(
                line,
                1,
                format!(
                    "this row has {} fields but the header has {}",
                    record.len(),
                    header.len()
                ),
            ));
        }
        let name = &record[columns.design];
        if name.is_empty() {
            return Err(self.at(
                line,
                field_column(text, columns.design),
                "empty design name".to_string(),
            ));
        }
        let number = |column: &str, index: usize| -> Result<f64, InputError> {
            let raw = &record[index];
            match raw.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(self.at(
                    line,
                    field_column(text, index),
                    format!("column `{column}`: expected a finite number, found `{raw}`"),
                )),
            }
        };
        let values = columns
            .values
            .iter()
            .map(|&(v, c)| number(v, c))
            .collect::<Result<Vec<_>, _>>()?;
        let measured = number(columns.response.0, columns.response.1)?;
        Ok(Row {
            line,
            text: text.to_string(),
            name: name.to_string(),
            values,
            measured,
        })
    }
}

impl Designs {
    /// A row joins its design as a replicate (its design variables must agree) or starts a new one.
    fn add(&mut self, row: Row, csv: &Csv, columns: &Columns) -> Result<(), InputError> {
        let Some(k) = self.designs.iter().position(|d| d.name == row.name) else {
            self.designs.push(TestDesign {
                name: row.name,
                values: row.values,
                replicates: vec![row.measured],
            });
            self.first_lines.push(row.line);
            return Ok(());
        };
        let known = &self.designs[k];
        if let Some(j) = (0..row.values.len()).find(|&j| !same(row.values[j], known.values[j])) {
            let (var, col) = columns.values[j];
            return Err(csv.at(
                row.line,
                field_column(&row.text, col),
                format!(
                    "replicate of design `{}` has {var} = {}, but line {} has {var} = {}; \
                     rows of one design must agree on the design variables",
                    row.name, row.values[j], self.first_lines[k], known.values[j]
                ),
            ));
        }
        self.designs[k].replicates.push(row.measured);
        Ok(())
    }
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
