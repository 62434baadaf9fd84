//! LS-DYNA-format ASCII output of a crushsim run: `rcforc`, `glstat`, `nodout`, `d3hsp`, `messag`.
//!
//! Each file starts with the deck title and a ` ls-dyna (version ...)  date ...` line whose
//! version text says it is crushsim; formats follow the printf formats in the project's facts
//! (rcforc `  master%11d time%12.5E  x ...`, nodout `%9d` + 12 × `%12.4E`). Dates are fixed, so
//! the same deck gives the same bytes.
//!
//! glstat balances: total energy = kinetic + internal + hourglass + sliding interface energy, and
//! equals the initial total energy plus the external work (the work of the prescribed motion).
//! [`Faults`] (from the test switch) make the histories incomplete or the energies unsound, each
//! in one way, so the checks that catch them can be tested.

use std::fmt::Write;

use super::model::Model;
use super::physics::{History, Step};

/// The fixed date written everywhere (outputs must not depend on the wall clock).
pub const DATE: &str = "01/01/2026";
pub const TIME: &str = "00:00:00";
pub const VERSION: &str = concat!("crushsim ", env!("CARGO_PKG_VERSION"), " stand-in, not LS-DYNA");

/// The banner line every file starts with after its title.
pub fn version_line() -> String {
    format!(" ls-dyna (version {VERSION})  date {DATE}")
}

pub fn normal_termination() -> String {
    format!(" N o r m a l    t e r m i n a t i o n                              {DATE} {TIME}")
}

pub fn error_termination() -> String {
    format!(" E r r o r    t e r m i n a t i o n                                {DATE} {TIME}")
}

