//! crushsim's binout: the histories a deck sends to binout (`*DATABASE_RCFORC` / `_GLSTAT` /
//! `_NODOUT` with BINARY 2 or 3) written through the `lsda` crate in LS-DYNA's layout, with
//! single-precision reals (R4) as an SMP single-precision LS-DYNA writes them.
//!
//! Layout (what LSTC's `l2a` and lasso-python read): `/rcforc/metadata` (title, version, date,
//! revision, `ids` and `side` of the entries: each contact's slave (0) then master (1)),
//! `/nodout/metadata` (`ids`), `/glstat/metadata`, and one directory `d000001`, `d000002`, … per
//! output step of each history with `time` and its values. The steps of all histories are
//! written in time order with a symbol table after each output time, as LS-DYNA does, so a run
//! killed mid-way leaves a readable file. The values are the ASCII files' own (the same
//! functions of [`super::output`]), at float precision instead of 6 digits; the same faults
//! apply (`gap`, `early`: steps left out; `unpaired`: the last master entry left out of the
//! middle step's arrays; `missnode`: the middle step's node arrays left empty).

use lsda::{Header, Values, Writer};

use super::model::Model;
use super::output::{self, DATE, Faults, VERSION};
use super::physics::History;

/// Which histories go to binout, with their intervals.
#[derive(Debug, Clone, Copy, Default)]
pub struct Wanted {
    pub rcforc: Option<f64>,
    pub glstat: Option<f64>,
    pub nodout: Option<f64>,
}

fn r4(v: &[f64]) -> Values {
    Values::R4(v.iter().map(|&x| x as f32).collect())
}

fn i4(v: &[i64]) -> Values {
    Values::I4(v.iter().map(|&x| x as i32).collect())
}

fn metadata(w: &mut Writer, m: &Model, dir: &str) -> Result<(), lsda::Error> {
    w.cd(&format!("/{dir}/metadata"));
    w.write("title", &Values::from_text(&format!("{:<80}", m.title)))?;
    w.write("version", &Values::from_text(VERSION))?;
    w.write("date", &Values::from_text(DATE))?;
    w.write("revision", &Values::from_text("crushsim  "))
}

/// One history's output to write: which, its step number, the output's number and time.
#[derive(Clone, Copy)]
struct Out {
    kind: u8,
    step: usize,
    number: usize,
    time: f64,
}

/// The binout's bytes (one file) for the histories in `wanted`; `faults(dt)` gives the faults of
/// a history written at interval `dt` (their defaults depend on it, as in the ASCII files).
pub fn binout(m: &Model, h: &History, wanted: Wanted, faults: impl Fn(f64) -> Faults) -> Result<Vec<u8>, lsda::Error> {
    let mut w = Writer::new(Header::default());
    let kinds = [
        (0u8, wanted.rcforc, "rcforc"),
        (1, wanted.glstat, "glstat"),
        (2, wanted.nodout, "nodout"),
    ];
    let mut outs = Vec::new();
    for (kind, dt, name) in kinds {
        let Some(dt) = dt else { continue };
        metadata(&mut w, m, name)?;
        ids(&mut w, m, kind)?;
        let times = faults(dt).times(m, dt);
        outs.extend(times.iter().enumerate().map(|(k, &(number, time))| Out {
            kind,
            step: k + 1,
            number,
            time,
        }));
    }
    w.flush()?;
    outs.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.kind.cmp(&b.kind)));
    let middle = |dt: Option<f64>| dt.map_or(usize::MAX, |dt| Faults::middle(m, dt));
    let of = |dt: Option<f64>| faults(dt.unwrap_or(m.run.end_time));
    for (k, o) in outs.iter().enumerate() {
        match o.kind {
            0 => rcforc_step(
                &mut w,
                m,
                h,
                o,
                of(wanted.rcforc).unpaired && o.number == middle(wanted.rcforc),
            )?,
            1 => glstat_step(&mut w, m, h, o, &of(wanted.glstat))?,
            _ => nodout_step(
                &mut w,
                m,
                h,
                o,
                of(wanted.nodout).missing_node && o.number == middle(wanted.nodout),
            )?,
        }
        if outs.get(k + 1).is_none_or(|next| next.time != o.time) {
            w.flush()?;
        }
    }
    Ok(w.finish()?.remove(0))
}

