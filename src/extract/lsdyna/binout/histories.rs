//! rcforc, nodout and glstat read from a binout into the types the ASCII readers give
//! ([`Rcforc`], [`Nodout`], [`Glstat`]), and rwforc (rigid-wall forces, binout only).
//!
//! The names are LS-DYNA's (as LSTC's `l2a` and lasso-python read them): rcforc `metadata/ids`
//! and `side` (0 slave / SURFA, 1 master / SURFB) and per step `time`, `x_force`, `y_force`,
//! `z_force`, `mass` (optionally `x_moment`, `y_moment`, `z_moment`), one value per entry;
//! nodout `metadata/ids` and per step `x_displacement` … `z_coordinate` per node; glstat one value
//! per step of each energy (`kinetic_energy` is the ASCII file's `kinetic energy`); rwforc
//! `forces/metadata/ids` and per step `normal_force`, `x_force`, `y_force`, `z_force` per wall.
//!
//! Where the ASCII types keep a line number, these keep the step's ordinal (1 for `d000001`),
//! which [`place`] turns into the step's directory and byte offset for messages. A step that
//! lacks a variable is an error naming it, except the last step of a file cut mid-record (a
//! writer stopped inside it): that one is left out, as the file's note says.

use std::collections::BTreeMap;

use super::Binout;
use crate::error::InputError;
use crate::extract::lsdyna::glstat::{Glstat, GlstatStep};
use crate::extract::lsdyna::nodout::{Nodout, NodoutBlock};
use crate::extract::lsdyna::rcforc::{Rcforc, RowAt, Side};

/// The step directory and offset of step `ordinal` (from 1) of history `dir`, for messages.
pub fn place(b: &Binout, dir: &str, ordinal: usize) -> String {
    let steps = b.steps(dir);
    let Some(step) = ordinal.checked_sub(1).and_then(|k| steps.get(k)) else {
        return dir.to_string();
    };
    match b.db.variable_in(step, "time") {
        Some(v) => format!("{step} (offset {})", v.place().1),
        None => step.clone(),
    }
}

/// The values of one step, read by name.
struct Step<'a> {
    b: &'a Binout,
    path: &'a str,
    /// The step directory's number in the database (one lookup of its path).
    id: usize,
}

impl<'a> Step<'a> {
    fn new(b: &'a Binout, path: &'a str) -> Step<'a> {
        let id = b.db.dir_id(path).unwrap_or(usize::MAX);
        Step { b, path, id }
    }

    fn var(&self, name: &str) -> Option<lsda::Variable<'a>> {
        self.b.db.variable_at(self.id, name)
    }

    fn get(&self, name: &str, n: usize) -> Result<Vec<f64>, InputError> {
        Ok(self.checked(name, n)?.to_f64())
    }

    /// Variable `name`, which must hold `n` values.
    fn checked(&self, name: &str, n: usize) -> Result<lsda::Variable<'a>, InputError> {
        let v = self.var(name).ok_or_else(|| self.missing(name))?;
        if v.len() != n {
            let (file, offset) = v.place();
            return Err(InputError::file(
                file,
                format!(
                    "offset {offset}: {}/{name} has {} value(s), expected {n} (one per entry of the metadata)",
                    self.path,
                    v.len()
                ),
            ));
        }
        Ok(v)
    }

    fn optional(&self, name: &str, n: usize) -> Result<Option<Vec<f64>>, InputError> {
        match self.var(name) {
            None => Ok(None),
            Some(_) => self.get(name, n).map(Some),
        }
    }

    fn time(&self) -> Result<f64, InputError> {
        Ok(self.get("time", 1)?[0])
    }

    fn missing(&self, name: &str) -> InputError {
        let first = self
            .b
            .db
            .variables(self.path)
            .and_then(|mut v| v.next())
            .map(|(_, v)| v.place().1);
        let at = first.map_or_else(String::new, |o| format!("offset {o}: "));
        InputError::file(
            &self.b.name,
            format!("{at}{}: no `{name}` in this output step", self.path),
        )
    }
}