/// Fortran `%w.pE`: `-1.23456E+02`, right-aligned in `w` characters.
pub fn e(value: f64, w: usize, p: usize) -> String {
    let v = if value == 0.0 { 0.0 } else { value }; // no "-0.00000E+00"
    let s = format!("{v:.p$E}");
    let (mant, exp) = s.split_once('E').unwrap_or((&s, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let sign = if exp < 0 { '-' } else { '+' };
    format!("{:>w$}", format!("{mant}E{sign}{:02}", exp.abs()))
}

fn header(m: &Model) -> String {
    format!("{}\n{}\n\n", m.title, version_line())
}

/// Output times for an interval `dt` up to the end time (the end included).
pub fn times(m: &Model, dt: f64) -> Vec<f64> {
    let n = (m.run.end_time / dt + 1e-9).floor() as usize;
    let mut t: Vec<f64> = (0..=n).map(|k| k as f64 * dt).collect();
    if m.run.end_time - t[n] > 1e-9 * m.run.end_time {
        t.push(m.run.end_time);
    }
    t
}

/// Deliberate defects of the outputs (test switches); the default writes sound, complete files.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Faults {
    /// Output number `k` (from 0) is left out of every history: a gap.
    pub skip_output: Option<usize>,
    /// Histories stop at this time (the run still ends "normally").
    pub stop_at: Option<f64>,
    /// rcforc: the master row of the last interface is left out at the middle output.
    pub unpaired: bool,
    /// nodout: the history nodes' rows are left out of the middle block.
    pub missing_node: bool,
    /// glstat: part of the internal energy is hourglass energy instead, at this ratio to what
    /// remains internal (their sum unchanged).
    pub hourglass: f64,
    /// glstat: spurious energy growing to this fraction of the balance at the end time.
    pub energy_drift: f64,
    /// glstat: `added mass` / `percentage increase` lines with this added fraction of the mass.
    pub added_mass: Option<f64>,
}

impl Faults {
    /// The output times a history writes, with their numbers (see [`times`]).
    pub fn times(&self, m: &Model, dt: f64) -> Vec<(usize, f64)> {
        times(m, dt)
            .into_iter()
            .enumerate()
            .filter(|&(k, t)| Some(k) != self.skip_output && self.stop_at.is_none_or(|s| t <= s))
            .collect()
    }

    /// The output number at the middle of the run.
    pub fn middle(m: &Model, dt: f64) -> usize {
        times(m, dt).len() / 2
    }
}

/// Resultant force on each side of each contact at a step (x, y, z), slave then master.
pub(crate) fn contact_forces(m: &Model, k: usize, s: &Step) -> ([f64; 3], [f64; 3]) {
    let c = &m.contacts[k];
    let f = s.force;
    if c.master_part == Some(m.striker.pid) {
        ([0.0, 0.0, -f], [0.0, 0.0, f]) // the tube pushes the striker up (+z)
    } else if c.master_part.is_some() && c.master_part == m.base_pid {
        ([0.0, 0.0, f], [0.0, 0.0, -f]) // the tube pushes the base down
    } else {
        ([0.0; 3], [0.0; 3]) // self-contact: no net resultant
    }
}

pub fn rcforc(m: &Model, h: &History, dt: f64, faults: &Faults) -> String {
    let mut out = header(m);
    out.push_str(" r e s u l t a n t   i n t e r f a c e   f o r c e s\n\n{BEGIN LEGEND\n Entity #        Title\n");
    for (k, c) in m.contacts.iter().enumerate() {
        let _ = writeln!(out, "{:9}     {}", k + 1, c.kind);
    }
    out.push_str("{END LEGEND}\n\n");
    let tube_mass = tube_mass(m);
    let middle = Faults::middle(m, dt);
    for (number, t) in faults.times(m, dt) {
        let s = h.at(t);
        for k in 0..m.contacts.len() {
            let drop_master = faults.unpaired && number == middle && k + 1 == m.contacts.len();
            let (slave, master) = contact_forces(m, k, s);
            let mass = if s.force > 0.0 { tube_mass } else { 0.0 };
            let _ = writeln!(
                out,
                "  slave {:11} time{}  x {}  y {}  z {} mass {}",
                k + 1,
                e(t, 12, 5),
                e(slave[0], 12, 5),
                e(slave[1], 12, 5),
                e(slave[2], 12, 5),
                e(mass, 12, 5)
            );
            if drop_master {
                continue;
            }
            let _ = writeln!(
                out,
                "  master{:11} time{}  x {}  y {}  z {} mass {}",
                k + 1,
                e(t, 12, 5),
                e(master[0], 12, 5),
                e(master[1], 12, 5),
                e(master[2], 12, 5),
                e(0.0, 12, 5)
            );
        }
    }
    out
}

/// The explicit time step LS-DYNA would take on this mesh (Courant, shell sound speed).
pub fn time_step(m: &Model) -> f64 {
    let c = (m.material.e / (m.material.rho * (1.0 - m.material.nu.powi(2)))).sqrt();
    m.run.tssfac * m.mesh.min_edge / c
}

pub fn cycle(m: &Model, t: f64) -> u64 {
    (t / time_step(m)).round() as u64
}

/// The tube's mass (t): what rcforc reports as the mass in contact once the crush force acts.
pub(crate) fn tube_mass(m: &Model) -> f64 {
    m.mesh
        .tube
        .iter()
        .map(|p| p.wall_length * p.thickness * m.mesh.tube_length * m.material.rho)
        .sum()
}

pub fn glstat(m: &Model, h: &History, dt: f64, faults: &Faults) -> String {
    let mut out = header(m);
    for (_, t) in faults.times(m, dt) {
        let rows = glstat_rows(m, h, t, faults);
        let _ = writeln!(
            out,
            "\n dt of cycle {:10} is controlled by shell {:10} of part {:10}\n",
            cycle(m, t),
            1,
            m.mesh.tube.first().map_or(0, |p| p.pid)
        );
        for (label, v) in rows {
            let _ = writeln!(out, " {label:.<31} {}", e(v, 12, 5));
        }
    }
    out
}

/// glstat's labels and values at output time `t` (ASCII labels; binout names follow from them).
pub(crate) fn glstat_rows(m: &Model, h: &History, t: f64, faults: &Faults) -> Vec<(&'static str, f64)> {
    let step = time_step(m);
    let initial = h.steps[0].kinetic;
    let s = h.at(t);
    let internal = s.internal / (1.0 + faults.hourglass);
    let hourglass = s.internal - internal;
    let reference = initial + s.external;
    let sliding = faults.energy_drift * reference * t / m.run.end_time;
    let total = s.kinetic + internal + hourglass + sliding;
    let ratio = if reference > 0.0 { total / reference } else { 1.0 };
    let mut rows: Vec<(&str, f64)> = vec![
        ("time", t),
        ("time step", step),
        ("kinetic energy", s.kinetic),
        ("internal energy", internal),
        ("spring and damper energy", 0.0),
        ("hourglass energy", hourglass),
        ("system damping energy", 0.0),
        ("sliding interface energy", sliding),
        ("external work", s.external),
        ("eroded kinetic energy", 0.0),
        ("eroded internal energy", 0.0),
        ("total energy", total),
        ("total energy / initial energy", ratio),
        ("energy ratio w/o eroded energy", ratio),
        ("global x velocity", 0.0),
        ("global y velocity", 0.0),
        ("global z velocity", -s.speed),
        ("time per zone cycle.(nanosec)", 0.0),
    ];
    if let Some(added) = faults.added_mass {
        rows.push(("added mass", added * model_mass(m)));
        rows.push(("percentage increase", 100.0 * added));
    }
    rows
}

/// The tube's and the striker's mass, t.
fn model_mass(m: &Model) -> f64 {
    let tube: f64 = m
        .mesh
        .tube
        .iter()
        .map(|p| p.wall_length * p.thickness * m.mesh.tube_length * m.material.rho)
        .sum();
    tube + m.striker.mass
}

pub fn nodout(m: &Model, h: &History, dt: f64, faults: &Faults) -> String {
    let mut out = header(m);
    let middle = Faults::middle(m, dt);
    for (number, t) in faults.times(m, dt) {
        let s = h.at(t);
        let _ = writeln!(
            out,
            "\n n o d a l   p r i n t   o u t   f o r   t i m e  s t e p{:8}                              ( at time {} )\n",
            cycle(m, t),
            e(t, 12, 7).trim()
        );
        out.push_str(" nodal point  x-disp     y-disp      z-disp      x-vel       y-vel       z-vel      x-accl      y-accl      z-accl      x-coor      y-coor      z-coor\n");
        let rows = if faults.missing_node && number == middle {
            &[][..]
        } else {
            &m.run.history_nodes[..]
        };
        for &(id, xyz) in rows {
            let row = nodout_row(m, s, id, xyz);
            let _ = write!(out, "{id:9}");
            for v in row {
                out.push_str(&e(v, 12, 4));
            }
            out.push('\n');
        }
    }
    out
}

/// A history node's displacement, velocity, acceleration and coordinates (x, y, z each) at step
/// `s`: only the striker's node moves.
pub(crate) fn nodout_row(m: &Model, s: &Step, id: i64, [x, y, z]: [f64; 3]) -> [f64; 12] {
    let moving = Some(id) == m.striker.node;
    let (dz, vz, az) = if moving {
        (-s.crush, -s.speed, -s.accel)
    } else {
        (0.0, 0.0, 0.0)
    };
    [0.0, 0.0, dz, 0.0, 0.0, vz, 0.0, 0.0, az, x, y, z + dz]
}

/// The d3hsp: banner, the stand-in notice, the input as read, the crush model's numbers.
pub fn d3hsp(m: &Model, h: &History, termination: &str) -> String {
    let mut out = header(m);
    out.push_str(&banner());
    out.push_str(&echo(m));
    out.push_str(&theory_echo(m, h));
    let _ = writeln!(out, "\n{termination}");
    out
}

pub fn banner() -> String {
    [
        " ***********************************************************************",
        " *  crushsim: a STAND-IN for LS-DYNA, not LS-DYNA.                      *",
        " *  It reads the keyword deck and writes LS-DYNA-format ASCII output,   *",
        " *  but the force history comes from super-folding-element theory of    *",
        " *  hexagonal honeycomb, not from an explicit finite-element solution.  *",
        " ***********************************************************************",
        "",
    ]
    .join("\n")
        + "\n"
}

fn echo(m: &Model) -> String {
    let mut out = String::from(" p a r a m e t e r s\n");
    for (name, value) in &m.params {
        let _ = writeln!(out, "   {name:<10} {value:?}");
    }
    let mt = &m.material;
    let _ = writeln!(
        out,
        "\n m a t e r i a l   (type 3, id {})\n   density {}\n   young's modulus {}\n   poisson's ratio {}",
        mt.mid,
        e(mt.rho, 12, 5),
        e(mt.e, 12, 5),
        e(mt.nu, 12, 5)
    );
    let _ = writeln!(
        out,
        "   yield stress {}\n   hardening modulus {}\n   beta {}\n   strain rate parameter c {}\n   strain rate parameter p {}",
        e(mt.sigy, 12, 5),
        e(mt.etan, 12, 5),
        e(mt.beta, 12, 5),
        e(mt.src, 12, 5),
        e(mt.srp, 12, 5)
    );
    out.push_str("\n t u b e   p a r t s\n   part  thickness    wall length   shells  title\n");
    for p in &m.mesh.tube {
        let _ = writeln!(
            out,
            "{:7} {} {} {:8}  {}",
            p.pid,
            e(p.thickness, 12, 5),
            e(p.wall_length, 14, 5),
            p.elements,
            p.title
        );
    }
    let s = &m.striker;
    let _ = writeln!(
        out,
        "\n   tube length {}  diameter {}\n   nodes {}  shells {}  smallest edge {}",
        e(m.mesh.tube_length, 12, 5),
        e(m.mesh.tube_diameter, 12, 5),
        m.mesh.nodes,
        m.mesh.elements,
        e(m.mesh.min_edge, 12, 5)
    );
    let motion = if s.prescribed.is_some() { "prescribed" } else { "free" };
    let _ = writeln!(
        out,
        "   striker part {}  mass {}  speed {}  motion {motion}",
        s.pid,
        e(s.mass, 12, 5),
        e(s.speed, 12, 5)
    );
    let _ = writeln!(
        out,
        "   termination time {}  time step {}",
        e(m.run.end_time, 12, 5),
        e(time_step(m), 12, 5)
    );
    for (k, c) in m.contacts.iter().enumerate() {
        let _ = writeln!(
            out,
            "   contact {:3}  {}  ssid {} msid {}  fs {}",
            k + 1,
            c.kind,
            c.ssid,
            c.msid,
            e(c.fs, 10, 3)
        );
    }
    out
}

fn theory_echo(m: &Model, h: &History) -> String {
    let th = &h.theory;
    let v = m.striker.speed;
    let mut out = String::from("\n c r u s h   m o d e l   (super-folding element, Wierzbicki 1983)\n");
    let rows = [
        ("cell side s from the mesh", th.cell_side),
        ("cell size across flats", th.cell_size),
        ("flow stress sigma_0", th.flow_stress),
        ("strain-rate factor at start", th.rate_factor(m, v)),
        ("mean crush force F_m", th.mean_force(m, v)),
        ("initial peak force", th.peak_force(m, v)),
        ("fold half-wavelength H", th.folds.half_wave),
        ("relative density", th.folds.rel_density),
        ("densification strain", th.folds.eps_d),
        ("final crush", h.steps.last().map_or(0.0, |s| s.crush)),
        ("absorbed energy", h.steps.last().map_or(0.0, |s| s.internal)),
    ];
    for (label, value) in rows {
        let _ = writeln!(out, "   {label:.<40} {}", e(value, 12, 5));
    }
    out
}

/// The messag file: the same banner and termination line.
pub fn messag(m: &Model, lines: &[String], termination: &str) -> String {
    let mut out = header(m);
    for l in lines {
        let _ = writeln!(out, "{l}");
    }
    let _ = writeln!(out, "{termination}");
    out
}
