//! Average crush force = absorbed energy / stroke over a stroke window, plus peak force and energy.
//!
//! Both sources give a [`ForceDisplacement`] curve (displacement in mm, force in kN, compression
//! positive):
//! - a simulation: a contact force history (`rcforc`, one interface side and axis) and the striker's
//!   displacement history (`nodout`, one node and axis), put on common times (the union of both time grids
//!   inside their overlap, each interpolated linearly) — [`from_histories`], [`from_lsdyna`];
//! - a test machine's CSV of displacement and force — [`read_test_csv`], [`parse_test_csv`].
//!
//! Sign convention: the curve's force and displacement are `sign × component`. With [`Sign::Auto`]
//! the displacement sign makes the stroke end positive (last − first ≥ 0) and the force sign makes the
//! absorbed energy over the whole record non-negative; give [`Sign::Plus`] / [`Sign::Minus`] to fix
//! it (e.g. a striker moving along −z: displacement `Minus`).
//!
//! [`crush_force`]: energy = ∫ F dd by the trapezoidal rule along the curve from the first point where the
//! stroke reaches `s0` to the first point after it where it reaches `s1` (both ends interpolated
//! linearly; rebound segments count with their sign); mean = energy / (s1 − s0). Units: mm × kN = J.

use super::lsdyna::{nodout::Nodout, rcforc::Rcforc, rcforc::Side};
pub use crate::base::curve::{CsvOptions, ForceDisplacement, ForceUnit, data_lines, parse_test_csv, read_test_csv};
use crate::error::InputError;
pub use crate::study::settings::{Sign, SimSource, Window};
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrushResult {
    /// Energy / stroke over the window, kN.
    pub mean_force: f64,
    /// Absorbed energy over the window, J (kN·mm).
    pub energy: f64,
    /// s1 − s0, mm.
    pub stroke: f64,
    /// Largest force inside the window (ends included), kN, and the stroke where it occurs.
    pub peak_force: f64,
    pub peak_at: f64,
}

/// Why a curve cannot be built or evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CrushError {
    #[error("{0}")]
    Input(#[from] InputError),
    #[error("{what}: {message}")]
    Data { what: String, message: String },
}

/// A curve problem with `what` (a history, the settings, the stroke window).
pub(crate) fn data(what: &str, message: impl Into<String>) -> CrushError {
    CrushError::Data {
        what: what.to_string(),
        message: message.into(),
    }
}

fn check_series(what: &str, t: &[f64], v: &[f64]) -> Result<(), CrushError> {
    if t.len() != v.len() {
        return Err(data(what, format!("{} times but {} values", t.len(), v.len())));
    }
    if t.len() < 2 {
        return Err(data(what, "needs at least two samples"));
    }
    if let Some(i) = t.iter().chain(v).position(|x| !x.is_finite()) {
        return Err(data(what, format!("non-finite value (sample {})", i % t.len() + 1)));
    }
    if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(data(
            what,
            format!(
                "time must increase strictly; sample {} is at {} after {}",
                i + 2,
                t[i + 1],
                t[i]
            ),
        ));
    }
    Ok(())
}

/// Linear interpolation of (t, v) at `x` (t strictly increasing, x inside [t0, tn]).
fn interp(t: &[f64], v: &[f64], x: f64) -> f64 {
    let j = t.partition_point(|&ti| ti < x);
    if j == 0 {
        return v[0];
    }
    if j >= t.len() {
        return v[t.len() - 1];
    }
    if t[j] == x {
        return v[j];
    }
    let f = (x - t[j - 1]) / (t[j] - t[j - 1]);
    v[j - 1] + f * (v[j] - v[j - 1])
}

/// Put a force history and a displacement history on common times and pair them.
/// Common times: the union of both grids inside the overlap of the two time ranges.
pub fn from_histories(
    force_time: &[f64],
    force: &[f64],
    disp_time: &[f64],
    disp: &[f64],
    force_sign: Sign,
    disp_sign: Sign,
) -> Result<ForceDisplacement, CrushError> {
    check_series("force history", force_time, force)?;
    check_series("displacement history", disp_time, disp)?;
    let lo = force_time[0].max(disp_time[0]);
    let hi = force_time[force_time.len() - 1].min(disp_time[disp_time.len() - 1]);
    if hi <= lo {
        return Err(data(
            "histories",
            format!("force and displacement times do not overlap ({lo} .. {hi})"),
        ));
    }
    let mut times: Vec<f64> = force_time
        .iter()
        .chain(disp_time)
        .copied()
        .filter(|&t| t >= lo && t <= hi)
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let mut d: Vec<f64> = times.iter().map(|&t| interp(disp_time, disp, t)).collect();
    let mut f: Vec<f64> = times.iter().map(|&t| interp(force_time, force, t)).collect();
    apply_signs(&mut d, &mut f, force_sign, disp_sign);
    Ok(ForceDisplacement {
        displacement: d,
        force: f,
    })
}