/// The steps of `dir` to read: all, except a last step cut short in a cut file.
fn readable_steps(b: &Binout, dir: &str, needs: &[&str]) -> Vec<String> {
    let mut steps = b.steps(dir);
    let cut = !b.db.notes().is_empty();
    if cut
        && let Some(last) = steps.last()
        && needs.iter().any(|n| b.db.variable_in(last, n).is_none())
    {
        steps.pop();
    }
    steps
}

fn title(b: &Binout, dir: &str) -> String {
    b.db.variable(&format!("{dir}/metadata/title"))
        .and_then(|v| v.values().text())
        .map(|t| t.trim_end().to_string())
        .unwrap_or_default()
}

/// Integer ids of a metadata variable (empty when absent).
fn ids(b: &Binout, path: &str) -> Result<Vec<u64>, InputError> {
    let Some(v) = b.db.variable(path) else {
        return Ok(Vec::new());
    };
    let (file, offset) = v.place();
    v.values()
        .to_i64()
        .and_then(|ids| ids.into_iter().map(|i| u64::try_from(i).ok()).collect())
        .ok_or_else(|| {
            InputError::file(
                file,
                format!("offset {offset}: {path}: expected non-negative integer ids"),
            )
        })
}

/// rcforc from the binout; `None` when it has no `/rcforc`.
pub fn rcforc(b: &Binout) -> Result<Option<Rcforc>, InputError> {
    if !b.db.is_dir("/rcforc") {
        return Ok(None);
    }
    let ids = ids(b, "/rcforc/metadata/ids")?;
    let sides = ids_or_empty(b, "/rcforc/metadata/side")?;
    if sides.len() != ids.len() {
        return Err(InputError::file(
            &b.name,
            format!("/rcforc/metadata: {} ids but {} sides", ids.len(), sides.len()),
        ));
    }
    let n = ids.len();
    let mut out = Rcforc {
        title: title(b, "/rcforc"),
        ..Default::default()
    };
    let names = ["time", "x_force", "y_force", "z_force", "mass"];
    for (k, path) in readable_steps(b, "/rcforc", &names).iter().enumerate() {
        let s = Step::new(b, path);
        let time = s.time()?;
        let f: Vec<lsda::Variable> = names[1..]
            .iter()
            .map(|name| s.checked(name, n))
            .collect::<Result<_, _>>()?;
        let moments = ["x_moment", "y_moment", "z_moment"]
            .iter()
            .map(|m| s.optional(m, n))
            .collect::<Result<Vec<_>, _>>()?;
        for j in 0..n {
            let side = if sides[j] == 0 { Side::SurfA } else { Side::SurfB };
            let series = out.interfaces.entry((side, ids[j])).or_default();
            series.time.push(time);
            series.x.push(f[0].f64_at(j));
            series.y.push(f[1].f64_at(j));
            series.z.push(f[2].f64_at(j));
            series.mass.push(f[3].f64_at(j));
            if let [Some(mx), Some(my), Some(mz)] = &moments[..] {
                let m = series.moments.get_or_insert_with(Default::default);
                m[0].push(mx[j]);
                m[1].push(my[j]);
                m[2].push(mz[j]);
            }
            out.rows.push(RowAt {
                line: k + 1,
                side,
                interface: ids[j],
                time,
            });
        }
    }
    Ok(Some(out))
}

fn ids_or_empty(b: &Binout, path: &str) -> Result<Vec<u64>, InputError> {
    ids(b, path)
}

const NODOUT: [&str; 12] = [
    "x_displacement",
    "y_displacement",
    "z_displacement",
    "x_velocity",
    "y_velocity",
    "z_velocity",
    "x_acceleration",
    "y_acceleration",
    "z_acceleration",
    "x_coordinate",
    "y_coordinate",
    "z_coordinate",
];

