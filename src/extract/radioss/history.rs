//! What lab takes from an OpenRadioss time history (T01, read by the `radioss-th` crate): the
//! crush curve, the run's energy figures, and whether the history is complete.
//!
//! - **Curve**: the force of one contact interface (`FNX`/`FNY`/`FNZ`, the component along the
//!   study's axis, differentiated from its stored impulse as OpenRadioss's `th_to_csv` does) against
//!   the displacement of one history node along its axis, both at the T01's output times; signs
//!   and units as for LS-DYNA histories ([`crate::extract::crush`]).
//! - **Figures** (each the worst over the steps whose internal energy is at least
//!   [`SIGNIFICANT_INTERNAL`] of its largest, as for glstat):
//!   the **energy error** (internal + kinetic + rotational kinetic + contact + hourglass energy −
//!   external work) / external work, from the energies at time 0 on; the **added mass ratio**
//!   `ADDED MASS / (MASS − ADDED MASS)` (mass scaling's increase over the model's own mass, like
//!   LS-DYNA's `percentage increase`); the **kinetic ratio** kinetic / internal energy (a
//!   quasi-static crush must keep it small); hourglass / internal energy.
//! - **Complete**: the output times start at 0, step by the deck's smallest `*DATABASE_` interval
//!   and reach its termination time within one interval (the same rule as for LS-DYNA histories,
//!   [`crate::extract::lsdyna::complete::times`]; "line" there is the time step's number); the
//!   interface and the node are recorded.

use radioss_th::TimeHistory;

use crate::extract::crush::{self, CrushError, ForceDisplacement, SimSource, data};
use crate::extract::lsdyna::complete::{self, Expected, Incomplete};
use crate::extract::lsdyna::quality::{Quality, SIGNIFICANT_INTERNAL, worst};

const AXES: [&str; 3] = ["X", "Y", "Z"];

/// The crush curve of `th`: interface `source.interface`'s normal force along `source.force_axis`
/// against node `source.node`'s displacement along `source.disp_axis`.
pub fn curve(th: &TimeHistory, source: &SimSource) -> Result<ForceDisplacement, CrushError> {
    let (Some(f_axis), Some(d_axis)) = (AXES.get(source.force_axis), AXES.get(source.disp_axis)) else {
        return Err(data("settings", "axes must be 0, 1 or 2"));
    };
    let interface = i32::try_from(source.interface).map_err(|_| data("settings", "interface id too large"))?;
    let node = i32::try_from(source.node).map_err(|_| data("settings", "node id too large"))?;
    let force = th.interface_force(interface, &format!("FN{f_axis}")).ok_or_else(|| {
        data(
            "T01",
            format!("no interface {interface} (recorded: {:?})", th.interfaces()),
        )
    })?;
    let disp = th
        .node(node, &format!("D{d_axis}"))
        .ok_or_else(|| data("T01", format!("no history node {node}")))?;
    crush::in_units(&th.times, &force, &th.times, &disp, source)
}

/// The energy figures of `th` (`None` where it does not record what they need).
pub fn figures(th: &TimeHistory) -> Quality {
    let series = |name: &str| th.global(name);
    let internal = series("INTERNAL ENERGY");
    let significant: Vec<bool> = match &internal {
        Some(ie) => {
            let peak = ie.iter().copied().fold(0.0, f64::max);
            ie.iter()
                .map(|v| peak > 0.0 && *v >= SIGNIFICANT_INTERNAL * peak)
                .collect()
        }
        None => Vec::new(),
    };
    let ratio = |num: Option<Vec<f64>>| -> Option<f64> {
        let (num, ie) = (num?, internal.as_ref()?);
        worst(
            num.iter()
                .zip(ie)
                .zip(&significant)
                .filter(|(_, s)| **s)
                .map(|((n, i), _)| n / i),
        )
    };
    Quality {
        hourglass_ratio: ratio(series("HOURGLASS ENERGY")),
        energy_error: energy_error(th),
        added_mass_ratio: added_mass(th),
        kinetic_ratio: ratio(series("KINETIC ENERGY")),
    }
}

/// (energy in the model − external work) / external work, at the steps where the external work is
/// at least [`SIGNIFICANT_INTERNAL`] of its largest (before, the ratio of two small numbers).
fn energy_error(th: &TimeHistory) -> Option<f64> {
    let parts = [
        "INTERNAL ENERGY",
        "KINETIC ENERGY",
        "ROTATION ENERGY",
        "CONTACT ENERGY",
        "HOURGLASS ENERGY",
    ];
    let mut total = vec![0.0; th.times.len()];
    for name in parts {
        for (t, v) in total.iter_mut().zip(th.global(name)?) {
            *t += v;
        }
    }
    let work = th.global("EXTERNAL WORK")?;
    let (e0, w0) = (total[0], work[0]);
    let largest = work.iter().map(|w| (w - w0).abs()).fold(0.0, f64::max);
    worst(total.iter().zip(&work).filter_map(|(e, w)| {
        let input = w - w0;
        (largest > 0.0 && input.abs() >= SIGNIFICANT_INTERNAL * largest).then(|| (e - e0 - input) / input.abs())
    }))
}

fn added_mass(th: &TimeHistory) -> Option<f64> {
    let (added, mass) = (th.global("ADDED MASS")?, th.global("MASS")?);
    worst(
        added
            .iter()
            .zip(&mass)
            .map(|(a, m)| if m - a > 0.0 { a / (m - a) } else { f64::NAN }),
    )
}

/// Whether `th` (the file `file`) is complete against the deck's interval and termination time,
/// and records `source`'s interface and node.
pub fn complete(th: &TimeHistory, file: &str, want: Expected, source: &SimSource) -> Result<(), Incomplete> {
    let points: Vec<(usize, f64)> = th.times.iter().enumerate().map(|(k, t)| (k + 1, *t)).collect();
    complete::times(file, &points, want, th.times.len())?;
    let at = |detail: String| Incomplete {
        file: file.to_string(),
        line: 0,
        detail,
    };
    let interface = i32::try_from(source.interface).unwrap_or(i32::MAX);
    if !th.interfaces().contains(&interface) {
        return Err(at(format!(
            "interface {interface} is not recorded (recorded interfaces: {:?})",
            th.interfaces()
        )));
    }
    if th.node(i32::try_from(source.node).unwrap_or(i32::MAX), "DX").is_none() {
        return Err(at(format!("history node {} is not recorded", source.node)));
    }
    Ok(())
}