fn apply_signs(d: &mut [f64], f: &mut [f64], force_sign: Sign, disp_sign: Sign) {
    let ds = factor(disp_sign, || d[d.len() - 1] - d[0] >= 0.0);
    d.iter_mut().for_each(|x| *x *= ds);
    let fs = factor(force_sign, || trapezoid(d, f) >= 0.0);
    f.iter_mut().for_each(|x| *x *= fs);
}

/// The factor a sign stands for: with [`Sign::Auto`], 1 when `positive()` holds, else −1.
fn factor(sign: Sign, positive: impl FnOnce() -> bool) -> f64 {
    match sign {
        Sign::Plus => 1.0,
        Sign::Minus => -1.0,
        Sign::Auto if positive() => 1.0,
        Sign::Auto => -1.0,
    }
}

fn trapezoid(d: &[f64], f: &[f64]) -> f64 {
    d.windows(2)
        .zip(f.windows(2))
        .map(|(dd, ff)| 0.5 * (ff[0] + ff[1]) * (dd[1] - dd[0]))
        .sum()
}

/// The curve from parsed rcforc and nodout files.
pub fn from_lsdyna(rcforc: &Rcforc, nodout: &Nodout, src: &SimSource) -> Result<ForceDisplacement, CrushError> {
    let side_name = match src.side {
        Side::SurfA => "SURFA/slave",
        Side::SurfB => "SURFB/master",
    };
    let s = rcforc.interfaces.get(&(src.side, src.interface)).ok_or_else(|| {
        data(
            "rcforc",
            format!("no {side_name} resultants for interface {}", src.interface),
        )
    })?;
    let comp = s
        .component(src.force_axis)
        .ok_or_else(|| data("settings", "force axis must be 0, 1 or 2"))?;
    against_stroke(&s.time, comp, nodout, src)
}

/// A force history (times `time`, solver units) against the striker's nodout displacement, both in
/// the curve's units and signs: what rcforc's and rwforc's curves share.
fn against_stroke(
    time: &[f64],
    force: &[f64],
    nodout: &Nodout,
    src: &SimSource,
) -> Result<ForceDisplacement, CrushError> {
    let n = nodout
        .nodes
        .get(&src.node)
        .ok_or_else(|| data("nodout", format!("no node {}", src.node)))?;
    let disp = n
        .disp
        .get(src.disp_axis)
        .ok_or_else(|| data("settings", "displacement axis must be 0, 1 or 2"))?;
    in_units(time, force, &n.time, disp, src)
}

/// [`from_histories`] of a force and a displacement history in the solver's units, turned into kN
/// and mm by the source's unit factors (which must be positive and finite) and signed as it says.
pub(crate) fn in_units(
    force_time: &[f64],
    force: &[f64],
    disp_time: &[f64],
    disp: &[f64],
    src: &SimSource,
) -> Result<ForceDisplacement, CrushError> {
    if !(src.force_to_kn.is_finite() && src.force_to_kn > 0.0 && src.disp_to_mm.is_finite() && src.disp_to_mm > 0.0) {
        return Err(data("settings", "unit factors must be positive and finite"));
    }
    let f: Vec<f64> = force.iter().map(|v| v * src.force_to_kn).collect();
    let d: Vec<f64> = disp.iter().map(|v| v * src.disp_to_mm).collect();
    from_histories(force_time, &f, disp_time, &d, src.force_sign, src.disp_sign)
}

/// The curve from a rigid wall's normal force (rwforc) and nodout: the wall's force against the
/// striker's displacement, as [`from_lsdyna`] pairs rcforc's.
pub fn from_wall(
    wall: &super::lsdyna::binout::histories::WallSeries,
    nodout: &Nodout,
    src: &SimSource,
) -> Result<ForceDisplacement, CrushError> {
    against_stroke(&wall.time, &wall.normal, nodout, src)
}

