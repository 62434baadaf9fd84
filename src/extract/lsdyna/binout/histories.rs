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
use crate::extract::lsdyna::nodout::{NodeSeries, Nodout, NodoutBlock};
use crate::extract::lsdyna::rcforc::{ContactSeries, Rcforc, RowAt, Side};

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

/// The most variables a history's steps are read by (nodout: `time`, twelve, `cycle`).
const MOST: usize = 14;

/// The variable names a history's steps are read by (at most [`MOST`]), each looked up once in
/// the database.
struct Names<'n> {
    names: &'n [&'n str],
    /// By name number ([`lsda::NameId::index`]): 1 + the place of the name in `names`, or 0.
    place: Vec<u8>,
}

impl<'n> Names<'n> {
    fn new(b: &Binout, names: &'n [&'n str]) -> Names<'n> {
        assert!(names.len() <= MOST, "at most {MOST} names");
        let mut place = Vec::new();
        for (k, name) in names.iter().enumerate() {
            if let Some(id) = b.db.name_id(name) {
                if place.len() <= id.index() {
                    place.resize(id.index() + 1, 0);
                }
                place[id.index()] = k as u8 + 1;
            }
        }
        Names { names, place }
    }
}

/// The values of one step, read by name.
struct Step<'a, 'n> {
    b: &'a Binout,
    /// The step directory's number in the database.
    id: usize,
    names: &'a Names<'n>,
    /// The variables of the names, read in one pass over the step's variables.
    found: [Option<lsda::Variable<'a>>; MOST],
}

impl<'a, 'n> Step<'a, 'n> {
    fn new(b: &'a Binout, id: usize, names: &'a Names<'n>) -> Step<'a, 'n> {
        let mut found = [None; MOST];
        for (name, v) in b.db.variables_by_id(id) {
            if let Some(&k) = names.place.get(name.index())
                && k > 0
            {
                found[k as usize - 1] = Some(v);
            }
        }
        Step { b, id, names, found }
    }

    fn path(&self) -> &'a str {
        self.b.db.dir_path(self.id).unwrap_or("/")
    }

    /// Variable number `k` of the names.
    fn var(&self, k: usize) -> Option<lsda::Variable<'a>> {
        self.found[k]
    }

    fn get(&self, k: usize, n: usize) -> Result<Vec<f64>, InputError> {
        Ok(self.checked(k, n)?.to_f64())
    }

    /// Variable number `k` of the names, which must hold `n` values.
    fn checked(&self, k: usize, n: usize) -> Result<lsda::Variable<'a>, InputError> {
        let name = self.names.names[k];
        let v = self.var(k).ok_or_else(|| self.missing(name))?;
        if v.len() != n {
            let (file, offset) = v.place();
            return Err(InputError::file(
                file,
                format!(
                    "offset {offset}: {}/{name} has {} value(s), expected {n} (one per entry of the metadata)",
                    self.path(),
                    v.len()
                ),
            ));
        }
        Ok(v)
    }

    fn optional(&self, k: usize, n: usize) -> Result<Option<lsda::Variable<'a>>, InputError> {
        match self.var(k) {
            None => Ok(None),
            Some(_) => self.checked(k, n).map(Some),
        }
    }

    /// The step's time: variable number `k` of the names, one value.
    fn time(&self, k: usize) -> Result<f64, InputError> {
        Ok(self.checked(k, 1)?.f64_at(0))
    }

    fn missing(&self, name: &str) -> InputError {
        let path = self.path();
        let first = self
            .b
            .db
            .variables(path)
            .and_then(|mut v| v.next())
            .map(|(_, v)| v.place().1);
        let at = first.map_or_else(String::new, |o| format!("offset {o}: "));
        InputError::file(&self.b.name, format!("{at}{path}: no `{name}` in this output step"))
    }
}

