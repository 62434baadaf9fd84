//! Study loading: YAML → schema → validated [`Study`].
//!
//! [`yaml::parse`] catches what the schema can see (syntax, unknown and duplicate keys, missing keys,
//! wrong types); the checks here catch the rest, each at the node that is wrong.

use std::collections::HashMap;
use std::path::Path;

use super::BayesianSettings;
use super::expr::ExprError;
use super::schema::{BayesianFile, CalibrationFile, DiagnosisFile, Name, SimulationFile, StudyFile};
use super::yaml::{self, Spanned};
use super::{
    CalibrationSettings, DesignVariable, DiagnosisSettings, Experiments, Expression, Hypothesis, HypothesisKind,
    Method, Parameter, Simulation, Split, Study, SurrogateKind, Symbols, experiments, symbols,
};
use crate::error::InputError;

#[path = "load_cluster.rs"]
mod cluster;
#[path = "load_solver.rs"]
mod solver;

#[path = "load_extension.rs"]
mod extension;

#[path = "load_curves.rs"]
mod curves;

#[path = "load_quality.rs"]
mod quality;

#[path = "load_openradioss.rs"]
mod openradioss;

/// Loads and validates a study file and everything it references.
pub fn load(path: &Path) -> Result<Study, InputError> {
    let source = std::fs::read_to_string(path)
        .map_err(|e| InputError::file(path, format!("cannot read the study file: {e}")))?;
    let file: StudyFile = yaml::parse(path, &source)?;
    Checker { path, source: &source }.study(file)
}

/// The experiments file and the designs a study tests from it.
struct Tested {
    experiments: Experiments,
    training: Vec<String>,
    validation: Vec<String>,
}

/// The study file and its text, for located errors.
struct Checker<'a> {
    path: &'a Path,
    source: &'a str,
}

