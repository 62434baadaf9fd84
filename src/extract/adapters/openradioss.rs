//! The `openradioss` adapter: OpenRadioss's starter reads the rendered LS-DYNA deck and writes the
//! engine's input, then its engine runs it; the run is judged from both listings and the time
//! history.
//!
//! - **Programs** (argv, no shell; [`OpenRadiossAdapter::starter_argv`] and
//!   [`OpenRadiossAdapter::engine_argv`]): `starter_linux64_gf -i main.k -np 1 -nt N`, then
//!   `engine_linux64_gf -i main_0001.rad -nt N -norst` (the engine writes no restart file; the
//!   starter's, which only the engine reads, is removed after the run). One thread repeats bit for
//!   bit; two do not.
//! - **Failure text**: the starter's listing (`main_0000.out`) counting errors (`N ERROR(S)` with
//!   N > 0, naming the first error), or the engine's listing (`main_0001.out`) saying
//!   `ERROR TERMINATION` or why it stopped early (`RUN STOPPED: ...`, `USER BREAK`: OpenRadioss
//!   then still prints `NORMAL TERMINATION`) → `Outcome::FailureText`.
//! - **Success** needs both listings, the starter's `0 ERROR(S)`, the engine's `NORMAL TERMINATION`,
//!   the time history `mainT01` parsed (crate `radioss-th`) and complete against the deck's
//!   termination time and output interval (the smallest DT of its `*DATABASE_` cards, which is what
//!   the starter makes of them) with the response's interface and node recorded
//!   ([`crate::extract::radioss::history`]).
//! - **Response**: the mean crush force over the stroke window from the interface's force (its
//!   impulse differentiated as `th_to_csv` does) against the history node's displacement.
//! - **Figures**: energy error, added mass, kinetic / internal and hourglass / internal energy,
//!   for the study's gates. **Warnings**: each distinct warning of both listings with its count,
//!   kept in the run's record and shown.
//!
//! Recorded outputs ([`Adapter::outputs`]): both listings, `mainT01` and the starter's
//! `mainT01_TITLES` (the names OpenRadioss's converter gives the T01's columns).

use std::path::{Path, PathBuf};

use super::{deck_controls, incomplete};
use crate::execute::adapter::bad;
use crate::execute::{Adapter, Judged, Outcome, ResponseProblem};
use crate::extract::crush::{self, SimSource, Window};
use crate::extract::lsdyna::complete::Expected;
use crate::extract::radioss::{history, listing};
use crate::study::OpenRadiossSettings;

/// The `openradioss` adapter's settings.
#[derive(Debug, Clone)]
pub struct OpenRadiossAdapter {
    pub window: Window,
    /// Interface (`interface`), history node (`node`), axes and units; `side` is not used (an
    /// OpenRadioss interface records one force).
    pub source: SimSource,
    /// The main deck, relative to the run directory: its stem is the run's root name (`main` for
    /// `main.k`: `main_0000.out`, `main_0001.rad`, `mainT01`).
    pub deck: PathBuf,
    /// Programs, threads (`-nt`), nodal noise (`-rxalea A -rseed S`) and environment.
    pub settings: OpenRadiossSettings,
}

