//! Validation of `simulation.solver` and the keys that go with it (`response`, `sampling`,
//! `surrogate`), each error at the offending node. Templates are read and parsed here, so
//! `lab check` reports template syntax errors at the template's file and line.

use std::path::{Component, Path, PathBuf};
use std::time::Duration;

use super::super::schema::{
    DeckSpecFile, MeshFile, ResponseFile, RetriesFile, SamplingFile, SeedsFile, SimulationFile, SolverFile,
};
use super::super::solver::{
    CopiedFile, Execution, MeshSpec, Response, RunInputs, Sampling, SamplingMethod, Seeds, SolverSimulation,
    SurrogateKind, Template,
};
use super::super::yaml::Spanned;
use super::Checker;
use crate::base::deck::Deck;
use crate::error::InputError;
use crate::study::settings::Side;
use crate::study::settings::{Backoff, OutcomeClass, RetryPolicy};
use crate::study::settings::{Sign, SimSource, Window};

/// Outcome classes a retry policy may name, by their study-file names.
const RETRY_CLASSES: [(&str, OutcomeClass); 6] = [
    ("non_zero_exit", OutcomeClass::NonZeroExit),
    ("failure_text", OutcomeClass::FailureText),
    ("bad_response", OutcomeClass::BadResponse),
    ("incomplete_output", OutcomeClass::IncompleteOutput),
    ("timeout", OutcomeClass::Timeout),
    ("signal", OutcomeClass::Signal),
];

/// The paper checks each response surface at 5 random points.
const DEFAULT_CHECK_RUNS: usize = 5;

/// A solver's templates, its copied files, and the names they all get in the run directory.
type Inputs = (Vec<Template>, Vec<CopiedFile>, Vec<PathBuf>);

