//! Validation of `adapter: openradioss` and `solver.openradioss` (programs, threads, nodal noise,
//! environment), each error at the offending node. The starter's argv becomes the study's
//! `command` (what is looked up on PATH and kept in recordings); the engine's is the adapter's.

use super::super::schema::{OpenRadiossFile, SolverFile};
use super::super::solver::OpenRadiossSettings;
use super::super::yaml::Spanned;
use super::Checker;
use crate::error::InputError;

/// The programs of the build in `../shared/tools/openradioss` (linux64_gf).
const STARTER: &str = "starter_linux64_gf";
const ENGINE: &str = "engine_linux64_gf";

impl Checker<'_> {
    /// `solver.openradioss`, only with `adapter: openradioss`; defaults when absent.
    pub(super) fn openradioss(
        &self,
        adapter: &str,
        solver: &Spanned<SolverFile>,
    ) -> Result<Option<OpenRadiossSettings>, InputError> {
        let spec = &solver.value;
        if adapter != "openradioss" {
            return match &spec.openradioss {
                Some(o) => Err(self.at(o, "`solver.openradioss` goes with `adapter: openradioss`")),
                None => Ok(None),
            };
        }
        if let Some(c) = &spec.command {
            return Err(self.at(
                c,
                "`adapter: openradioss` runs its starter then its engine: name them in `solver.openradioss: {starter, engine}`, not `command`",
            ));
        }
        // Without `solver.openradioss`, the settings of an empty one: every default.
        let o = spec.openradioss.as_ref().map(|node| &node.value);
        self.openradioss_settings(o.unwrap_or(&OpenRadiossFile::default()))
            .map(Some)
    }

    fn openradioss_settings(&self, o: &OpenRadiossFile) -> Result<OpenRadiossSettings, InputError> {
        let program = |p: &Option<Spanned<String>>, default: &str| -> Result<String, InputError> {
            match p {
                None => Ok(default.to_string()),
                Some(p) if p.value.trim().is_empty() => Err(self.at(p, "the program name is empty")),
                Some(p) => Ok(p.value.clone()),
            }
        };
        let threads = match &o.threads {
            None => 1,
            Some(t) if t.value >= 1 => t.value,
            Some(t) => Err(self.at(t, "`openradioss.threads` must be 1 or more"))?,
        };
        let noise = match &o.noise {
            None => None,
            Some(n) => {
                let (a, s) = (&n.value.amplitude, &n.value.seed);
                if !(a.value.is_finite() && a.value > 0.0) {
                    return Err(self.at(a, "`noise.amplitude` must be a positive length (mm)"));
                }
                if !(s.value.is_finite() && s.value > 0.0 && s.value <= 1.0) {
                    return Err(self.at(
                        s,
                        "`noise.seed` must be in (0, 1]: the starter ignores other seeds (with a warning)",
                    ));
                }
                Some((a.value, s.value))
            }
        };
        let mut environment = Vec::new();
        for (name, value) in &o.environment {
            let ok = !name.value.is_empty() && name.value.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !ok {
                return Err(self.at(name, format!("`{}` is not an environment variable name", name.value)));
            }
            environment.push((name.value.clone(), value.value.clone()));
        }
        let standin = o
            .standin
            .as_ref()
            .map(|d| self.path.parent().unwrap_or(std::path::Path::new("")).join(&d.value));
        Ok(OpenRadiossSettings {
            starter: program(&o.starter, STARTER)?,
            engine: program(&o.engine, ENGINE)?,
            threads,
            noise,
            environment,
            standin,
        })
    }
}