/// nodout from the binout (translations); `None` when it has no `/nodout`.
pub fn nodout(b: &Binout) -> Result<Option<Nodout>, InputError> {
    if !b.db.is_dir("/nodout") {
        return Ok(None);
    }
    let ids = ids(b, "/nodout/metadata/ids")?;
    let n = ids.len();
    let mut out = Nodout {
        title: title(b, "/nodout"),
        ..Default::default()
    };
    let mut needs = vec!["time"];
    needs.extend(NODOUT);
    for (k, path) in readable_steps(b, "/nodout", &needs).iter().enumerate() {
        let s = Step::new(b, path);
        let time = s.time()?;
        let cycle = s.optional("cycle", 1)?.map_or(0, |c| c[0] as u64);
        let cols: Vec<lsda::Variable> = NODOUT.iter().map(|name| s.checked(name, n)).collect::<Result<_, _>>()?;
        out.steps.push((cycle, time));
        out.blocks.push(NodoutBlock {
            line: k + 1,
            time,
            nodes: ids.clone(),
        });
        for (j, id) in ids.iter().enumerate() {
            let series = out.nodes.entry(*id).or_default();
            series.time.push(time);
            for a in 0..3 {
                series.disp[a].push(cols[a].f64_at(j));
                series.vel[a].push(cols[3 + a].f64_at(j));
                series.accl[a].push(cols[6 + a].f64_at(j));
                series.coor[a].push(cols[9 + a].f64_at(j));
            }
        }
    }
    Ok(Some(out))
}

/// The ASCII glstat label of a binout glstat variable.
pub fn glstat_label(name: &str) -> String {
    match name {
        "energy_ratio" => "total energy / initial energy".into(),
        "energy_ratio_wo_eroded" => "energy ratio w/o eroded energy".into(),
        other => other.replace('_', " "),
    }
}

/// glstat from the binout (every one-value variable of a step, by its ASCII label); `None` when
/// it has no `/glstat`.
pub fn glstat(b: &Binout) -> Result<Option<Glstat>, InputError> {
    if !b.db.is_dir("/glstat") {
        return Ok(None);
    }
    let mut out = Glstat {
        title: title(b, "/glstat"),
        steps: Vec::new(),
    };
    for (k, path) in readable_steps(b, "/glstat", &["time"]).iter().enumerate() {
        let s = Step::new(b, path);
        let mut step = GlstatStep {
            cycle: s.optional("cycle", 1)?.map(|c| c[0] as u64),
            time: s.time()?,
            values: BTreeMap::new(),
            line: k + 1,
            lines: BTreeMap::new(),
        };
        for (name, v) in b.db.variables(path).into_iter().flatten() {
            if name == "time" || name == "cycle" || v.len() != 1 {
                continue;
            }
            let label = glstat_label(name);
            step.lines.insert(label.clone(), k + 1);
            step.values.insert(label, v.to_f64()[0]);
        }
        out.steps.push(step);
    }
    Ok(Some(out))
}

/// One rigid wall's force history.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WallSeries {
    pub time: Vec<f64>,
    pub normal: Vec<f64>,
    /// x, y, z components.
    pub force: [Vec<f64>; 3],
}

/// rwforc's `forces`: the resultant force on each rigid wall over time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rwforc {
    pub title: String,
    pub walls: BTreeMap<u64, WallSeries>,
    /// Each step's ordinal and time, in order (what the completeness check walks).
    pub steps: Vec<(usize, f64)>,
}

/// rwforc (`/rwforc/forces`) from the binout; `None` when it has none.
pub fn rwforc(b: &Binout) -> Result<Option<Rwforc>, InputError> {
    let dir = "/rwforc/forces";
    if !b.db.is_dir(dir) {
        return Ok(None);
    }
    let ids = ids(b, "/rwforc/forces/metadata/ids")?;
    let n = ids.len();
    let mut out = Rwforc {
        title: title(b, dir),
        ..Default::default()
    };
    let names = ["time", "normal_force", "x_force", "y_force", "z_force"];
    for (k, path) in readable_steps(b, dir, &names).iter().enumerate() {
        let s = Step::new(b, path);
        let time = s.time()?;
        let f: Vec<Vec<f64>> = names[1..].iter().map(|name| s.get(name, n)).collect::<Result<_, _>>()?;
        out.steps.push((k + 1, time));
        for (j, id) in ids.iter().enumerate() {
            let w = out.walls.entry(*id).or_default();
            w.time.push(time);
            w.normal.push(f[0][j]);
            for a in 0..3 {
                w.force[a].push(f[1 + a][j]);
            }
        }
    }
    Ok(Some(out))
}