/// Mean crush force, energy and peak over the window.
pub fn crush_force(curve: &ForceDisplacement, w: Window) -> Result<CrushResult, CrushError> {
    let (d, f) = (&curve.displacement, &curve.force);
    check_series_pairs(d, f)?;
    if !(w.s0.is_finite() && w.s1.is_finite() && w.s1 > w.s0) {
        return Err(data(
            "stroke window",
            format!("needs finite s0 < s1, got [{}, {}]", w.s0, w.s1),
        ));
    }
    let max_d = d.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if d[0] > w.s0 {
        return Err(data(
            "stroke window",
            format!("the curve starts at {} mm, after s0 = {} mm", d[0], w.s0),
        ));
    }
    let n = d.len();
    // Start: the first point where the stroke reaches s0 (segment i0, fraction g0).
    let (i0, g0) = if d[0] == w.s0 {
        (0, 0.0)
    } else {
        let i = (0..n - 1).find(|&i| d[i] < w.s0 && w.s0 <= d[i + 1]).ok_or_else(|| {
            data(
                "stroke window",
                format!("s0 = {} mm is never reached (max stroke {max_d} mm)", w.s0),
            )
        })?;
        (i, (w.s0 - d[i]) / (d[i + 1] - d[i]))
    };
    // End: the first point after the start where the stroke reaches s1.
    let j = (i0..n - 1)
        .find(|&k| (k == i0 || d[k] < w.s1) && w.s1 <= d[k + 1])
        .ok_or_else(|| {
            data(
                "stroke window",
                format!("s1 = {} mm is never reached (max stroke {max_d} mm)", w.s1),
            )
        })?;
    let h = if j == i0 {
        let start = d[i0] + g0 * (d[i0 + 1] - d[i0]);
        g0 + (1.0 - g0) * (w.s1 - start) / (d[i0 + 1] - start)
    } else {
        (w.s1 - d[j]) / (d[j + 1] - d[j])
    };
    let lerp = |v: &[f64], i: usize, g: f64| if g == 0.0 { v[i] } else { v[i] + g * (v[i + 1] - v[i]) };
    let mut pd = vec![w.s0];
    let mut pf = vec![lerp(f, i0, g0)];
    for k in (i0 + 1)..=j {
        pd.push(d[k]);
        pf.push(f[k]);
    }
    pd.push(w.s1);
    pf.push(lerp(f, j, h));
    let energy = trapezoid(&pd, &pf);
    let stroke = w.s1 - w.s0;
    let (mut peak, mut peak_at) = (f64::NEG_INFINITY, w.s0);
    for (x, y) in pd.iter().zip(&pf) {
        if *y > peak {
            peak = *y;
            peak_at = *x;
        }
    }
    Ok(CrushResult {
        mean_force: energy / stroke,
        energy,
        stroke,
        peak_force: peak,
        peak_at,
    })
}

fn check_series_pairs(d: &[f64], f: &[f64]) -> Result<(), CrushError> {
    if d.len() != f.len() {
        return Err(data(
            "curve",
            format!("{} displacements but {} forces", d.len(), f.len()),
        ));
    }
    if d.len() < 2 {
        return Err(data("curve", "needs at least two points"));
    }
    if d.iter().chain(f).any(|x| !x.is_finite()) {
        return Err(data("curve", "non-finite value"));
    }
    Ok(())
}

/// A run's curve from the first of `dirs` holding `<dir>/<key>/rcforc` or a binout (a run
/// directory, or a recording); `None` when none does or its histories do not parse (the run's
/// response came from the same files, so that means they were removed). A binout is read when
/// there is one and holds the history, as the `lsdyna` adapter reads it then (the deck sends the
/// history there).
pub fn read_run(dirs: &[std::path::PathBuf], key: &str, source: &SimSource) -> Option<ForceDisplacement> {
    use super::lsdyna::binout::{self, histories};
    use super::lsdyna::{nodout, rcforc};
    let has_binout = |d: &Path| d.join(binout::STEM).is_file() || d.join(format!("{}0000", binout::STEM)).is_file();
    let dir = dirs
        .iter()
        .map(|d| d.join(key))
        .find(|d| d.join("rcforc").is_file() || has_binout(d))?;
    let b = if has_binout(&dir) {
        binout::open_dir(&dir).ok().flatten()
    } else {
        None
    };
    let text = |name: &str| std::fs::read_to_string(dir.join(name)).ok();
    if let Some(id) = source.rigid_wall {
        let b = b.as_ref()?;
        let wall = histories::rwforc(b).ok()??.walls.remove(&id)?;
        return from_wall(&wall, &histories::nodout(b).ok()??, source).ok();
    }
    let rc = match b.as_ref().and_then(|b| histories::rcforc(b).ok().flatten()) {
        Some(rc) => rc,
        None => rcforc::parse_interface(Path::new("rcforc"), &text("rcforc")?, source.side, source.interface).ok()?,
    };
    let nod = match b.as_ref().and_then(|b| histories::nodout(b).ok().flatten()) {
        Some(nod) => nod,
        None => nodout::parse(Path::new("nodout"), &text("nodout")?).ok()?,
    };
    from_lsdyna(&rc, &nod, source).ok()
}
