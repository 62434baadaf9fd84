//! `glstat`: global energies, a block per output step.
//!
//! Layout (LSTC `l2a.c`, `translate_glstat`): an optional ` dt of cycle N is controlled by ...` line, then
//! `label ....... value` lines (`%14.5E` or `%14d`), starting with ` time.....`; labels include
//! `time step`, `kinetic energy`, `internal energy`, `hourglass energy`, `sliding interface energy`,
//! `external work`, `total energy`, `total energy / initial energy`, `energy ratio w/o eroded energy.`
//! (a single dot), `time per zone cycle.(nanosec)`, `stonewall energy ... wall# N` (the trailing text
//! becomes part of the key). A two-line label (`number of shell elements that` / `reached the minimum
//! time step..`) and an optional mass-properties block (`m a s s   p r o p e r t i e s` up to a line of
//! asterisks) are skipped. A new step begins at each `time` label. Keys are the label with runs of
//! white space collapsed, without the dot leader.

use super::text::{body, err, parse_number, read_text, squash_eq, squash_starts_with};
use crate::error::InputError;
use regex::Regex;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::LazyLock;

#[derive(Debug, Clone, PartialEq)]
pub struct GlstatStep {
    /// From the ` dt of cycle N` line before the step, if any.
    pub cycle: Option<u64>,
    pub time: f64,
    pub values: BTreeMap<String, f64>,
    /// The line of the step's ` time....` label.
    pub line: usize,
    /// The line of each label, by key (what the completeness check names).
    pub lines: BTreeMap<String, usize>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Glstat {
    pub title: String,
    pub steps: Vec<GlstatStep>,
}

impl Glstat {
    pub fn time(&self) -> Vec<f64> {
        self.steps.iter().map(|s| s.time).collect()
    }
    /// The history of one label, if every step has it.
    pub fn series(&self, label: &str) -> Option<Vec<f64>> {
        self.steps.iter().map(|s| s.values.get(label).copied()).collect()
    }
    pub fn kinetic_energy(&self) -> Option<Vec<f64>> {
        self.series("kinetic energy")
    }
    pub fn internal_energy(&self) -> Option<Vec<f64>> {
        self.series("internal energy")
    }
}

static LABEL_VALUE: LazyLock<Regex> = LazyLock::new(|| {
    let num = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][-+]?\d+|[-+]\d{3})?|[-+]?(?i:nan|infinity|inf)|\*+";
    Regex::new(&format!(r"^\s*(\S.*?)\s*(?:\.+|=)\s*({num})(?:\s+(.*?))?\s*$")).expect("valid regex")
});
static DT_CYCLE: LazyLock<Regex> = LazyLock::new(|| Regex::new(r"^\s*dt of cycle\s*(\d+)").expect("valid regex"));

pub fn read(file: &Path) -> Result<Glstat, InputError> {
    parse(file, &read_text(file)?)
}

pub fn parse(file: &Path, text: &str) -> Result<Glstat, InputError> {
    let b = body(file, text, "glstat")?;
    let mut out = Glstat {
        title: b.title.to_string(),
        steps: Vec::new(),
    };
    let mut pending_cycle: Option<u64> = None;
    let mut in_mass_props = false;
    for &(no, line) in &b.lines {
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        let fail = |message: String| err(file, text, no, message);
        if in_mass_props {
            if trimmed.starts_with("****") {
                in_mass_props = false;
            }
            continue;
        }
        if squash_starts_with(line, "masspropertiesofbody") {
            in_mass_props = true;
            continue;
        }
        // The regex only where it can match: most lines are `label ..... value`.
        if let Some(c) = trimmed
            .starts_with("dt of cycle")
            .then(|| DT_CYCLE.captures(line))
            .flatten()
        {
            pending_cycle = c[1].parse().ok();
            continue;
        }
        if squash_eq(line, "numberofshellelementsthat") {
            continue;
        }
        let Some(c) = LABEL_VALUE.captures(line) else {
            return Err(fail(
                "expected a `label ....... value` line (or ` dt of cycle N ...`)".into(),
            ));
        };
        let label = c[1].split_whitespace().collect::<Vec<_>>().join(" ");
        let value = parse_number(&c[2]).ok_or_else(|| fail("expected a number after the label".into()))?;
        let key = match c
            .get(3)
            .map(|m| m.as_str().split_whitespace().collect::<Vec<_>>().join(" "))
        {
            Some(rest) if !rest.is_empty() => format!("{label} {rest}"),
            _ => label,
        };
        if key == "time" {
            out.steps.push(GlstatStep {
                cycle: pending_cycle.take(),
                time: value,
                values: BTreeMap::new(),
                line: no,
                lines: BTreeMap::new(),
            });
            continue;
        }
        let Some(step) = out.steps.last_mut() else {
            return Err(fail(format!("`{key}` before the first ` time....` line of a step")));
        };
        step.lines.insert(key.clone(), no);
        if step.values.insert(key.clone(), value).is_some() {
            return Err(fail(format!("`{key}` appears twice in one step")));
        }
    }
    Ok(out)
}