impl OpenRadiossAdapter {
    /// The run's root name: the deck's file name without its extension.
    pub fn root(&self) -> String {
        self.deck
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    fn file(&self, suffix: &str) -> String {
        format!("{}{suffix}", self.root())
    }

    pub fn starter_listing(&self) -> String {
        self.file("_0000.out")
    }

    pub fn engine_listing(&self) -> String {
        self.file("_0001.out")
    }

    pub fn time_history(&self) -> String {
        self.file("T01")
    }

    /// The starter's argv on `deck` ([`OpenRadiossSettings::starter_argv`]).
    pub fn starter_argv(settings: &OpenRadiossSettings, deck: &Path) -> Vec<String> {
        settings.starter_argv(deck)
    }

    /// The engine's argv, on the input the starter wrote.
    pub fn engine_argv(&self) -> Vec<String> {
        vec![
            self.settings.engine.clone(),
            "-i".into(),
            self.file("_0001.rad"),
            "-nt".into(),
            self.settings.threads.to_string(),
            "-norst".into(),
        ]
    }

    /// A listing's text and what it says; `None` when the file is not there.
    fn listing(&self, dir: &Path, name: &str) -> Result<Option<listing::Listing>, Outcome> {
        match std::fs::read(dir.join(name)) {
            Ok(bytes) => Ok(Some(listing::parse(&String::from_utf8_lossy(&bytes)))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(bad(ResponseProblem::Missing, format!("{name}: {e}"))),
        }
    }

    /// The deck's termination time and the T01 interval (the smallest `*DATABASE_` DT).
    fn expected(&self, dir: &Path) -> Result<Expected, Outcome> {
        let c = deck_controls(dir, &self.deck, "output interval are needed to check the time history")?;
        let dt = [c.rcforc, c.nodout, c.glstat]
            .into_iter()
            .flatten()
            .map(|i| i.dt)
            .filter(|d| *d > 0.0)
            .reduce(f64::min);
        Ok(Expected {
            dt,
            end_time: c.end_time,
        })
    }
}

impl Adapter for OpenRadiossAdapter {
    /// What the executor runs after the starter, and the environment of both programs: lab's own,
    /// then the study's `openradioss.environment`, plus `OMP_NUM_THREADS` (the threads) unless the
    /// study sets it and `OMP_STACKSIZE=400m` (OpenRadioss's advice) unless either sets it.
    fn chain(&self) -> crate::execute::Chain {
        let mut env = self.settings.environment.clone();
        let set = |env: &[(String, String)], name: &str| env.iter().any(|(n, _)| n == name);
        if !set(&env, "OMP_NUM_THREADS") {
            env.push(("OMP_NUM_THREADS".into(), self.settings.threads.to_string()));
        }
        if !set(&env, "OMP_STACKSIZE") && std::env::var_os("OMP_STACKSIZE").is_none() {
            env.push(("OMP_STACKSIZE".into(), "400m".into()));
        }
        crate::execute::Chain {
            then: vec![self.engine_argv()],
            env,
            scratch: self.scratch(),
        }
    }

    fn identity(&self) -> String {
        let s = &self.source;
        let parts = (
            [self.window.s0, self.window.s1],
            s.interface,
            s.force_axis,
            format!("{:?}", s.force_sign),
            s.force_to_kn,
            s.node,
            s.disp_axis,
            format!("{:?}", s.disp_sign),
            s.disp_to_mm,
            self.deck.to_string_lossy(),
            self.engine_argv(),
        );
        format!(
            "openradioss/1 crush_force {}",
            serde_json::to_string(&parts).expect("settings serialize")
        )
    }

    fn outputs(&self) -> Vec<PathBuf> {
        [
            self.starter_listing(),
            self.engine_listing(),
            self.time_history(),
            self.file("T01_TITLES"),
        ]
        .into_iter()
        .map(PathBuf::from)
        .collect()
    }

    fn cleared(&self) -> Vec<PathBuf> {
        let mut out = self.outputs();
        out.push(PathBuf::from(self.file("_0001.rad")));
        out.extend(self.scratch());
        out
    }

    fn scratch(&self) -> Vec<PathBuf> {
        vec![PathBuf::from(self.file("_0000_0001.rst"))]
    }

    fn find_failure(&self, dir: &Path) -> Option<Outcome> {
        let failure = |file: String, line: String| Some(Outcome::FailureText { file, line });
        // The listing's first error, as ` (line N: TITLE)`.
        let first = |l: &listing::Listing| {
            l.first_error()
                .map(|m| format!(" (line {}: {})", m.line, m.title))
                .unwrap_or_default()
        };
        if let Ok(Some(s)) = self.listing(dir, &self.starter_listing())
            && let Some(n) = s.error_count.filter(|n| *n > 0)
        {
            return failure(self.starter_listing(), format!("{n} ERROR(S){}", first(&s)));
        }
        let Ok(Some(e)) = self.listing(dir, &self.engine_listing()) else {
            return None;
        };
        if let Some(line) = e.error_termination {
            return failure(
                self.engine_listing(),
                format!("ERROR TERMINATION at line {line}{}", first(&e)),
            );
        }
        e.stopped.map(|(line, why)| Outcome::FailureText {
            file: self.engine_listing(),
            line: format!("the run stopped early at line {line}: {why}"),
        })
    }

    fn extract(&self, dir: &Path) -> Result<f64, Outcome> {
        self.judge(dir).map(|j| j.response)
    }

    fn judge(&self, dir: &Path) -> Result<Judged, Outcome> {
        let missing = |what: String| bad(ResponseProblem::Missing, what);
        let starter = self
            .listing(dir, &self.starter_listing())?
            .ok_or_else(|| missing(format!("the starter wrote no {}", self.starter_listing())))?;
        if starter.error_count != Some(0) {
            return Err(missing(format!(
                "{} does not end with the starter's `0 ERROR(S)`: the starter did not finish",
                self.starter_listing()
            )));
        }
        let engine = self
            .listing(dir, &self.engine_listing())?
            .ok_or_else(|| missing(format!("the engine wrote no {}", self.engine_listing())))?;
        if engine.normal_termination.is_none() {
            return Err(missing(format!("no NORMAL TERMINATION in {}", self.engine_listing())));
        }
        let name = self.time_history();
        let th = radioss_th::read(&dir.join(&name)).map_err(|e| match e {
            radioss_th::Error::Io { .. } => missing(format!("{name}: {e}")),
            radioss_th::Error::Truncated { offset, .. } => Outcome::IncompleteOutput {
                file: name.clone(),
                line: 0,
                detail: format!("{e} (byte {offset})"),
            },
            radioss_th::Error::Format { .. } => bad(ResponseProblem::Unparseable, format!("{name}: {e}")),
        })?;
        history::complete(&th, &name, self.expected(dir)?, &self.source).map_err(incomplete)?;
        let curve = history::curve(&th, &self.source).map_err(|e| bad(ResponseProblem::Unparseable, e.to_string()))?;
        let result =
            crush::crush_force(&curve, self.window).map_err(|e| bad(ResponseProblem::Unparseable, e.to_string()))?;
        if !result.mean_force.is_finite() {
            return Err(bad(ResponseProblem::Unparseable, "the mean crush force is not finite"));
        }
        let mut warnings: Vec<String> = starter
            .warnings()
            .into_iter()
            .map(|w| format!("starter: {w}"))
            .collect();
        warnings.extend(engine.warnings().into_iter().map(|w| format!("engine: {w}")));
        Ok(Judged {
            response: result.mean_force,
            quality: Some(history::figures(&th)),
            warnings,
        })
    }
}

/// The crush curve of a run directory or recording holding the adapter's `mainT01`; `None` when
/// it is not there or does not read.
pub fn read_curve(dir: &Path, adapter: &OpenRadiossAdapter) -> Option<crush::ForceDisplacement> {
    let th = radioss_th::read(&dir.join(adapter.time_history())).ok()?;
    history::curve(&th, &adapter.source).ok()
}