impl Checker<'_> {
    /// An error at `node`, or about the whole file when its location is unknown.
    fn at<T>(&self, node: &Spanned<T>, message: impl Into<String>) -> InputError {
        self.at_position(node.line, node.column, message)
    }

    fn at_position(&self, line: usize, column: usize, message: impl Into<String>) -> InputError {
        if line > 0 && column > 0 {
            InputError::at(self.path, self.source, line, column, message)
        } else {
            InputError::file(self.path, message)
        }
    }

    /// Line `line` (from 1) of the study file.
    fn line(&self, line: usize) -> &str {
        line.checked_sub(1)
            .and_then(|i| self.source.lines().nth(i))
            .unwrap_or("")
    }

    /// Where the key `key:` whose value is `value` is written: on the value's line before it, or on
    /// one of the few lines above (block style). Falls back to the value's own location.
    fn key_position<T>(&self, key: &str, value: &Spanned<T>) -> (usize, usize) {
        let pattern = format!("{key}:");
        for line in (value.line.saturating_sub(3).max(1)..=value.line).rev() {
            let text = self.line(line);
            let found = text
                .match_indices(&pattern)
                .map(|(at, _)| text[..at].chars().count())
                .filter(|&col| {
                    let before = text[..text.char_indices().nth(col).map_or(text.len(), |(b, _)| b)]
                        .chars()
                        .next_back();
                    !before.is_some_and(|c| c.is_alphanumeric() || c == '_')
                });
            let found = if line == value.line {
                found.filter(|&col| col + 1 < value.column).last()
            } else {
                found.last()
            };
            if let Some(col) = found {
                return (line, col + 1);
            }
        }
        (value.line, value.column)
    }

    fn at_key<T>(&self, key: &str, value: &Spanned<T>, message: impl Into<String>) -> InputError {
        let (line, column) = self.key_position(key, value);
        self.at_position(line, column, message)
    }

    /// An expression error at the offending character when the expression is written on one line
    /// (node column, plus one for an opening quote, plus the error's character offset), else at the
    /// expression's node.
    fn expression_error(&self, node: &Spanned<String>, what: &str, error: ExprError) -> InputError {
        let message = match error.offset {
            Some(_) => format!("{what}: {}", error.message),
            None => format!("{what} does not parse: {}", error.message),
        };
        let column = error
            .offset
            .and_then(|offset| self.column_in_string(node, offset))
            .unwrap_or(node.column);
        self.at_position(node.line, column, message)
    }

    /// Column of the `offset`-th character of the string at `node`, if the source text there
    /// matches the string's value up to and including that character.
    fn column_in_string(&self, node: &Spanned<String>, offset: usize) -> Option<usize> {
        let text: Vec<char> = self.line(node.line).chars().skip(node.column.checked_sub(1)?).collect();
        let quote = usize::from(matches!(text.first(), Some('"' | '\'')));
        let value: Vec<char> = node.value.chars().collect();
        let wanted = value.get(..=offset)?;
        let written = text.get(quote..quote + wanted.len())?;
        (written == wanted).then_some(node.column + quote + offset)
    }

    /// The study's checks as named steps, in the order their errors are reported: the names, the
    /// variables, the simulation, the experiments and the designs tested, the calibration, the
    /// splits, the truth, then the diagnosis (which needs the rest).
    fn study(&self, file: StudyFile) -> Result<Study, InputError> {
        let name = self.name(&file.name)?;
        self.names(&file)?;
        let constants = self.constants(&file)?;
        let design = self.design_variables(&file)?;
        let parameters = self.parameters(&file)?;
        let symbols = symbols(&design, &parameters, &constants);
        // The names a deck used as it is must define: the design variables, the parameters and the
        // hypotheses' extension variables.
        let extension_names = file
            .diagnosis
            .iter()
            .flat_map(|d| &d.hypotheses)
            .flat_map(|h| h.extension.iter().flat_map(|e| e.value.keys().map(|k| k.value.clone())));
        let deck_names: Vec<String> = symbols.names()[..design.len() + parameters.len()]
            .iter()
            .cloned()
            .chain(extension_names)
            .collect();
        let mut simulation =
            self.simulation(&file.simulation, &symbols, &deck_names, design.len(), parameters.len())?;
        let Tested {
            experiments,
            training,
            validation,
        } = self.tested(&file, &design, &simulation)?;
        self.per_design_files(&file, &mut simulation, &training, &validation)?;
        let mut calibration = self.calibration(file.calibration.as_ref(), &file.training, training.len())?;
        (calibration.against, calibration.curve) = self.curve_calibration(
            file.calibration.as_ref(),
            &simulation,
            &experiments,
            &training,
            &validation,
        )?;
        calibration.splits = self.splits(file.splits.as_ref(), &experiments, &training, &validation, &calibration)?;
        let mut experiments = experiments;
        experiments.truth = self.truth(&file, &parameters)?;
        let mut study = Study {
            name,
            path: self.path.to_path_buf(),
            constants,
            design,
            parameters,
            simulation,
            experiments,
            split: Split { training, validation },
            calibration,
            diagnosis: DiagnosisSettings::default(),
        };
        debug_assert_eq!(study.symbols(), symbols);
        study.diagnosis = self.diagnosis(file.diagnosis.as_ref(), &study)?;
        self.budget(&file, &study)?;
        self.across_designs(&file, &study)?;
        Ok(study)
    }

    /// One emulator across the designs is a Gaussian process: the curves' emulator across the designs
    /// is one too, so `calibration.curve.surrogate` may only say `gp`.
    fn across_designs(&self, file: &StudyFile, study: &Study) -> Result<(), InputError> {
        let node = file
            .simulation
            .value
            .sampling
            .as_ref()
            .and_then(|s| s.value.across_designs.as_ref());
        let curve = study.calibration.curve.surrogate.filter(|k| *k != SurrogateKind::Gp);
        match (node, curve) {
            (Some(node), Some(kind)) if node.value && study.calibration.against.curves => Err(self.at_key(
                "across_designs",
                node,
                format!(
                    "`sampling.across_designs` fits the curves' emulator as Gaussian processes across the designs, \
                     but `calibration.curve.surrogate` says `{}`: set it to `gp` or leave it out, or sample per design",
                    kind.key()
                ),
            )),
            _ => Ok(()),
        }
    }

    /// A sequence's `budget` pays at least for the runs it makes whatever they show
    /// ([`crate::plan::sweep::SequenceFloor`]): fewer could not be kept.
    fn budget(&self, file: &StudyFile, study: &Study) -> Result<(), InputError> {
        let (Simulation::Solver(sim), Some(node)) = (
            &study.simulation,
            file.simulation
                .value
                .sampling
                .as_ref()
                .and_then(|s| s.value.budget.as_ref()),
        ) else {
            return Ok(());
        };
        let Some(floor) = super::sequence::SequenceFloor::of(study, sim) else {
            return Ok(());
        };
        if node.value >= floor.runs() {
            return Ok(());
        }
        let mut parts = vec![
            format!(
                "its first batch of {} at the {} tested design(s)",
                floor.initial, floor.designs
            ),
            format!("one held-out run per design ({})", floor.designs),
        ];
        if floor.probes > 0 {
            parts.push(format!("the extension hypotheses' probes ({})", floor.probes));
        }
        if floor.looped > 0 {
            parts.push(format!(
                "the solver in the loop's first batches (up to {})",
                floor.looped
            ));
        }
        parts.push(format!(
            "the confirmation runs at the fitted parameters of the uncorrected simulation and of a named cause \
             ({})",
            floor.confirmation
        ));
        Err(self.at_key(
            "budget",
            node,
            format!(
                "`sampling.budget` is {} solver run(s), fewer than the sequence makes whatever its runs show: {}; \
                 a budget of at least {} (or none: {} per tested design)",
                node.value,
                parts.join(", "),
                floor.runs(),
                crate::study::solver::DEFAULT_BUDGET_PER_DESIGN
            ),
        ))
    }

    /// `constants:`, each a finite number.
    fn constants(&self, file: &StudyFile) -> Result<Vec<(String, f64)>, InputError> {
        file.constants
            .iter()
            .map(|(name, value)| {
                let v = self.finite(value, &format!("constant `{}`", name.value))?;
                Ok((name.value.clone(), v))
            })
            .collect()
    }

    /// `design:`, each with optional finite bounds, min < max.
    fn design_variables(&self, file: &StudyFile) -> Result<Vec<DesignVariable>, InputError> {
        file.design
            .value
            .iter()
            .map(|(name, spec)| {
                let spec = spec.as_ref();
                let what = format!("design variable `{}`", name.value);
                let min = spec
                    .and_then(|s| s.min.as_ref())
                    .map(|m| self.finite(m, &format!("{what}: min")))
                    .transpose()?;
                let max = spec
                    .and_then(|s| s.max.as_ref())
                    .map(|m| self.finite(m, &format!("{what}: max")))
                    .transpose()?;
                if let (Some(lo), Some(hi), Some(node)) = (min, max, spec.and_then(|s| s.min.as_ref()))
                    && lo >= hi
                {
                    return Err(self.at(node, format!("{what}: min ({lo}) must be less than max ({hi})")));
                }
                let scale = spec
                    .and_then(|s| s.scale.as_ref())
                    .map(|node| self.scale(node, &what))
                    .transpose()?;
                Ok(DesignVariable {
                    name: name.value.clone(),
                    unit: spec.and_then(|s| s.unit.clone()),
                    min,
                    max,
                    scale,
                })
            })
            .collect()
    }

    /// A design variable's `scale`: a finite positive number (in the variable's unit).
    fn scale(&self, node: &Spanned<f64>, what: &str) -> Result<f64, InputError> {
        let v = self.finite(node, &format!("{what}: scale"))?;
        if v <= 0.0 {
            return Err(self.at(
                node,
                format!(
                    "{what}: scale must be positive ({v} given): it is the length L, in the variable's unit, that \
                     makes x/L dimensionless in the discovery library's exp(-x/L) and ln(x/L)"
                ),
            ));
        }
        Ok(v)
    }

    /// `parameters:`, at least one, each with finite bounds, min < max.
    fn parameters(&self, file: &StudyFile) -> Result<Vec<Parameter>, InputError> {
        if file.parameters.value.is_empty() {
            return Err(self.at_key(
                "parameters",
                &file.parameters,
                "no calibration parameters: give at least one, e.g. `E: {min: 50000, max: 80000}`",
            ));
        }
        file.parameters
            .value
            .iter()
            .map(|(name, spec)| {
                let what = format!("parameter `{}`", name.value);
                let min = self.finite(&spec.min, &format!("{what}: min"))?;
                let max = self.finite(&spec.max, &format!("{what}: max"))?;
                if min >= max {
                    return Err(self.at(&spec.min, format!("{what}: min ({min}) must be less than max ({max})")));
                }
                Ok(Parameter {
                    name: name.value.clone(),
                    min,
                    max,
                    unit: spec.unit.clone(),
                })
            })
            .collect()
    }

    /// The experiments, the training and validation designs among them (disjoint, training not
    /// empty), and the specimens' curves of those designs.
    fn tested(
        &self,
        file: &StudyFile,
        design: &[DesignVariable],
        simulation: &Simulation,
    ) -> Result<Tested, InputError> {
        let mut experiments = self.experiments(file, design)?;
        experiments.unit = self.response_unit(file.experiments.unit.as_ref(), simulation)?;
        let training = self.designs(&file.training.value, "training", &experiments)?;
        if training.is_empty() {
            return Err(self.at(
                &file.training,
                "no training designs: list at least one design of the experiments file, e.g. `training: [h8, h10]`",
            ));
        }
        let validation = self.designs(&file.validation, "validation", &experiments)?;
        if let Some(both) = file.validation.iter().find(|v| training.contains(&v.value)) {
            return Err(self.at(
                both,
                format!(
                    "design `{}` is listed in both training and validation; a design is one or the other",
                    both.value
                ),
            ));
        }

        let planned: Vec<String> = training.iter().chain(&validation).cloned().collect();
        experiments.curves = self.specimen_curves(file.experiments.curves.as_ref(), &experiments, &planned)?;
        experiments.uncertainty = self.uncertainty(file.experiments.uncertainty.as_ref())?;
        Ok(Tested {
            experiments,
            training,
            validation,
        })
    }

    /// `truth:`: known values of parameters (synthetic tests), each a parameter's.
    fn truth(&self, file: &StudyFile, parameters: &[Parameter]) -> Result<Vec<(String, f64)>, InputError> {
        let mut truth = Vec::new();
        for (name, value) in &file.truth {
            if !parameters.iter().any(|p| p.name == name.value) {
                let known: Vec<&str> = parameters.iter().map(|p| p.name.as_str()).collect();
                return Err(self.at(
                    name,
                    format!(
                        "`truth` names `{}`, which is not a parameter; parameters: {}",
                        name.value,
                        known.join(", ")
                    ),
                ));
            }
            truth.push((
                name.value.clone(),
                self.finite(value, &format!("truth `{}`", name.value))?,
            ));
        }
        Ok(truth)
    }

    fn name(&self, name: &Spanned<String>) -> Result<String, InputError> {
        let valid = name
            .value
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
            && name
                .value
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_lowercase() || c.is_ascii_digit());
        if !valid {
            return Err(self.at(
                name,
                format!(
                    "invalid study name `{}`: use lowercase letters, digits and '-', starting with a letter or digit",
                    name.value
                ),
            ));
        }
        Ok(name.value.clone())
    }

    /// Names of constants, design variables and parameters: identifiers, each defined once.
    fn names(&self, file: &StudyFile) -> Result<(), InputError> {
        let mut all: Vec<(&Name, &str)> = file
            .constants
            .keys()
            .map(|n| (n, "a constant"))
            .chain(file.design.value.keys().map(|n| (n, "a design variable")))
            .chain(file.parameters.value.keys().map(|n| (n, "a parameter")))
            .collect();
        all.sort_by_key(|(n, _)| (n.line, n.column));
        let mut seen: HashMap<&str, (&Name, &str)> = HashMap::new();
        for &(name, kind) in &all {
            let text = name.value.as_str();
            let identifier = text.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && text.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !identifier {
                return Err(self.at(
                    name,
                    format!(
                        "invalid name `{text}` for {kind}: use letters, digits and '_', starting with a letter, \
                         so that expressions can refer to it"
                    ),
                ));
            }
            if text == "y" {
                return Err(self.at(
                    name,
                    format!("`y` is reserved (the simulation's prediction in hypothesis terms); rename {kind}"),
                ));
            }
            if text == "design" && kind == "a design variable" {
                return Err(self.at(
                    name,
                    "`design` is reserved: the experiments file's `design` column holds design names",
                ));
            }
            if let Some((first, first_kind)) = seen.get(text) {
                let where_ = if first.line > 0 {
                    format!(" on line {}", first.line)
                } else {
                    String::new()
                };
                return Err(self.at(
                    name,
                    format!("`{text}` is defined twice: as {first_kind}{where_} and as {kind}"),
                ));
            }
            seen.insert(text, (name, kind));
        }
        Ok(())
    }

    fn finite(&self, node: &Spanned<f64>, what: &str) -> Result<f64, InputError> {
        if node.value.is_finite() {
            Ok(node.value)
        } else {
            Err(self.at(node, format!("{what} must be a finite number, not {}", node.value)))
        }
    }

    /// A deck's per-design includes (`deck.per_design`): each tested design's file read, or an
    /// error at the key naming the design and the file.
    fn per_design_files(
        &self,
        file: &StudyFile,
        simulation: &mut Simulation,
        training: &[String],
        validation: &[String],
    ) -> Result<(), InputError> {
        let Simulation::Solver(sim) = simulation else {
            return Ok(());
        };
        let Some(deck) = sim.inputs.deck.as_mut() else {
            return Ok(());
        };
        let designs: Vec<String> = training.iter().chain(validation).cloned().collect();
        deck.read_per_design(&designs).map_err(|message| {
            let node = file
                .simulation
                .value
                .solver
                .as_ref()
                .and_then(|s| s.value.deck.as_ref());
            match node {
                Some(node) => self.at_key("per_design", node, message),
                None => InputError::file(self.path, message),
            }
        })
    }

    fn simulation(
        &self,
        node: &Spanned<SimulationFile>,
        symbols: &Symbols,
        deck_names: &[String],
        n_design: usize,
        n_parameters: usize,
    ) -> Result<Simulation, InputError> {
        let sim = &node.value;
        if let Some(solver) = &sim.solver {
            if let Some(expression) = &sim.expression {
                return Err(self.at_key(
                    "expression",
                    expression,
                    "`simulation` has both `expression` and `solver`: give exactly one",
                ));
            }
            return self
                .solver(node, solver, (&symbols.names()[..n_design], deck_names), n_parameters)
                .map(|s| Simulation::Solver(Box::new(s)));
        }
        self.no_solver_keys(sim)?;
        let Some(text) = &sim.expression else {
            return Err(self.at_key(
                "simulation",
                node,
                "`simulation` needs `expression` (a closed form over the design variables, parameters and \
                 constants) or `solver` (a program run per sample)",
            ));
        };
        let expression = Expression::compile(&text.value, symbols)
            .map_err(|e| self.expression_error(text, "simulation expression", e))?;
        if !(n_design..n_design + n_parameters).any(|i| expression.uses(i)) {
            let names = symbols.names()[n_design..n_design + n_parameters].join(", ");
            return Err(self.at(
                text,
                format!(
                    "the simulation expression uses no calibration parameter ({names}): there is nothing to calibrate"
                ),
            ));
        }
        Ok(Simulation::Expression(expression))
    }

    /// `experiments.uncertainty`: each part a finite number ≥ 0, at least one above 0.
    fn uncertainty(
        &self,
        node: Option<&Spanned<super::schema::UncertaintyFile>>,
    ) -> Result<Option<[f64; 2]>, InputError> {
        let Some(node) = node else {
            return Ok(None);
        };
        let part = |p: &Option<Spanned<f64>>, name: &str| match p {
            Some(v) if !(v.value.is_finite() && v.value >= 0.0) => Err(self.at(
                v,
                format!(
                    "`experiments.uncertainty.{name}` is {}: expected a finite number ≥ 0",
                    v.value
                ),
            )),
            Some(v) => Ok(v.value),
            None => Ok(0.0),
        };
        let (a, b) = (
            part(&node.value.absolute, "absolute")?,
            part(&node.value.relative, "relative")?,
        );
        if a == 0.0 && b == 0.0 {
            return Err(self.at(
                node,
                "`experiments.uncertainty` states no uncertainty: give `absolute` (in the response's unit) and/or \
                 `relative` (a fraction of the level, 0.01 for 1 %) above 0",
            ));
        }
        Ok(Some([a, b]))
    }

    fn experiments(&self, file: &StudyFile, design: &[DesignVariable]) -> Result<Experiments, InputError> {
        let spec = &file.experiments;
        if spec.file.value.trim().is_empty() {
            return Err(self.at(
                &spec.file,
                "`experiments.file` is empty: name the CSV file of measured tests",
            ));
        }
        let response = &spec.response;
        if response.value.trim().is_empty() {
            return Err(self.at(
                response,
                "`experiments.response` is empty: name the CSV column of the measured response",
            ));
        }
        if response.value == "design" || design.iter().any(|d| d.name == response.value) {
            return Err(self.at(
                response,
                format!(
                    "the response column `{}` cannot also be the `design` column or a design variable",
                    response.value
                ),
            ));
        }
        let csv = self.referenced_file(&spec.file, "experiments file")?;
        let names: Vec<String> = design.iter().map(|d| d.name.clone()).collect();
        experiments::read(&csv, &response.value, &names)
    }

    /// `splits`: each a training and a validation list of tested designs, none in both; with a
    /// solver, only designs the study plans runs for (its training and validation designs).
    fn splits(
        &self,
        node: Option<&Spanned<Vec<super::schema::SplitFile>>>,
        experiments: &Experiments,
        training: &[String],
        validation: &[String],
        calibration: &CalibrationSettings,
    ) -> Result<Vec<super::Split>, InputError> {
        let Some(node) = node else { return Ok(Vec::new()) };
        let planned: Vec<&String> = training.iter().chain(validation).collect();
        let mut out = Vec::new();
        for split in &node.value {
            let t = self.designs(&split.training.value, "split training", experiments)?;
            let v = self.designs(&split.validation, "split validation", experiments)?;
            for name in split.training.value.iter().chain(&split.validation) {
                if !planned.contains(&&name.value) {
                    return Err(self.at(
                        name,
                        format!(
                            "split design `{}` is neither in `training` nor in `validation`, so nothing is planned \
                             for it; list it there first",
                            name.value
                        ),
                    ));
                }
                if t.contains(&name.value) && v.contains(&name.value) {
                    return Err(self.at(name, format!("design `{}` is in both halves of a split", name.value)));
                }
            }
            if calibration.methods.contains(&Method::Sensitivity) && t.len() < 2 {
                return Err(self.at(
                    &split.training,
                    "the sensitivity method needs at least 2 training designs per split",
                ));
            }
            out.push(super::Split {
                training: t,
                validation: v,
            });
        }
        Ok(out)
    }

    /// Training or validation design names: each in the experiments, each listed once.
    fn designs(&self, names: &[Name], role: &str, experiments: &Experiments) -> Result<Vec<String>, InputError> {
        let mut out: Vec<String> = Vec::with_capacity(names.len());
        for name in names {
            if experiments.get(&name.value).is_none() {
                let known: Vec<&str> = experiments.designs.iter().map(|d| d.name.as_str()).collect();
                return Err(self.at(
                    name,
                    format!(
                        "{role} design `{}` is not in the experiments file {}; its designs are: {}",
                        name.value,
                        experiments.file.display(),
                        known.join(", ")
                    ),
                ));
            }
            if out.contains(&name.value) {
                return Err(self.at(name, format!("design `{}` is listed twice in {role}", name.value)));
            }
            out.push(name.value.clone());
        }
        Ok(out)
    }

    fn calibration(
        &self,
        spec: Option<&CalibrationFile>,
        training: &Spanned<Vec<Name>>,
        n_training: usize,
    ) -> Result<CalibrationSettings, InputError> {
        let all = vec![Method::LeastSquares, Method::Sensitivity, Method::Bayesian];
        let methods = match spec.and_then(|c| c.methods.as_ref()) {
            None => {
                if n_training < 2 {
                    return Err(self.at(
                        training,
                        format!(
                            "the default calibration methods include sensitivity, which needs at least 2 training \
                             designs (training has {n_training}); add more, or list the methods, e.g. \
                             `calibration: {{methods: [least_squares, bayesian]}}`"
                        ),
                    ));
                }
                all
            }
            Some(list) => {
                if list.value.is_empty() {
                    return Err(self.at(
                        list,
                        "no calibration methods: choose from least_squares, sensitivity, bayesian",
                    ));
                }
                let mut methods = Vec::new();
                for key in &list.value {
                    let method = Method::from_key(&key.value).ok_or_else(|| {
                        self.at(
                            key,
                            format!(
                                "unknown method `{}`: choose from least_squares, sensitivity, bayesian",
                                key.value
                            ),
                        )
                    })?;
                    if methods.contains(&method) {
                        return Err(self.at(key, format!("method `{}` is listed twice", key.value)));
                    }
                    if method == Method::Sensitivity && n_training < 2 {
                        return Err(self.at(
                            key,
                            format!(
                                "the sensitivity method needs at least 2 training designs (it pairs consecutive ones); \
                                 training has {n_training}"
                            ),
                        ));
                    }
                    methods.push(method);
                }
                methods
            }
        };
        Ok(CalibrationSettings {
            methods,
            bayesian: self.bayesian(spec.map(|c| &c.bayesian))?,
            against: Default::default(),
            curve: Default::default(),
            splits: Vec::new(),
        })
    }

    fn bayesian(&self, spec: Option<&BayesianFile>) -> Result<BayesianSettings, InputError> {
        let mut settings = BayesianSettings::default();
        let Some(spec) = spec else {
            return Ok(settings);
        };
        let at_least = |node: &Option<Spanned<usize>>, key: &str, min: usize, default: usize| match node {
            Some(n) if n.value < min => Err(self.at(n, format!("bayesian.{key} must be at least {min}"))),
            Some(n) => Ok(n.value),
            None => Ok(default),
        };
        settings.emulator_samples = at_least(&spec.emulator_samples, "emulator_samples", 2, settings.emulator_samples)?;
        settings.mcmc_walkers = at_least(&spec.mcmc_walkers, "mcmc_walkers", 2, settings.mcmc_walkers)?;
        settings.mcmc_steps = at_least(&spec.mcmc_steps, "mcmc_steps", 1, settings.mcmc_steps)?;
        settings.mcmc_burn_in = at_least(&spec.mcmc_burn_in, "mcmc_burn_in", 0, settings.mcmc_burn_in)?;
        if let Some(seed) = spec.seed {
            settings.seed = seed;
        }
        if settings.mcmc_burn_in >= settings.mcmc_steps {
            let message = format!(
                "bayesian.mcmc_burn_in ({}) must be less than bayesian.mcmc_steps ({})",
                settings.mcmc_burn_in, settings.mcmc_steps
            );
            return Err(match (&spec.mcmc_burn_in, &spec.mcmc_steps) {
                (Some(node), _) | (None, Some(node)) => self.at(node, message),
                (None, None) => InputError::file(self.path, message),
            });
        }
        Ok(settings)
    }

    fn diagnosis(&self, spec: Option<&DiagnosisFile>, study: &Study) -> Result<DiagnosisSettings, InputError> {
        let symbols = &study.term_symbols();
        let mut hypotheses: Vec<Hypothesis> = Vec::new();
        for h in spec.map_or(&[][..], |d| &d.hypotheses[..]) {
            if h.name.value.trim().is_empty() {
                return Err(self.at(&h.name, "empty hypothesis name"));
            }
            if hypotheses.iter().any(|k| k.name == h.name.value) {
                return Err(self.at(&h.name, format!("hypothesis `{}` is listed twice", h.name.value)));
            }
            let kind = match (&h.term, &h.extension) {
                (Some(term), None) => {
                    HypothesisKind::Term(Expression::compile(&term.value, symbols).map_err(|e| {
                        self.expression_error(term, &format!("term of hypothesis `{}`", h.name.value), e)
                    })?)
                }
                (None, Some(extension)) => HypothesisKind::Extension(self.extension(study, &h.name, extension)?),
                (Some(_), Some(extension)) => {
                    return Err(self.at_key(
                        "extension",
                        extension,
                        format!(
                            "hypothesis `{}` has both `term` and `extension`: give exactly one (a term is an additive \
                             shape; an extension sets template variables for extra solver runs)",
                            h.name.value
                        ),
                    ));
                }
                (None, None) => {
                    return Err(self.at(
                        &h.name,
                        format!(
                            "hypothesis `{}` needs `term:` (an additive discrepancy shape, e.g. \"1/h\") or \
                             `extension:` (template variables for extra solver runs, e.g. {{shear: 1}})",
                            h.name.value
                        ),
                    ));
                }
            };
            hypotheses.push(Hypothesis {
                name: h.name.value.clone(),
                kind,
            });
        }
        let discover = spec.and_then(|d| d.discover).unwrap_or(hypotheses.is_empty());
        Ok(DiagnosisSettings { hypotheses, discover })
    }
}
