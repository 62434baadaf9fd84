//! A force–displacement curve, and a test machine's CSV of one.

use std::path::Path;

use super::number::parse_number;
use crate::error::InputError;

/// A force–displacement curve: displacement in mm, force in kN, compression positive.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceDisplacement {
    pub displacement: Vec<f64>,
    pub force: Vec<f64>,
}

/// Force unit of a test-machine CSV.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForceUnit {
    KiloNewton,
    Newton,
}

impl ForceUnit {
    fn to_kn(self) -> f64 {
        match self {
            ForceUnit::KiloNewton => 1.0,
            ForceUnit::Newton => 1e-3,
        }
    }
}

/// Settings of the test-machine CSV reader.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CsvOptions {
    /// The force unit when the header does not say; if both say, they must agree.
    pub force_unit: Option<ForceUnit>,
}

pub fn read_test_csv(file: &Path, opts: CsvOptions) -> Result<ForceDisplacement, InputError> {
    let text = super::number::read_text(file)?;
    parse_test_csv(file, &text, opts)
}

fn split_fields(line: &str) -> Vec<&str> {
    let sep = if line.contains(',') {
        Some(',')
    } else if line.contains(';') {
        Some(';')
    } else if line.contains('\t') {
        Some('\t')
    } else {
        None
    };
    match sep {
        Some(c) => line.split(c).map(str::trim).collect(),
        None => line.split_whitespace().collect(),
    }
}

/// Unit named in a header cell: `[kN]`, `(N)`, `_kN`, ` kN`, `force_n`, ...
fn header_unit(cell: &str) -> Option<String> {
    let c = cell.trim().to_ascii_lowercase();
    if let (Some(a), Some(b)) = (c.find(['[', '(']), c.rfind([']', ')']))
        && b > a
    {
        return Some(c[a + 1..b].trim().to_string());
    }
    c.rsplit(['_', ' ', '/']).next().filter(|u| *u != c).map(str::to_string)
}

/// A test machine's force–displacement CSV: columns displacement \[mm\] and force \[kN or N\], an optional
/// header (recognised by non-numeric cells; it must name the columns: `disp`/`stroke`/`travel`/`extension`
/// and `force`/`load`; without a header the first two columns are displacement and force), `#` comments, separators `,` `;` tab or spaces.
pub fn parse_test_csv(file: &Path, text: &str, opts: CsvOptions) -> Result<ForceDisplacement, InputError> {
    let at = |line: usize, col: usize, m: String| InputError::at(file, text, line, col, m);
    let mut cols = (0usize, 1usize);
    let mut unit = opts.force_unit;
    let mut disp_scale = 1.0;
    let mut header_seen = false;
    let mut d = Vec::new();
    let mut f = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let no = i + 1;
        let line = raw.trim().trim_start_matches('\u{feff}');
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cells = split_fields(line);
        let numeric = cells.iter().all(|c| parse_number(c).is_some());
        if !numeric {
            if header_seen || !d.is_empty() {
                let bad = cells.iter().position(|c| parse_number(c).is_none()).unwrap_or(0);
                let col = raw.find(cells[bad]).map_or(1, |p| p + 1);
                return Err(at(no, col, format!("expected a number, found `{}`", cells[bad])));
            }
            header_seen = true;
            let header = header(file, text, no, &cells, opts)?;
            (cols, unit, disp_scale) = (header.cols, header.unit, header.disp_scale);
            continue;
        }
        let need = cols.0.max(cols.1) + 1;
        if cells.len() < need {
            return Err(at(
                no,
                1,
                format!("expected at least {need} columns, found {}", cells.len()),
            ));
        }
        let dv = parse_number(cells[cols.0]).unwrap_or(f64::NAN);
        let fv = parse_number(cells[cols.1]).unwrap_or(f64::NAN);
        if !dv.is_finite() || !fv.is_finite() {
            return Err(at(no, 1, "expected finite displacement and force values".into()));
        }
        d.push(dv * disp_scale);
        f.push(fv);
    }
    let Some(unit) = unit else {
        return Err(InputError::file(
            file,
            "force unit unknown: name it in the header (e.g. `force [kN]`) or set the force unit (kN or N)",
        ));
    };
    if d.len() < 2 {
        return Err(InputError::file(
            file,
            "expected at least two data rows of displacement and force",
        ));
    }
    let k = unit.to_kn();
    Ok(ForceDisplacement {
        displacement: d,
        force: f.into_iter().map(|x| x * k).collect(),
    })
}

/// The line numbers (from 1) of the data rows of a test-machine CSV, in the order [`parse_test_csv`]
/// reads them: sample `k` (from 1) of the parsed curve sits on line `data_lines(text)[k - 1]`. Lets an
/// error about a sample name its line.
pub fn data_lines(text: &str) -> Vec<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, raw)| {
            let line = raw.trim().trim_start_matches('\u{feff}');
            !line.is_empty() && !line.starts_with('#') && split_fields(line).iter().all(|c| parse_number(c).is_some())
        })
        .map(|(i, _)| i + 1)
        .collect()
}

/// What a CSV header row says: which columns hold displacement and force, the force unit (the
/// header's, else the setting's) and the displacement scale to mm.
struct Header {
    cols: (usize, usize),
    unit: Option<ForceUnit>,
    disp_scale: f64,
}

/// Reads a header row (line `no`): it must name a displacement and a force column; units in it
/// must be known and agree with the setting.
fn header(file: &Path, text: &str, no: usize, cells: &[&str], opts: CsvOptions) -> Result<Header, InputError> {
    let at = |line: usize, col: usize, m: String| InputError::at(file, text, line, col, m);
    let lower: Vec<String> = cells.iter().map(|c| c.to_ascii_lowercase()).collect();
    let dcol = lower
        .iter()
        .position(|c| ["disp", "stroke", "travel", "extension"].iter().any(|k| c.contains(k)));
    let fcol = lower
        .iter()
        .position(|c| ["force", "load"].iter().any(|k| c.contains(k)));
    let cols = match (dcol, fcol) {
        (Some(a), Some(b)) if a != b => (a, b),
        _ => {
            return Err(at(
                no,
                1,
                "header must name a displacement column (disp/stroke) and a force column (force/load)".into(),
            ));
        }
    };
    let mut unit = opts.force_unit;
    let mut disp_scale = 1.0;
    if let Some(u) = header_unit(cells[cols.1]) {
        let hu = match u.as_str() {
            "kn" => Some(ForceUnit::KiloNewton),
            "n" => Some(ForceUnit::Newton),
            _ => None,
        };
        match (hu, opts.force_unit) {
            (Some(h), Some(s)) if h != s => {
                return Err(at(
                    no,
                    1,
                    format!("header says force in {u} but the setting says {s:?}"),
                ));
            }
            (Some(h), _) => unit = Some(h),
            (None, _) if !u.is_empty() && u != "force" && u != "load" => {
                return Err(at(no, 1, format!("unknown force unit `{u}`: expected kN or N")));
            }
            _ => {}
        }
    }
    if let Some(u) = header_unit(cells[cols.0]) {
        match u.as_str() {
            "mm" => disp_scale = 1.0,
            "m" => disp_scale = 1000.0,
            "disp" | "displacement" | "stroke" | "travel" | "extension" | "" => {}
            other => {
                return Err(at(
                    no,
                    1,
                    format!("unknown displacement unit `{other}`: expected mm or m"),
                ));
            }
        }
    }
    Ok(Header { cols, unit, disp_scale })
}
