//! The solver adapters: how each solver's finished run is judged (its failure text, whether its
//! outputs are complete, the response and the run's sanity figures), behind the run engine's
//! [`Adapter`] trait: LS-DYNA ([`lsdyna`]), OpenRadioss ([`openradioss`]) and CalculiX
//! ([`calculix`]); the `command` adapter is the run engine's own ([`crate::execute::CommandAdapter`]).
//! [`solver`] makes a study's.

pub mod calculix;
pub mod lsdyna;
pub mod openradioss;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::Error;
use crate::execute::adapter::bad;
use crate::execute::sweep::Solver;
use crate::execute::{Adapter, CommandAdapter, Outcome, ResponseProblem};
use crate::extract::lsdyna::complete::Incomplete;
use crate::extract::lsdyna::controls::{self, Controls};
use crate::study::{Response, SolverSimulation};
pub use lsdyna::LsDynaAdapter;
use openradioss::OpenRadiossAdapter;

/// A study's solver with its adapter, as the run engine takes it.
pub fn solver(sim: &SolverSimulation) -> Result<Solver<'_>, Error> {
    Ok(Solver {
        sim,
        adapter: adapter(sim)?,
    })
}

/// The study's adapter: `command` (response file + regex), `lsdyna` or `openradioss` (crush
/// force) or `calculix`.
pub fn adapter(sim: &SolverSimulation) -> Result<Arc<dyn Adapter>, Error> {
    if let Some(a) = openradioss(sim) {
        return Ok(Arc::new(a));
    }
    Ok(match &sim.response {
        Response::Regex { file, regex } => {
            Arc::new(CommandAdapter::new(file, regex, &[]).map_err(|e| Error::Failed(format!("response regex: {e}")))?)
        }
        Response::CrushForce { window, source } => Arc::new(LsDynaAdapter {
            window: *window,
            source: source.clone(),
            deck: sim.inputs.deck(),
        }),
        Response::Dat(ccx) => Arc::new(ccx.clone()),
    })
}

/// The `openradioss` adapter of a study with `adapter: openradioss` and a crush-force response.
pub fn openradioss(sim: &SolverSimulation) -> Option<OpenRadiossAdapter> {
    let (Some(settings), Response::CrushForce { window, source }) = (&sim.openradioss, &sim.response) else {
        return None;
    };
    Some(OpenRadiossAdapter {
        window: *window,
        source: source.clone(),
        deck: sim.inputs.deck(),
        settings: settings.clone(),
    })
}

/// A run's force–displacement curve, read from the first of `dirs` holding `<dir>/<key>/` with
/// the adapter's histories (rcforc and nodout, or OpenRadioss's T01); `None` when none does or
/// they do not read.
pub fn run_curve(
    sim: &SolverSimulation,
    dirs: &[PathBuf],
    key: &str,
) -> Option<crate::extract::crush::ForceDisplacement> {
    let Response::CrushForce { source, .. } = &sim.response else {
        return None;
    };
    match openradioss(sim) {
        Some(a) => {
            let dir = dirs
                .iter()
                .map(|d| d.join(key))
                .find(|d| d.join(a.time_history()).is_file())?;
            openradioss::read_curve(&dir, &a)
        }
        None => crate::extract::crush::read_run(dirs, key, source),
    }
}

/// What the run's main deck `deck` (relative to the run directory `dir`) asks of its outputs; a
/// deck that is not there is a missing response, saying that its termination time and `needed`.
fn deck_controls(dir: &Path, deck: &Path, needed: &str) -> Result<Controls, Outcome> {
    let path = dir.join(deck);
    if !path.is_file() {
        return Err(bad(
            ResponseProblem::Missing,
            format!(
                "the deck {} is not in the run directory: its termination time and {needed}",
                deck.display()
            ),
        ));
    }
    controls::read(&path).map_err(|e| bad(ResponseProblem::Unparseable, format!("the deck: {e}")))
}

/// A history that is not complete, as the run's outcome.
fn incomplete(i: Incomplete) -> Outcome {
    Outcome::IncompleteOutput {
        file: i.file,
        line: i.line,
        detail: i.detail,
    }
}

/// The file name of `path` (empty when it has none), as outcomes name output files.
fn file_name(path: &Path) -> String {
    path.file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into())
}