impl Checker<'_> {
    /// `response`, `sampling` and `surrogate` without `solver` are a mistake, not silently ignored.
    pub(super) fn no_solver_keys(&self, sim: &SimulationFile) -> Result<(), InputError> {
        let given = [
            ("response", sim.response.as_ref().map(Spanned::place)),
            ("sampling", sim.sampling.as_ref().map(Spanned::place)),
            ("surrogate", sim.surrogate.as_ref().map(Spanned::place)),
            ("mesh", sim.mesh.as_ref().map(Spanned::place)),
            ("replay", sim.replay.as_ref().map(Spanned::place)),
            ("quality", sim.quality.as_ref().map(Spanned::place)),
        ];
        match given.into_iter().find_map(|(key, node)| Some((key, node?))) {
            Some((key, node)) => Err(self.at_key(
                key,
                &node,
                format!("`simulation.{key}` goes with `simulation.solver`, which is missing"),
            )),
            None => Ok(()),
        }
    }

    /// `simulation.solver` and the keys that go with it, in the order their errors are reported:
    /// adapter, inputs, command, limits, response (and the cluster keys), surrogate, sampling,
    /// mesh, replay.
    pub(super) fn solver(
        &self,
        node: &Spanned<SimulationFile>,
        solver: &Spanned<SolverFile>,
        (design_names, deck_names): (&[String], &[String]),
        n_parameters: usize,
    ) -> Result<SolverSimulation, InputError> {
        let sim = &node.value;
        let spec = &solver.value;
        let adapter = self.adapter(&spec.adapter)?;
        // `lsdyna` and `openradioss` both run an LS-DYNA deck and read a crush force.
        let lsdyna = adapter == "lsdyna" || adapter == "openradioss";
        let openradioss = self.openradioss(&adapter, solver)?;
        let (templates, files, outputs) = self.inputs(spec)?;
        let deck = spec
            .deck
            .as_ref()
            .map(|d| self.deck(d, &templates, (deck_names, design_names), &outputs))
            .transpose()?;
        let main = match &deck {
            Some(d) => Some(d.files[0].output.clone()),
            None => templates.first().map(|t| t.output.clone()),
        };
        let command = match &openradioss {
            Some(settings) => settings.starter_argv(&self.main_deck(solver, main)?),
            None => self.solver_command(solver, &adapter, main)?,
        };
        let (timeout, retry) = self.limits(spec)?;
        let Some(response) = &sim.response else {
            return Err(self.missing_response(solver, &adapter, lsdyna));
        };
        // `calculix`, `job`, `response.dat`, `slurm`: see load_cluster.rs.
        let cluster = self.cluster_keys(&adapter, solver, response, &outputs)?;
        let command = match &cluster.calculix {
            Some(ccx) if command.is_empty() => ccx.argv(),
            _ => command,
        };
        let response = match cluster.calculix {
            Some(ccx) => Response::Dat(ccx),
            None if lsdyna => self.crush_response(response, &adapter)?,
            None => self.regex_response(response)?,
        };
        let surrogate = self.surrogate_kind(sim)?;
        let Some(sampling) = &sim.sampling else {
            return Err(self.at_key(
                "solver",
                solver,
                "a solver simulation needs `simulation.sampling`, e.g. `{method: lhs, count: 12, seed: 1}`",
            ));
        };
        let sampling = self.sampling(&sampling.value, surrogate, n_parameters)?;
        let nodal_noise = openradioss.as_ref().is_some_and(|o| o.noise.is_some());
        let inputs = self.run_inputs(sim, (templates, deck, files), design_names, (lsdyna, nodal_noise))?;
        let replay = self.replay_dir(sim)?;
        Ok(SolverSimulation {
            adapter,
            inputs,
            execution: Execution {
                command,
                timeout,
                retry,
                slurm: cluster.slurm,
            },
            response,
            sampling,
            surrogate,
            replay,
            quality: sim
                .quality
                .as_ref()
                .map(|q| self.quality(q))
                .transpose()?
                .unwrap_or_default(),
            openradioss,
        })
    }

    /// The solver's templates and copied files, read and checked in that order, with the names
    /// they get in the run directory (each name once).
    fn inputs(&self, spec: &SolverFile) -> Result<Inputs, InputError> {
        let mut outputs: Vec<PathBuf> = Vec::new();
        let templates = spec
            .templates
            .iter()
            .map(|t| self.template(t, &mut outputs))
            .collect::<Result<Vec<_>, _>>()?;
        let files = spec
            .files
            .iter()
            .map(|f| self.copied(f, &mut outputs))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((templates, files, outputs))
    }

    /// The error at `solver` when `simulation.response` is missing: what an LS-DYNA deck's crush
    /// force (`lsdyna`, `openradioss`) or any other solver's response file needs.
    fn missing_response(&self, solver: &Spanned<SolverFile>, adapter: &str, lsdyna: bool) -> InputError {
        let want = if lsdyna {
            format!(
                "an `{adapter}` solver needs `simulation.response: {{kind: crush_force, window: [5, 60], node: ...}}`"
            )
        } else {
            "a solver simulation needs `simulation.response: {file, regex}`".to_string()
        };
        self.at_key("solver", solver, want)
    }

    /// `deck.per_design`: each include's name and its files' pattern (relative to the study file,
    /// with `{design}` in it).
    fn per_design(&self, spec: &DeckSpecFile) -> Result<Vec<(String, PathBuf)>, InputError> {
        let dir = self.path.parent().unwrap_or(Path::new(""));
        spec.per_design
            .iter()
            .map(|(include, pattern)| {
                if !pattern.value.contains("{design}") {
                    return Err(self.at(
                        pattern,
                        "a per-design file's path with `{design}` in it, e.g. `meshes/{design}.k`",
                    ));
                }
                Ok((include.value.clone(), dir.join(&pattern.value)))
            })
            .collect()
    }

    /// The main deck of an `openradioss` run: the deck used as it is, or the first template's output.
    fn main_deck(&self, solver: &Spanned<SolverFile>, main: Option<PathBuf>) -> Result<PathBuf, InputError> {
        main.ok_or_else(|| {
            self.at_key(
                "solver",
                solver,
                "an `openradioss` solver needs `deck: {file: model.k}` or `templates: [main.k.tera, ...]` (the first \
                 is the main deck)",
            )
        })
    }

    /// `solver.deck`: the deck and its includes read, every study variable defined in them (a
    /// `*PARAMETER` entry or a `<<name>>` mark; with per-design includes, a design variable may be
    /// the geometry they carry instead), each under its own name in upper case or the name
    /// `names:` gives it.
    fn deck(
        &self,
        node: &Spanned<DeckSpecFile>,
        templates: &[Template],
        (variables, design): (&[String], &[String]),
        outputs: &[PathBuf],
    ) -> Result<Deck, InputError> {
        if !templates.is_empty() {
            return Err(self.at_key(
                "deck",
                node,
                "`deck` and `templates` together: a deck used as it is takes the place of the templates",
            ));
        }
        let spec = &node.value;
        let file = self.referenced_file(&spec.file, "deck")?;
        let mut names: Vec<(String, String)> = variables.iter().map(|v| (v.clone(), v.to_ascii_uppercase())).collect();
        for (variable, name) in &spec.names {
            let Some(entry) = names.iter_mut().find(|(v, _)| *v == variable.value) else {
                return Err(self.at(
                    variable,
                    format!(
                        "`{}` is not a design variable, parameter or extension variable of the study",
                        variable.value
                    ),
                ));
            };
            let valid = !name.value.is_empty() && name.value.len() <= 9;
            if !valid || !name.value.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(self.at(name, "a `*PARAMETER` name: 1 to 9 letters, digits or `_`"));
            }
            entry.1 = name.value.to_ascii_uppercase();
        }
        let per_design = self.per_design(spec)?;
        let (deck, defined) = Deck::read(&file, names, &per_design)?;
        let included: Vec<String> = deck
            .files
            .iter()
            .flat_map(|f| lsdyna_keyword::parameters::includes(&f.source))
            .map(|i| i.file)
            .collect();
        if let Some((name, _)) = spec.per_design.iter().find(|(n, _)| !included.contains(&n.value)) {
            return Err(self.at(
                name,
                format!(
                    "`per_design`: no `*INCLUDE` of the deck or its includes names `{}`",
                    name.value
                ),
            ));
        }
        let marks = deck.marks()?;
        // With per-design includes, a design variable the deck does not name is the geometry they
        // carry (the honeycomb's cell size).
        let geometry = |v: &String| !deck.per_design.is_empty() && design.contains(v);
        for (variable, name) in deck.names.iter().filter(|(v, _)| !geometry(v)) {
            if !defined.iter().any(|d| d.entry.name == *name) && !marks.contains(name) {
                return Err(self.at(&spec.file, format!(
                    "`{variable}` has no `*PARAMETER` {name} in {} or the files it includes (nor a `<<{name}>>` mark): \
                     add one, or name the deck's parameter with `names: {{{variable}: ...}}`",
                    file.display()
                )));
            }
        }
        if let Some(f) = deck.files.iter().find(|f| outputs.contains(&f.output)) {
            return Err(self.at(
                &spec.file,
                format!(
                    "the deck's file `{}` and another input would both be written to it in the run directory",
                    f.output.display()
                ),
            ));
        }
        Ok(deck)
    }

    /// `solver.command`, or the adapter's default: `lsdyna` runs `ls-dyna i=<first template>`;
    /// `calculix` gets `[ccx, -i, JOB]` once the job is known (empty here, see load_cluster.rs).
    fn solver_command(
        &self,
        solver: &Spanned<SolverFile>,
        adapter: &str,
        main: Option<PathBuf>,
    ) -> Result<Vec<String>, InputError> {
        match &solver.value.command {
            Some(c) => self.command(c),
            None if adapter == "lsdyna" => {
                let Some(main) = main else {
                    return Err(self.at_key(
                        "solver",
                        solver,
                        "an `lsdyna` solver needs `deck: {file: model.k}` or `templates: [main.k.tera, ...]` (the first \
                         is the main deck)",
                    ));
                };
                Ok(vec![
                    "ls-dyna".to_string(),
                    format!("i={}", main.display()),
                    "ncpu=1".to_string(),
                ])
            }
            None if adapter == "calculix" => Ok(Vec::new()),
            None => Err(self.at_key(
                "solver",
                solver,
                "a `command` solver needs `command: [program, args...]`",
            )),
        }
    }

    /// `solver.timeout` (seconds per attempt) and `solver.retries`.
    fn limits(&self, spec: &SolverFile) -> Result<(Option<Duration>, RetryPolicy), InputError> {
        let timeout = spec
            .timeout
            .as_ref()
            .map(|t| self.seconds(t, "solver.timeout", false))
            .transpose()?;
        let retry = spec
            .retries
            .as_ref()
            .map(|r| self.retries(r))
            .transpose()?
            .unwrap_or_default();
        Ok((timeout, retry))
    }

    /// `simulation.surrogate` (default linear).
    fn surrogate_kind(&self, sim: &SimulationFile) -> Result<SurrogateKind, InputError> {
        match &sim.surrogate {
            None => Ok(SurrogateKind::Linear),
            Some(s) => self.surrogate_named(s, &s.value),
        }
    }

    /// The surrogate `key` names (the value of `node`, as the caller reads it).
    pub(super) fn surrogate_named(&self, node: &Spanned<String>, key: &str) -> Result<SurrogateKind, InputError> {
        SurrogateKind::from_key(key).ok_or_else(|| {
            self.at(
                node,
                format!("unknown surrogate `{}`: choose from linear, quadratic, gp", node.value),
            )
        })
    }

    /// `simulation.replay`, relative to the study file.
    /// What each run directory gets: the templates, the deck used as it is, the copied files, then
    /// (checked in this order) the design's mesh and the seeds' variable.
    fn run_inputs(
        &self,
        sim: &SimulationFile,
        (templates, deck, files): (Vec<Template>, Option<Deck>, Vec<CopiedFile>),
        design_names: &[String],
        (lsdyna, nodal_noise): (bool, bool),
    ) -> Result<RunInputs, InputError> {
        let mesh = sim.mesh.as_ref().map(|m| self.mesh(m, design_names)).transpose()?;
        let seeds = (sim.seeds.as_ref())
            .map(|n| self.seeds(n, &templates, deck.as_ref(), nodal_noise))
            .transpose()?;
        Ok(RunInputs {
            templates,
            deck,
            files,
            mesh,
            seeds,
            parameter_width: lsdyna.then_some(10),
        })
    }

    /// `simulation.seeds`: at least two seeds, set by a template variable that a template (or
    /// the deck's `names`) uses, else every seed would render the same run.
    fn seeds(
        &self,
        node: &Spanned<SeedsFile>,
        templates: &[Template],
        deck: Option<&Deck>,
        nodal_noise: bool,
    ) -> Result<Seeds, InputError> {
        let s = &node.value;
        if s.count.value < 2 {
            return Err(self.at(
                &s.count,
                "`seeds.count` must be at least 2: the solver's scatter is measured between seeds",
            ));
        }
        let Some(variable) = &s.variable else {
            if nodal_noise {
                return Ok(Seeds {
                    count: s.count.value,
                    variable: None,
                });
            }
            return Err(self.at(
                node,
                "`seeds` needs `variable`: the template variable that sets a run's seed (an `openradioss` \
                 solver with `openradioss.noise` may leave it out: the seeds are then its starter's `-rseed`)",
            ));
        };
        let name = variable.value.trim();
        let used = templates.iter().any(|t| t.source.contains(name))
            || deck.is_some_and(|d| d.names.iter().any(|(n, _)| n == name));
        if name.is_empty() || !used {
            return Err(self.at(
                variable,
                format!("`seeds.variable` `{name}` is used by no template (nor named by the deck): every seed would run the same deck"),
            ));
        }
        Ok(Seeds {
            count: s.count.value,
            variable: Some(name.to_string()),
        })
    }

    fn replay_dir(&self, sim: &SimulationFile) -> Result<Option<PathBuf>, InputError> {
        let Some(r) = &sim.replay else {
            return Ok(None);
        };
        if r.value.trim().is_empty() {
            return Err(self.at(
                r,
                "`simulation.replay` is empty: give a directory relative to the study file",
            ));
        }
        Ok(Some(self.path.parent().unwrap_or(Path::new("")).join(&r.value)))
    }

    fn regex_response(&self, node: &Spanned<ResponseFile>) -> Result<Response, InputError> {
        let r = &node.value;
        if let Some(kind) = &r.kind {
            return Err(self.at(
                kind,
                "`response.kind` goes with `adapter: lsdyna`; the command adapter reads {file, regex}",
            ));
        }
        let (Some(file), Some(regex)) = (&r.file, &r.regex) else {
            return Err(self.at_key(
                "response",
                node,
                "the command adapter needs `simulation.response: {file, regex}`",
            ));
        };
        let response_file = self.relative_path(file, "response.file")?;
        crate::study::settings::response_regex(&regex.value)
            .map_err(|e| self.at(regex, format!("response regex: {e}")))?;
        Ok(Response::Regex {
            file: response_file,
            regex: regex.value.clone(),
        })
    }

    fn crush_response(&self, node: &Spanned<ResponseFile>, adapter: &str) -> Result<Response, InputError> {
        let r = &node.value;
        if let Some(f) = r.file.as_ref().or(r.regex.as_ref()) {
            return Err(self.at(
                f,
                format!(
                    "the {adapter} adapter reads its solver's histories itself: give `kind: crush_force`, `window`, \
                     `node`, not file/regex"
                ),
            ));
        }
        if let (Some(side), "openradioss") = (&r.side, adapter) {
            return Err(self.at(
                side,
                "an OpenRadioss interface records one force: `response.side` goes with `adapter: lsdyna`",
            ));
        }
        self.crush_force_kind(node)?;
        let window = self.stroke_window(node)?;
        let source = self.crush_source(node)?;
        Ok(Response::CrushForce { window, source })
    }

    /// `response.kind`: `crush_force`, the lsdyna adapter's one kind.
    fn crush_force_kind(&self, node: &Spanned<ResponseFile>) -> Result<(), InputError> {
        let r = &node.value;
        match &r.kind {
            Some(k) if k.value == "crush_force" => {}
            Some(k) => {
                return Err(self.at(
                    k,
                    format!(
                        "unknown response kind `{}`: the lsdyna adapter has crush_force",
                        k.value
                    ),
                ));
            }
            None => {
                return Err(self.at_key(
                    "response",
                    node,
                    "the lsdyna adapter needs `response.kind: crush_force`",
                ));
            }
        }
        Ok(())
    }

    /// `response.window: [s0, s1]`, the stroke window in mm.
    fn stroke_window(&self, node: &Spanned<ResponseFile>) -> Result<Window, InputError> {
        let r = &node.value;
        let Some(window) = &r.window else {
            return Err(self.at_key(
                "response",
                node,
                "`response.window: [s0, s1]` (stroke window, mm) is missing",
            ));
        };
        let w: Vec<f64> = window.value.iter().map(|v| v.value).collect();
        if w.len() != 2 || !w.iter().all(|v| v.is_finite()) || w[0] < 0.0 || w[1] <= w[0] {
            return Err(self.at(window, "`response.window` must be [s0, s1] in mm with 0 <= s0 < s1"));
        }
        Ok(Window { s0: w[0], s1: w[1] })
    }

    /// Where the crush force and the stroke are read: rcforc interface, side and axis, nodout node
    /// and axis, unit factors.
    fn crush_source(&self, node: &Spanned<ResponseFile>) -> Result<SimSource, InputError> {
        let r = &node.value;
        let Some(node_id) = &r.node else {
            return Err(self.at_key(
                "response",
                node,
                "`response.node` (the striker's nodout node id) is missing",
            ));
        };
        let axis = |n: &Option<Spanned<String>>, default: usize| -> Result<usize, InputError> {
            match n {
                None => Ok(default),
                Some(a) => match a.value.to_ascii_lowercase().as_str() {
                    "x" => Ok(0),
                    "y" => Ok(1),
                    "z" => Ok(2),
                    other => Err(self.at(a, format!("axis `{other}`: choose x, y or z"))),
                },
            }
        };
        let force_axis = axis(&r.axis, 2)?;
        let disp_axis = axis(&r.node_axis, force_axis)?;
        let side = match &r.side {
            None => Side::SurfB,
            Some(s) => match s.value.to_ascii_lowercase().as_str() {
                "master" | "surfb" => Side::SurfB,
                "slave" | "surfa" => Side::SurfA,
                other => return Err(self.at(s, format!("side `{other}`: choose master (surfb) or slave (surfa)"))),
            },
        };
        let factor = |n: &Option<Spanned<f64>>, key: &str| -> Result<f64, InputError> {
            match n {
                None => Ok(1.0),
                Some(v) if v.value.is_finite() && v.value > 0.0 => Ok(v.value),
                Some(v) => Err(self.at(v, format!("`response.{key}` must be a positive number"))),
            }
        };
        Ok(SimSource {
            interface: r.interface.as_ref().map_or(1, |i| i.value),
            side,
            force_axis,
            force_sign: Sign::Auto,
            force_to_kn: factor(&r.force_to_kn, "force_to_kn")?,
            node: node_id.value,
            disp_axis,
            disp_sign: Sign::Auto,
            disp_to_mm: factor(&r.disp_to_mm, "disp_to_mm")?,
            rigid_wall: r.rigid_wall.as_ref().map(|w| w.value),
        })
    }

    fn mesh(&self, node: &Spanned<MeshFile>, design_names: &[String]) -> Result<MeshSpec, InputError> {
        let m = &node.value;
        if m.kind.value != "honeycomb_tube" {
            return Err(self.at(
                &m.kind,
                format!("unknown mesh kind `{}`: choose honeycomb_tube", m.kind.value),
            ));
        }
        let positive = |v: &Spanned<f64>, key: &str| -> Result<f64, InputError> {
            if v.value.is_finite() && v.value > 0.0 {
                Ok(v.value)
            } else {
                Err(self.at(v, format!("`mesh.{key}` must be a positive length in mm")))
            }
        };
        let element_size = positive(&m.element_size, "element_size")?;
        let cell_name = m.cell.as_ref().map_or("c", |c| c.value.as_str());
        let Some(cell_variable) = design_names.iter().position(|n| n == cell_name) else {
            let msg = format!(
                "the mesh's cell size comes from design variable `{cell_name}`, which the study does not have \
                 (design variables: {}); set `mesh.cell`",
                design_names.join(", ")
            );
            return Err(match &m.cell {
                Some(c) => self.at(c, msg),
                None => self.at_key("mesh", node, msg),
            });
        };
        let diameter = m
            .diameter
            .as_ref()
            .map(|v| positive(v, "diameter"))
            .transpose()?
            .unwrap_or(57.35);
        let length = m
            .length
            .as_ref()
            .map(|v| positive(v, "length"))
            .transpose()?
            .unwrap_or(150.0);
        let edge_set = match &m.edge_set {
            Some(v) if v.value == 0 => return Err(self.at(v, "`mesh.edge_set` is a set id: 1 or more")),
            other => other.as_ref().map(|v| v.value),
        };
        Ok(MeshSpec {
            cell_variable,
            element_size,
            diameter,
            length,
            edge_set,
        })
    }

    fn adapter(&self, node: &Spanned<String>) -> Result<String, InputError> {
        match node.value.as_str() {
            "command" | "lsdyna" | "calculix" | "openradioss" => Ok(node.value.clone()),
            name => Err(self.at(
                node,
                format!("unknown adapter `{name}`: choose from command, lsdyna, calculix, openradioss"),
            )),
        }
    }

    fn command(&self, node: &Spanned<Vec<Spanned<String>>>) -> Result<Vec<String>, InputError> {
        let Some(program) = node.value.first() else {
            return Err(self.at(
                node,
                "empty `solver.command`: give the program and its arguments, e.g. [ccx, -i, job]",
            ));
        };
        if program.value.trim().is_empty() {
            return Err(self.at(program, "the solver's program name is empty"));
        }
        Ok(node.value.iter().map(|a| a.value.clone()).collect())
    }

    /// A file named in the study, resolved against the study's directory; it must exist.
    pub(super) fn referenced_file(&self, node: &Spanned<String>, what: &str) -> Result<PathBuf, InputError> {
        let path = self.path.parent().unwrap_or(Path::new("")).join(&node.value);
        if !path.is_file() {
            let why = if path.exists() {
                "is not a file"
            } else {
                "does not exist"
            };
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
        let name = file
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let output = PathBuf::from(name.strip_suffix(".tera").unwrap_or(&name));
        if output.as_os_str().is_empty() {
            return Err(self.at(
                node,
                format!("`{}` leaves no file name in the run directory", node.value),
            ));
        }
        if outputs.contains(&output) {
            return Err(self.at(
                node,
                format!(
                    "two inputs would both be written to `{}` in the run directory",
                    output.display()
                ),
            ));
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
        crate::base::template::Renderer::new(std::slice::from_ref(&template))?;
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
            return Err(self.at(
                node,
                format!("`{key}` must be a relative path inside the run directory"),
            ));
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
            return Err(self.at(
                &spec.max_attempts,
                "`retries.max_attempts` counts the first attempt: at least 1",
            ));
        }
        let initial = spec
            .backoff
            .as_ref()
            .map(|b| self.seconds(b, "retries.backoff", true))
            .transpose()?;
        let max = spec
            .max_backoff
            .as_ref()
            .map(|b| self.seconds(b, "retries.max_backoff", true))
            .transpose()?;
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
        RETRY_CLASSES
            .iter()
            .find(|(name, _)| *name == node.value)
            .map(|(_, c)| *c)
            .ok_or_else(|| {
                let names: Vec<&str> = RETRY_CLASSES.iter().map(|(n, _)| *n).collect();
                self.at(
                    node,
                    format!(
                        "unknown outcome class `{}`: choose from {}",
                        node.value,
                        names.join(", ")
                    ),
                )
            })
    }

    fn sampling(&self, spec: &SamplingFile, surrogate: SurrogateKind, p: usize) -> Result<Sampling, InputError> {
        if let Some(s) = &spec.surrogate {
            return Err(self.at(
                s,
                "`surrogate` goes in `sampling.replaces` (the replaced design's own), not in `sampling`",
            ));
        }
        self.sampling_with(spec, surrogate, p)
    }

    /// `sampling` (or `sampling.replaces`, whose own `surrogate` has been taken) with `surrogate`.
    fn sampling_with(&self, spec: &SamplingFile, surrogate: SurrogateKind, p: usize) -> Result<Sampling, InputError> {
        let method = match spec.method.value.as_str() {
            "lhs" => SamplingMethod::Lhs,
            "grid" => SamplingMethod::Grid,
            "sequential" => return self.sequential(spec, surrogate, p),
            other => {
                return Err(self.at(
                    &spec.method,
                    format!("unknown sampling method `{other}`: choose lhs, grid or sequential"),
                ));
            }
        };
        for (key, given) in [
            ("initial", spec.initial.is_some()),
            ("batch", spec.batch.is_some()),
            ("budget", spec.budget.is_some()),
            ("tolerance", spec.tolerance.is_some()),
            ("across_designs", spec.across_designs.is_some()),
            ("replaces", spec.replaces.is_some()),
        ] {
            if given {
                return Err(self.at(
                    &spec.method,
                    format!(
                        "`sampling.{key}` belongs to `method: sequential`, not `{}`",
                        spec.method.value
                    ),
                ));
            }
        }
        let Some(count) = &spec.count else {
            return Err(self.at(
                &spec.method,
                format!("`method: {}` needs `count`: samples per design", spec.method.value),
            ));
        };
        let count = count.value;
        let needed = surrogate.min_samples(p);
        let count_node = spec.count.as_ref().expect("checked");
        if count < needed {
            return Err(self.at(
                count_node,
                format!(
                    "{count} samples per design are too few for a {} surrogate over {p} parameter(s): it needs at \
                     least {needed}",
                    surrogate.key()
                ),
            ));
        }
        if method == SamplingMethod::Grid && Sampling::grid_side(count, p).is_none() {
            return Err(self.at(
                count_node,
                format!("a grid over {p} parameters needs a count that is a {p}-th power (points per axis ^ {p})"),
            ));
        }
        let check_runs = spec.check_runs.as_ref().map_or(DEFAULT_CHECK_RUNS, |c| c.value);
        Ok(Sampling {
            method,
            count,
            seed: spec.seed,
            check_runs,
            sequential: None,
            surrogate: None,
        })
    }

    /// `method: sequential`: `initial` (default: the surrogates' fewest samples plus one, set when the
    /// plan is made), `batch`, `budget`, `tolerance`, `seed`; no `count` or `check_runs` (the last runs
    /// at each design are its check).
    fn sequential(&self, spec: &SamplingFile, surrogate: SurrogateKind, p: usize) -> Result<Sampling, InputError> {
        if let Some(c) = &spec.count {
            return Err(self.at(
                c,
                "`method: sequential` takes `initial` (the first samples per design), not `count`",
            ));
        }
        if let Some(c) = &spec.check_runs {
            return Err(self.at(
                c,
                "`method: sequential` needs no `check_runs`: each design's latest runs check its emulator",
            ));
        }
        let initial = self.sequential_initial(spec, surrogate, p)?;
        if let Some(b) = spec.batch.as_ref().filter(|b| b.value == 0) {
            return Err(self.at(b, "`sampling.batch` must be at least 1"));
        }
        if let Some(b) = spec.budget.as_ref().filter(|b| b.value == 0) {
            return Err(self.at(b, "`sampling.budget` must be at least 1"));
        }
        let tolerance = self.sequential_tolerance(spec)?;
        let replaces = spec
            .replaces
            .as_ref()
            .map(|node| self.replaced_design(node, surrogate, p))
            .transpose()?;
        let across_designs = self.one_emulator_across(spec, surrogate)?;
        Ok(Sampling {
            method: SamplingMethod::Sequential,
            count: initial,
            seed: spec.seed,
            check_runs: 0,
            sequential: Some(crate::study::solver::Sequential {
                batch: spec.batch.as_ref().map(|b| b.value),
                budget: spec.budget.as_ref().map_or(0, |b| b.value),
                tolerance,
                replaces,
                across_designs,
            }),
            surrogate: None,
        })
    }

    /// `sampling.initial`: the first samples per design, at least the surrogate's fewest; 0 when not
    /// given (the plan sets the default).
    fn sequential_initial(&self, spec: &SamplingFile, surrogate: SurrogateKind, p: usize) -> Result<usize, InputError> {
        match &spec.initial {
            Some(n) if n.value < surrogate.min_samples(p) => Err(self.at(
                n,
                format!(
                    "{} initial samples per design are too few for a {} surrogate over {p} parameter(s): it needs \
                     at least {}",
                    n.value,
                    surrogate.key(),
                    surrogate.min_samples(p)
                ),
            )),
            Some(n) => Ok(n.value),
            None => Ok(0),
        }
    }

    /// `sampling.tolerance`: a positive fraction of the tests' noise (default
    /// [`crate::study::solver::DEFAULT_TOLERANCE`]).
    fn sequential_tolerance(&self, spec: &SamplingFile) -> Result<f64, InputError> {
        match &spec.tolerance {
            Some(t) if !(t.value.is_finite() && t.value > 0.0) => Err(self.at(
                t,
                "`sampling.tolerance` is a positive fraction of the tests' noise, e.g. 0.5",
            )),
            Some(t) => Ok(t.value),
            None => Ok(crate::study::solver::DEFAULT_TOLERANCE),
        }
    }

    /// `sampling.replaces`: the fixed design (`lhs` or `grid`) the sequence replaces, checked as a
    /// sampling of its own with its own `surrogate` (the study's when not given); the returned
    /// sampling keeps that surrogate only when it was given.
    fn replaced_design(
        &self,
        node: &Spanned<Box<SamplingFile>>,
        surrogate: SurrogateKind,
        p: usize,
    ) -> Result<Box<Sampling>, InputError> {
        if node.value.method.value == "sequential" {
            return Err(self.at(
                node,
                "`sampling.replaces` names a fixed design: `method: lhs` or `grid`, not `sequential`",
            ));
        }
        let own = match &node.value.surrogate {
            Some(s) => self.surrogate_named(s, &s.value)?,
            None => surrogate,
        };
        let mut fixed = self.sampling_with(&node.value, own, p)?;
        fixed.surrogate = node.value.surrogate.is_some().then_some(own);
        Ok(Box::new(fixed))
    }

    /// `sampling.across_designs` (default false); true needs `surrogate: gp`, the one emulator that
    /// is fitted across the designs.
    fn one_emulator_across(&self, spec: &SamplingFile, surrogate: SurrogateKind) -> Result<bool, InputError> {
        let across_designs = spec.across_designs.as_ref().is_some_and(|a| a.value);
        if let Some(a) = spec
            .across_designs
            .as_ref()
            .filter(|a| a.value && surrogate != SurrogateKind::Gp)
        {
            return Err(self.at(
                a,
                format!(
                    "`sampling.across_designs` fits one Gaussian process across the designs: it needs `surrogate: gp`, \
                     not `{}`",
                    surrogate.key()
                ),
            ));
        }
        Ok(across_designs)
    }
}
