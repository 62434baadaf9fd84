//! Validation of `simulation.solver` and the keys that go with it (`response`, `sampling`,
//! `surrogate`), each error at the offending node. Templates are read and parsed here, so
//! `lab check` reports template syntax errors at the template's file and line.

use std::path::{Component, Path, PathBuf};
use std::time::Duration;

use super::super::schema::{RetriesFile, SamplingFile, SimulationFile, SolverFile};
use super::super::solver::{CopiedFile, Sampling, SamplingMethod, SolverSimulation, SurrogateKind, Template};
use super::super::yaml::Spanned;
use super::Checker;
use crate::error::InputError;
use crate::execute::{Backoff, CommandAdapter, OutcomeClass, RetryPolicy};

/// Adapters named by the contract whose implementation is not in this version.
const LATER_ADAPTERS: [&str; 1] = ["lsdyna"];

/// Outcome classes a retry policy may name, by their study-file names.
const RETRY_CLASSES: [(&str, OutcomeClass); 5] = [
    ("non_zero_exit", OutcomeClass::NonZeroExit),
    ("failure_text", OutcomeClass::FailureText),
    ("bad_response", OutcomeClass::BadResponse),
    ("timeout", OutcomeClass::Timeout),
    ("signal", OutcomeClass::Signal),
];

/// The paper checks each response surface at 5 random points.
const DEFAULT_CHECK_RUNS: usize = 5;