/// The step directories of `dir` to read (their numbers in the database, in the order of their
/// names): all, except a last step cut short in a cut file.
fn readable_steps(b: &Binout, dir: &str, needs: &[&str]) -> Vec<usize> {
    let Some(d) = b.db.dir_id(dir) else {
        return Vec::new();
    };
    let mut steps: Vec<usize> =
        b.db.subdirs_at(d)
            .into_iter()
            .filter(|(name, _)| super::is_step(name))
            .map(|(_, k)| k)
            .collect();
    let cut = !b.db.notes().is_empty();
    if cut
        && let Some(&last) = steps.last()
        && needs.iter().any(|n| b.db.variable_at(last, n).is_none())
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

/// The distinct keys of `keys` in the order first met, and for each key its number among them.
fn slots<K: Ord + Copy>(keys: &[K]) -> (Vec<K>, Vec<usize>) {
    let mut seen = BTreeMap::new();
    let mut distinct = Vec::new();
    let of = keys
        .iter()
        .map(|key| {
            *seen.entry(*key).or_insert_with(|| {
                distinct.push(*key);
                distinct.len() - 1
            })
        })
        .collect();
    (distinct, of)
}

/// rcforc from the binout; `None` when it has no `/rcforc`.
pub fn rcforc(b: &Binout) -> Result<Option<Rcforc>, InputError> {
    if !b.db.is_dir("/rcforc") {
        return Ok(None);
    }
    // Both read before the name `ids` is taken by the first.
    let (ids, sides) = (ids(b, "/rcforc/metadata/ids")?, ids(b, "/rcforc/metadata/side")?);
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
    let needs = ["time", "x_force", "y_force", "z_force", "mass"];
    let steps = readable_steps(b, "/rcforc", &needs);
    let names = Names::new(
        b,
        &[
            "time", "x_force", "y_force", "z_force", "mass", "x_moment", "y_moment", "z_moment",
        ],
    );
    // Each entry's series (entries of the same side and id share one, as in the map).
    let keys: Vec<(Side, u64)> = (0..n)
        .map(|j| (if sides[j] == 0 { Side::SurfA } else { Side::SurfB }, ids[j]))
        .collect();
    let (slots, slot_of) = slots(&keys);
    let per_slot = |k: usize| steps.len() * slot_of.iter().filter(|&&s| s == k).count();
    let mut series: Vec<ContactSeries> = (0..slots.len())
        .map(|k| {
            let m = per_slot(k);
            ContactSeries {
                time: Vec::with_capacity(m),
                x: Vec::with_capacity(m),
                y: Vec::with_capacity(m),
                z: Vec::with_capacity(m),
                mass: Vec::with_capacity(m),
                moments: None,
            }
        })
        .collect();
    out.rows.reserve(steps.len() * n);
    // Each step's x, y, z force and mass, decoded into the same buffers.
    let mut cols: [Vec<f64>; 4] = Default::default();
    for (k, &step) in steps.iter().enumerate() {
        let s = Step::new(b, step, &names);
        let time = s.time(0)?;
        for (c, col) in cols.iter_mut().enumerate() {
            s.checked(1 + c, n)?.to_f64_into(col);
        }
        let moments = [s.optional(5, n)?, s.optional(6, n)?, s.optional(7, n)?];
        for j in 0..n {
            let (side, id) = keys[j];
            let series = &mut series[slot_of[j]];
            series.time.push(time);
            series.x.push(cols[0][j]);
            series.y.push(cols[1][j]);
            series.z.push(cols[2][j]);
            series.mass.push(cols[3][j]);
            if let [Some(mx), Some(my), Some(mz)] = &moments {
                let m = series.moments.get_or_insert_with(Default::default);
                m[0].push(mx.f64_at(j));
                m[1].push(my.f64_at(j));
                m[2].push(mz.f64_at(j));
            }
            out.rows.push(RowAt {
                line: k + 1,
                side,
                interface: id,
                time,
            });
        }
    }
    if !steps.is_empty() {
        out.interfaces.extend(slots.into_iter().zip(series));
    }
    Ok(Some(out))
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
    let steps = readable_steps(b, "/nodout", &needs);
    let mut with_cycle = needs.clone();
    with_cycle.push("cycle");
    let names = Names::new(b, &with_cycle);
    // Each node's series (a repeated id shares one, as in the map).
    let (slots, slot_of) = slots(&ids);
    let column = |k: usize| Vec::with_capacity(steps.len() * slot_of.iter().filter(|&&s| s == k).count());
    let mut series: Vec<NodeSeries> = (0..slots.len())
        .map(|k| NodeSeries {
            time: column(k),
            disp: [column(k), column(k), column(k)],
            vel: [column(k), column(k), column(k)],
            accl: [column(k), column(k), column(k)],
            coor: [column(k), column(k), column(k)],
        })
        .collect();
    out.steps.reserve(steps.len());
    out.blocks.reserve(steps.len());
    // Each step's twelve columns, decoded into the same buffers.
    let mut cols: [Vec<f64>; 12] = Default::default();
    for (k, &step) in steps.iter().enumerate() {
        let s = Step::new(b, step, &names);
        let time = s.time(0)?;
        let cycle = s.optional(13, 1)?.map_or(0, |c| c.f64_at(0) as u64);
        for (a, col) in cols.iter_mut().enumerate() {
            s.checked(1 + a, n)?.to_f64_into(col);
        }
        out.steps.push((cycle, time));
        out.blocks.push(NodoutBlock {
            line: k + 1,
            time,
            nodes: ids.clone(),
        });
        for j in 0..n {
            let series = &mut series[slot_of[j]];
            series.time.push(time);
            for a in 0..3 {
                series.disp[a].push(cols[a][j]);
                series.vel[a].push(cols[3 + a][j]);
                series.accl[a].push(cols[6 + a][j]);
                series.coor[a].push(cols[9 + a][j]);
            }
        }
    }
    if !steps.is_empty() {
        out.nodes.extend(slots.into_iter().zip(series));
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
    let names = Names::new(b, &["time", "cycle"]);
    for (k, &id) in readable_steps(b, "/glstat", &["time"]).iter().enumerate() {
        let s = Step::new(b, id, &names);
        let path = s.path();
        let mut step = GlstatStep {
            cycle: s.optional(1, 1)?.map(|c| c.f64_at(0) as u64),
            time: s.time(0)?,
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
    let wanted = Names::new(b, &names);
    for (k, &id) in readable_steps(b, dir, &names).iter().enumerate() {
        let s = Step::new(b, id, &wanted);
        let time = s.time(0)?;
        let f: Vec<Vec<f64>> = (1..names.len()).map(|k| s.get(k, n)).collect::<Result<_, _>>()?;
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