/// The entries' ids in each history's metadata.
fn ids(w: &mut Writer, m: &Model, kind: u8) -> Result<(), lsda::Error> {
    match kind {
        0 => {
            let n = m.contacts.len() as i64;
            let ids: Vec<i64> = (1..=n).flat_map(|k| [k, k]).collect();
            let side: Vec<i64> = (1..=n).flat_map(|_| [0, 1]).collect();
            w.write("ids", &i4(&ids))?;
            w.write("side", &i4(&side))
        }
        2 => {
            let ids: Vec<i64> = m.run.history_nodes.iter().map(|n| n.0).collect();
            w.write("ids", &i4(&ids))
        }
        _ => Ok(()),
    }
}

fn step_dir(w: &mut Writer, name: &str, o: &Out) -> Result<(), lsda::Error> {
    w.cd(&format!("/{name}/d{:06}", o.step));
    w.write("time", &r4(&[o.time]))
}

fn rcforc_step(w: &mut Writer, m: &Model, h: &History, o: &Out, drop_last_master: bool) -> Result<(), lsda::Error> {
    step_dir(w, "rcforc", o)?;
    let s = h.at(o.time);
    let mass = if s.force > 0.0 { output::tube_mass(m) } else { 0.0 };
    let mut cols: [Vec<f64>; 4] = Default::default();
    for k in 0..m.contacts.len() {
        let (slave, master) = output::contact_forces(m, k, s);
        for (side, f, mass) in [(0, slave, mass), (1, master, 0.0)] {
            if drop_last_master && side == 1 && k + 1 == m.contacts.len() {
                continue;
            }
            for a in 0..3 {
                cols[a].push(f[a]);
            }
            cols[3].push(mass);
        }
    }
    for (name, col) in ["x_force", "y_force", "z_force", "mass"].iter().zip(&cols) {
        w.write(name, &r4(col))?;
    }
    Ok(())
}

/// The binout name of a glstat label (LS-DYNA's: `kinetic_energy`, `energy_ratio`, `nzc`, …).
pub fn glstat_name(label: &str) -> String {
    match label {
        "total energy / initial energy" => "energy_ratio".into(),
        "energy ratio w/o eroded energy" => "energy_ratio_wo_eroded".into(),
        "time per zone cycle.(nanosec)" => "nzc".into(),
        other => other.replace(' ', "_"),
    }
}

fn glstat_step(w: &mut Writer, m: &Model, h: &History, o: &Out, faults: &Faults) -> Result<(), lsda::Error> {
    step_dir(w, "glstat", o)?;
    w.write("cycle", &i4(&[output::cycle(m, o.time) as i64]))?;
    for (label, v) in output::glstat_rows(m, h, o.time, faults) {
        match glstat_name(label).as_str() {
            "time" => {}
            "nzc" => w.write("nzc", &i4(&[v as i64]))?,
            name => w.write(name, &r4(&[v]))?,
        }
    }
    Ok(())
}

fn nodout_step(w: &mut Writer, m: &Model, h: &History, o: &Out, empty: bool) -> Result<(), lsda::Error> {
    step_dir(w, "nodout", o)?;
    w.write("cycle", &i4(&[output::cycle(m, o.time) as i64]))?;
    let s = h.at(o.time);
    let rows: Vec<[f64; 12]> = if empty {
        Vec::new()
    } else {
        m.run
            .history_nodes
            .iter()
            .map(|&(id, xyz)| output::nodout_row(m, s, id, xyz))
            .collect()
    };
    let names = [
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
    for (c, name) in names.iter().enumerate() {
        let col: Vec<f64> = rows.iter().map(|r| r[c]).collect();
        w.write(name, &r4(&col))?;
    }
    Ok(())
}