impl Checker<'_> {
    /// `response`, `sampling` and `surrogate` without `solver` are a mistake, not silently ignored.
    pub(super) fn no_solver_keys(&self, sim: &SimulationFile) -> Result<(), InputError> {
        let at = |key: &str, line: usize, column: usize| {
            self.at_position(
                line,
                column,
                format!("`simulation.{key}` goes with `simulation.solver`, which is missing"),
            )
        };
        if let Some(n) = &sim.response {
            let (l, c) = self.key_position("response", n);
            return Err(at("response", l, c));
        }
        if let Some(n) = &sim.sampling {
            let (l, c) = self.key_position("sampling", n);
            return Err(at("sampling", l, c));
        }
        if let Some(n) = &sim.surrogate {
            let (l, c) = self.key_position("surrogate", n);
            return Err(at("surrogate", l, c));
        }
        Ok(())
    }

    pub(super) fn solver(
        &self,
        node: &Spanned<SimulationFile>,
        solver: &Spanned<SolverFile>,
        n_parameters: usize,
    ) -> Result<SolverSimulation, InputError> {
        let sim = &node.value;
        let spec = &solver.value;
        let adapter = self.adapter(&spec.adapter)?;
        let mut outputs: Vec<PathBuf> = Vec::new();
        let templates = spec.templates.iter().map(|t| self.template(t, &mut outputs)).collect::<Result<Vec<_>, _>>()?;
        let files = spec.files.iter().map(|f| self.copied(f, &mut outputs)).collect::<Result<Vec<_>, _>>()?;
        let timeout = spec.timeout.as_ref().map(|t| self.seconds(t, "solver.timeout", false)).transpose()?;
        let retry = spec.retries.as_ref().map(|r| self.retries(r)).transpose()?.unwrap_or_default();
        let Some(response) = &sim.response else {
            return Err(self.at_key(
                "solver",
                solver,
                "a solver simulation needs `simulation.response: {file, regex}`",
            ));
        };
        // `calculix`, `job`, `response.dat`, `slurm`: see load_cluster.rs.
        let cluster = self.cluster_keys(&adapter, solver, response, &outputs)?;
        let command = match (&spec.command, &cluster.calculix) {
            (Some(command), _) => self.command(command)?,
            (None, Some(ccx)) => ccx.argv(),
            (None, None) => {
                return Err(self.at_key(
                    "solver",
                    solver,
                    "`solver.command` is missing: give the program and its arguments, e.g. [python3, beam.py]",
                ));
            }
        };
        let (response_file, response_regex) = match &cluster.calculix {
            Some(ccx) => (ccx.dat_file(), String::new()),
            None => {
                let (Some(file), Some(regex)) = (&response.value.file, &response.value.regex) else {
                    return Err(self.at_key(
                        "response",
                        response,
                        "`simulation.response` needs `file` and `regex` (the first capture group is the response)",
                    ));
                };
                let response_file = self.relative_path(file, "response.file")?;
                CommandAdapter::new(&response_file, &regex.value, &[])
                    .map_err(|e| self.at(regex, format!("response regex: {e}")))?;
                (response_file, regex.value.clone())
            }
        };
        let surrogate = match &sim.surrogate {
            None => SurrogateKind::Linear,
            Some(s) => SurrogateKind::from_key(&s.value).ok_or_else(|| {
                self.at(s, format!("unknown surrogate `{}`: choose from linear, quadratic, gp", s.value))
            })?,
        };
        let Some(sampling) = &sim.sampling else {
            return Err(self.at_key(
                "solver",
                solver,
                "a solver simulation needs `simulation.sampling`, e.g. `{method: lhs, count: 12, seed: 1}`",
            ));
        };
        let sampling = self.sampling(sampling, surrogate, n_parameters)?;
        Ok(SolverSimulation {
            adapter,
            templates,
            files,
            command,
            timeout,
            retry,
            response_file,
            response_regex,
            sampling,
            surrogate,
            calculix: cluster.calculix,
            slurm: cluster.slurm,
        })
    }

    fn adapter(&self, node: &Spanned<String>) -> Result<String, InputError> {
        match node.value.as_str() {
            "command" | "calculix" => Ok(node.value.clone()),
            name if LATER_ADAPTERS.contains(&name) => Err(self.at(
                node,
                format!("adapter `{name}` is not available yet in this version of lab; use `adapter: command`"),
            )),
            name => Err(self.at(node, format!("unknown adapter `{name}`: choose from command, lsdyna, calculix"))),
        }
    }

    fn command(&self, node: &Spanned<Vec<Spanned<String>>>) -> Result<Vec<String>, InputError> {
        let Some(program) = node.value.first() else {
            return Err(
                self.at(node, "empty `solver.command`: give the program and its arguments, e.g. [ccx, -i, job]")
            );
        };
        if program.value.trim().is_empty() {
            return Err(self.at(program, "the solver's program name is empty"));
        }
        Ok(node.value.iter().map(|a| a.value.clone()).collect())
    }

    /// A file named in the study, resolved against the study's directory; it must exist.
    fn referenced_file(&self, node: &Spanned<String>, what: &str) -> Result<PathBuf, InputError> {
        let path = self.path.parent().unwrap_or(Path::new("")).join(&node.value);
        if !path.is_file() {
            let why = if path.exists() { "is not a file" } else { "does not exist" };
            return Err(self.at(
                node,
                format!(
                    "{what} `{}` {why} (looked for {}; paths are relative to the study file)",
                    node.value,
                    path.display()
                ),
            ));
        }
        Ok(path)
    }

    /// The name a template or copied file gets in the run directory; each name once.
    fn output_name(
        &self,
        node: &Spanned<String>,
        file: &Path,
        outputs: &mut Vec<PathBuf>,
    ) -> Result<PathBuf, InputError> {
        let name = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let output = PathBuf::from(name.strip_suffix(".tera").unwrap_or(&name));
        if output.as_os_str().is_empty() {
            return Err(self.at(node, format!("`{}` leaves no file name in the run directory", node.value)));
        }
        if outputs.contains(&output) {
            return Err(self
                .at(node, format!("two inputs would both be written to `{}` in the run directory", output.display())));
        }
        outputs.push(output.clone());
        Ok(output)
    }

    fn template(&self, node: &Spanned<String>, outputs: &mut Vec<PathBuf>) -> Result<Template, InputError> {
        let file = self.referenced_file(node, "template")?;
        let output = self.output_name(node, &file, outputs)?;
        let source = std::fs::read_to_string(&file)
            .map_err(|e| self.at(node, format!("cannot read template {}: {e}", file.display())))?;
        let template = Template { file, output, source };
        crate::render::Renderer::new(std::slice::from_ref(&template))?;
        Ok(template)
    }

    fn copied(&self, node: &Spanned<String>, outputs: &mut Vec<PathBuf>) -> Result<CopiedFile, InputError> {
        let file = self.referenced_file(node, "file")?;
        let output = self.output_name(node, &file, outputs)?;
        let bytes = std::fs::read(&file).map_err(|e| self.at(node, format!("cannot read {}: {e}", file.display())))?;
        Ok(CopiedFile { file, output, bytes })
    }

    pub(super) fn relative_path(&self, node: &Spanned<String>, key: &str) -> Result<PathBuf, InputError> {
        let path = PathBuf::from(&node.value);
        let inside = path.components().all(|c| matches!(c, Component::Normal(_)));
        if node.value.is_empty() || !inside {
            return Err(self.at(node, format!("`{key}` must be a relative path inside the run directory")));
        }
        Ok(path)
    }

    fn seconds(&self, node: &Spanned<f64>, key: &str, zero_ok: bool) -> Result<Duration, InputError> {
        let v = node.value;
        let ok = v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0)) && v < 1e9;
        if !ok {
            let want = if zero_ok { "zero or more" } else { "more than zero" };
            return Err(self.at(node, format!("`{key}` must be a number of seconds, {want}, not {v}")));
        }
        Ok(Duration::from_secs_f64(v))
    }

    fn retries(&self, node: &Spanned<RetriesFile>) -> Result<RetryPolicy, InputError> {
        let spec = &node.value;
        if spec.max_attempts.value < 1 {
            return Err(self.at(&spec.max_attempts, "`retries.max_attempts` counts the first attempt: at least 1"));
        }
        let initial = spec.backoff.as_ref().map(|b| self.seconds(b, "retries.backoff", true)).transpose()?;
        let max = spec.max_backoff.as_ref().map(|b| self.seconds(b, "retries.max_backoff", true)).transpose()?;
        let initial = initial.unwrap_or(Duration::ZERO);
        let max = max.unwrap_or(Duration::from_secs(60)).max(initial);
        let retry_on = match &spec.on {
            None => vec![OutcomeClass::NonZeroExit, OutcomeClass::Timeout, OutcomeClass::Signal],
            Some(names) => names.iter().map(|n| self.outcome_class(n)).collect::<Result<_, _>>()?,
        };
        Ok(RetryPolicy {
            max_attempts: spec.max_attempts.value,
            retry_on,
            backoff: Backoff::Exponential { initial, max },
        })
    }

    fn outcome_class(&self, node: &Spanned<String>) -> Result<OutcomeClass, InputError> {
        RETRY_CLASSES.iter().find(|(name, _)| *name == node.value).map(|(_, c)| *c).ok_or_else(|| {
            let names: Vec<&str> = RETRY_CLASSES.iter().map(|(n, _)| *n).collect();
            self.at(node, format!("unknown outcome class `{}`: choose from {}", node.value, names.join(", ")))
        })
    }

    fn sampling(
        &self,
        node: &Spanned<SamplingFile>,
        surrogate: SurrogateKind,
        p: usize,
    ) -> Result<Sampling, InputError> {
        let spec = &node.value;
        let method = match spec.method.value.as_str() {
            "lhs" => SamplingMethod::Lhs,
            "grid" => SamplingMethod::Grid,
            other => {
                return Err(self.at(&spec.method, format!("unknown sampling method `{other}`: choose lhs or grid")));
            }
        };
        let count = spec.count.value;
        let needed = surrogate.min_samples(p);
        if count < needed {
            return Err(self.at(
                &spec.count,
                format!(
                    "{count} samples per design are too few for a {} surrogate over {p} parameter(s): it needs at \
                     least {needed}",
                    surrogate.key()
                ),
            ));
        }
        if method == SamplingMethod::Grid && Sampling::grid_side(count, p).is_none() {
            return Err(self.at(
                &spec.count,
                format!("a grid over {p} parameters needs a count that is a {p}-th power (points per axis ^ {p})"),
            ));
        }
        let check_runs = spec.check_runs.as_ref().map_or(DEFAULT_CHECK_RUNS, |c| c.value);
        Ok(Sampling { method, count, seed: spec.seed, check_runs })
    }
}
