//! Validation of the keys of the cluster and CalculiX issue: `adapter: calculix` with `solver.job`
//! and `simulation.response.dat`, and `solver.slurm` (settings of `--executor slurm`). Kept apart
//! from load_solver.rs so other adapters' keys can grow beside it.

use std::path::PathBuf;

use super::super::schema::{DatFile, ResponseFile, SlurmFile, SolverFile};
use super::super::yaml::Spanned;
use super::Checker;
use crate::error::InputError;
use crate::study::settings::Reduce;
use crate::study::settings::SlurmSettings;
use crate::study::settings::{CalculixAdapter, DatResponse};

/// `.dat` block kinds a response may name.
const DAT_BLOCKS: [&str; 4] = ["displacements", "forces", "total force", "stresses"];

/// What the cluster keys give a solver simulation.
pub(super) struct ClusterSettings {
    pub calculix: Option<CalculixAdapter>,
    pub slurm: Option<SlurmSettings>,
}

impl Checker<'_> {
    pub(super) fn cluster_keys(
        &self,
        adapter: &str,
        solver: &Spanned<SolverFile>,
        response: &Spanned<ResponseFile>,
        inputs: &[PathBuf],
    ) -> Result<ClusterSettings, InputError> {
        let spec = &solver.value;
        let slurm = spec.slurm.as_ref().map(|s| self.slurm(s)).transpose()?;
        if adapter != "calculix" {
            if let Some(job) = &spec.job {
                return Err(self.at(job, "`solver.job` goes with `adapter: calculix`"));
            }
            if let Some(dat) = &response.value.dat {
                return Err(self.at(
                    dat,
                    "`response.dat` goes with `adapter: calculix`; use `file` and `regex`",
                ));
            }
            return Ok(ClusterSettings { calculix: None, slurm });
        }
        for (key, node) in [("file", &response.value.file), ("regex", &response.value.regex)] {
            if let Some(node) = node {
                return Err(self.at(
                    node,
                    format!("`response.{key}` does not go with `adapter: calculix`: the response is `response.dat`"),
                ));
            }
        }
        let Some(dat) = &response.value.dat else {
            return Err(self.at_key(
                "response",
                response,
                "`adapter: calculix` needs `response.dat: {block: displacements, set: NTIP, component: vy, reduce: mean}`",
            ));
        };
        let job = self.job(spec, solver, inputs)?;
        let response = self.dat(dat)?;
        Ok(ClusterSettings {
            calculix: Some(CalculixAdapter::new(job, response)),
            slurm,
        })
    }

    /// `solver.job`, or the stem of the only `.inp` input; `JOB.inp` must be one of the inputs.
    fn job(&self, spec: &SolverFile, solver: &Spanned<SolverFile>, inputs: &[PathBuf]) -> Result<String, InputError> {
        let inps: Vec<&PathBuf> = inputs
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e == "inp"))
            .collect();
        match &spec.job {
            Some(job) => {
                let name = &job.value;
                let ok = !name.is_empty()
                    && name
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
                    && !name.ends_with(".inp");
                if !ok {
                    return Err(self.at(
                        job,
                        "`solver.job` is the input's name without `.inp` (letters, digits, -, _, .)",
                    ));
                }
                if !inputs.iter().any(|p| p == &PathBuf::from(format!("{name}.inp"))) {
                    return Err(self.at(
                        job,
                        format!("no template or file gives `{name}.inp` in the run directory"),
                    ));
                }
                Ok(name.clone())
            }
            None => match inps.as_slice() {
                [one] => Ok(one.file_stem().unwrap_or_default().to_string_lossy().into_owned()),
                _ => Err(self.at_key(
                    "solver",
                    solver,
                    format!(
                        "{} `.inp` input(s): name the main one with `solver.job` (its name without .inp)",
                        inps.len()
                    ),
                )),
            },
        }
    }

    fn dat(&self, node: &Spanned<DatFile>) -> Result<DatResponse, InputError> {
        let d = &node.value;
        let block = d.block.value.trim().to_ascii_lowercase();
        if !DAT_BLOCKS.contains(&block.as_str()) {
            return Err(self.at(
                &d.block,
                format!(
                    "unknown .dat block `{}`: choose from {}",
                    d.block.value,
                    DAT_BLOCKS.join(", ")
                ),
            ));
        }
        let set = d.set.value.trim().to_ascii_uppercase();
        if set.is_empty() || set.contains(char::is_whitespace) {
            return Err(self.at(&d.set, "`dat.set` is the node or element set's name (one word)"));
        }
        let component = d.component.value.trim().to_ascii_lowercase();
        let names: &[&str] = match block.as_str() {
            "displacements" => &["vx", "vy", "vz"],
            "forces" | "total force" => &["fx", "fy", "fz"],
            _ => &["sxx", "syy", "szz", "sxy", "sxz", "syz"],
        };
        if !names.contains(&component.as_str()) {
            return Err(self.at(
                &d.component,
                format!("`{block}` blocks have components {}", names.join(", ")),
            ));
        }
        let reduce = match &d.reduce {
            None if block == "total force" => Reduce::Value,
            None => Reduce::Mean,
            Some(r) => Reduce::from_key(&r.value).ok_or_else(|| {
                self.at(
                    r,
                    format!("unknown reduce `{}`: choose from {}", r.value, Reduce::KEYS.join(", ")),
                )
            })?,
        };
        let window = match &d.window {
            None => None,
            Some(w) => {
                let v: Vec<f64> = w.value.iter().map(|x| x.value).collect();
                if v.len() != 2 || !v.iter().all(|x| x.is_finite()) || v[0] < 0.0 || v[1] <= v[0] {
                    return Err(self.at(
                        w,
                        "`dat.window` must be [t0, t1], step times with 0 <= t0 < t1 (the response is the mean of \
                         the block's history over them)",
                    ));
                }
                Some((v[0], v[1]))
            }
        };
        Ok(DatResponse {
            block,
            set,
            component,
            reduce,
            window,
        })
    }

    fn slurm(&self, node: &Spanned<SlurmFile>) -> Result<SlurmSettings, InputError> {
        let s = &node.value;
        let mut settings = SlurmSettings::default();
        let positive = |n: &Spanned<u32>, key: &str| {
            if n.value == 0 {
                Err(self.at(n, format!("`slurm.{key}` must be at least 1")))
            } else {
                Ok(n.value)
            }
        };
        if let Some(p) = &s.partition {
            if p.value.trim().is_empty() || p.value.contains(char::is_whitespace) {
                return Err(self.at(p, "`slurm.partition` is a partition name (one word)"));
            }
            settings.partition = Some(p.value.clone());
        }
        settings.time_limit_minutes = s.time_limit.as_ref().map(|t| positive(t, "time_limit")).transpose()?;
        if let Some(c) = &s.cpus {
            settings.cpus = positive(c, "cpus")?;
        }
        settings.memory_mb = s.memory.as_ref().map(|m| positive(m, "memory")).transpose()?;
        if let Some(r) = &s.runs_per_job {
            if r.value == 0 {
                return Err(self.at(r, "`slurm.runs_per_job` must be at least 1"));
            }
            settings.runs_per_job = r.value;
        }
        if let Some(l) = &s.lost_after {
            settings.lost_after = std::time::Duration::from_secs(u64::from(positive(l, "lost_after")?));
        }
        for o in &s.options {
            if !o.value.starts_with('-') {
                return Err(self.at(
                    o,
                    "each `slurm.options` item is one sbatch option, e.g. `--account=lab`",
                ));
            }
            settings.options.push(o.value.clone());
        }
        Ok(settings)
    }
}
