//! The solver-in-the-loop stage of [`super::run`]: after the screening diagnosis has ranked the
//! hypotheses, a model extension whose variables have ranges is extended for real.
//!
//! ```text
//! screening diagnosis ─► chosen ─► Plan::joint ─► render ─► execute (same store) ─► per hypothesis:
//!                                                  joint surrogates ─► calibrate ─► diagnose ─► SolverExtension
//! ```
//!
//! Which hypotheses: the named cause, or, when the evidence does not decide, the two leading
//! explanations (those that are extensions with ranges). The new runs are ordinary runs of the
//! store (content-addressed, resumable, recorded and replayed like the others). The extended model
//! is the study with the ranged variables added to its parameters, its surrogates fitted per design
//! over the joint space (the joint runs, plus the screening runs at the probe values), and the
//! study's own calibration methods and diagnosis run on it.

use super::runs::{self, RunContext, RunOutcomes};
use super::stages::{FitRun, calibrate, emulator_data, fit_surrogates, problem};
use super::{Event, Reporter};
use crate::calibrate::bayesian::SimulationData;
use crate::diagnose::joint::{Calibrated, LoopRuns, MethodEstimate, SolverExtension, VariableRange};
use crate::diagnose::{self, Diagnosis};
use crate::emulate::Model;
use crate::emulate::{DesignSurrogate, SurrogateModel};
use crate::error::Error;
use crate::execute::RunStore;
use crate::execute::sweep::{self, Prepared, SweepResult};
use crate::plan::{Plan, PlannedRun, RunRole, sweep::joint_bounds};
use crate::study::{HypothesisKind, SolverSimulation, Study};

/// The hypotheses to extend with the solver (indices into `study.diagnosis.hypotheses`): the
/// named cause, or, when the data cannot tell the leading explanations apart or the cause only
/// partly explains the misfit (with a rival that still adds), every explanation left open that is
/// a model extension with ranged variables
/// (at most [`MAX_EXTENDED`], best first): the loop's models then decide between them. Nothing
/// when there is no model error to explain, no candidate explains it, or the tests are too few to
/// fit the extension's parameters.
pub fn chosen(study: &Study, diagnosis: &Diagnosis) -> Vec<usize> {
    use crate::diagnose::verdict::Verdict;
    let names: Vec<&String> = match diagnosis.finding.verdict {
        Verdict::CauseNamed => diagnosis.finding.cause.iter().collect(),
        Verdict::PartlyExplained | Verdict::CannotTellApart => diagnosis.finding.leading.iter().collect(),
        Verdict::NoModelError | Verdict::Unexplained | Verdict::TooFewTests | Verdict::EmulatorLimited => Vec::new(),
    };
    let hypotheses = &study.diagnosis.hypotheses;
    names
        .into_iter()
        .filter_map(|name| {
            hypotheses
                .iter()
                .position(|h| &h.name == name && !h.ranges().is_empty())
        })
        .take(MAX_EXTENDED)
        .collect()
}

/// The most hypotheses one loop extends (each costs a Latin hypercube of runs per design).
pub const MAX_EXTENDED: usize = 3;

/// The extensions the loop judges where the solver's runs favour `favoured` and the emulators found no
/// model error: those first, then every other extension left open with a range to calibrate (the
/// emulators excluded none of them), [`MAX_EXTENDED`] at most.
pub fn open_beside(study: &Study, diagnosis: &Diagnosis, favoured: &[usize]) -> Vec<usize> {
    let others = (diagnosis.checked.not_excluded.iter())
        .filter_map(|n| ranged(study, &n.hypothesis))
        .filter(|k| !favoured.contains(k));
    favoured.iter().copied().chain(others).take(MAX_EXTENDED).collect()
}

/// The extensions whose absence the solver's runs over their amplitude reject where the emulators
/// found no model error ([`crate::diagnose::open::Favoured`]), the largest fall of χ² first: the
/// solver in the loop over them decides what the emulators could not.
pub fn favoured(study: &Study, diagnosis: &Diagnosis) -> Vec<usize> {
    (crate::diagnose::open::favoured_first(&diagnosis.checked.not_excluded).into_iter())
        .filter_map(|(n, _)| ranged(study, &n.hypothesis))
        .take(MAX_EXTENDED)
        .collect()
}

/// The index of the study's hypothesis `name` where it has a range to calibrate in the loop.
fn ranged(study: &Study, name: &str) -> Option<usize> {
    (study.diagnosis.hypotheses.iter()).position(|h| h.name == name && !h.ranges().is_empty())
}

/// `OUT/extension-plan.json`: the hypotheses the loop extends, written before its runs start so
/// that `lab status` counts them (the loop's plan depends on the screening's verdict).
pub const PLAN_FILE: &str = "extension-plan.json";

#[derive(serde::Serialize, serde::Deserialize)]
struct PlanFile {
    hypotheses: Vec<String>,
}

/// The loop's plan as the last `lab run` on `out` chose it (empty when none was chosen).
pub fn recorded_plan(study: &Study, sim: &SolverSimulation, out: &std::path::Path) -> Plan {
    let chosen: Vec<usize> = std::fs::read(out.join(PLAN_FILE))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<PlanFile>(&bytes).ok())
        .map(|f| {
            f.hypotheses
                .iter()
                .filter_map(|name| study.diagnosis.hypotheses.iter().position(|h| &h.name == name))
                .collect()
        })
        .unwrap_or_default();
    Plan::joint(study, sim, &chosen)
}

fn write_plan(study: &Study, hypotheses: &[usize], out: &std::path::Path) -> Result<(), Error> {
    let file = PlanFile {
        hypotheses: hypotheses
            .iter()
            .map(|&k| study.diagnosis.hypotheses[k].name.clone())
            .collect(),
    };
    let bytes = serde_json::to_vec_pretty(&file).map_err(|e| Error::Failed(e.to_string()))?;
    crate::execute::store::write_atomic(&out.join(PLAN_FILE), &bytes)
        .map_err(|e| Error::Failed(format!("{}: {e}", out.join(PLAN_FILE).display())))?;
    Ok(())
}

/// The loop's runs, swept on the screening's store.
pub struct JointRuns {
    pub plan: Plan,
    pub rendered: Prepared,
    pub swept: SweepResult,
    pub outcomes: RunOutcomes,
    /// The quality gates each run breaks (empty: sound).
    pub flags: Vec<Vec<crate::extract::lsdyna::quality::Flag>>,
    /// The responses the models may use (suspect runs left out unless the study says otherwise).
    pub usable: Vec<Option<f64>>,
    /// Per hypothesis whose baseline is its joint space's edge (a sequential study: the baseline's
    /// decks are byte for byte the extension's at these values), the edge: the screening's
    /// baseline runs then join its emulators there.
    pub edges: Vec<(usize, Vec<(String, f64)>)>,
    /// The hypotheses whose emulators no solver run checked at the decision's fitted point (a
    /// sequential loop whose budget ran out first, [`super::sequence::looped`]); none for a fixed
    /// plan, whose decision reads its emulators as its check runs measured them.
    pub unchecked: Vec<usize>,
    /// The hypotheses whose sequential loop is still running (its emulators not yet within the
    /// tolerance), when the loop asks for a provisional decision; none once it has stopped.
    pub running: Vec<usize>,
}

impl JointRuns {
    /// A screening or loop run's point in hypothesis `k`'s joint space, when it is one of its runs:
    /// its own runs, its probes, and the baseline's runs where the baseline is the space's edge.
    pub fn point(&self, k: usize, ranges: &[crate::study::Parameter], run: &PlannedRun) -> Option<Vec<f64>> {
        match run.role {
            RunRole::Extension(j) | RunRole::Joint(j) | RunRole::JointCheck(j) if j == k => {
                Some(run.joint_point(ranges))
            }
            RunRole::Sample | RunRole::Check => {
                let (_, edge) = self.edges.iter().find(|(j, _)| *j == k)?;
                let value = |name: &str| edge.iter().find(|(n, _)| n == name).map(|v| v.1);
                let tail: Option<Vec<f64>> = ranges.iter().map(|r| value(&r.name)).collect();
                Some(run.theta.iter().copied().chain(tail?).collect())
            }
            _ => None,
        }
    }
}

/// Plans, renders and runs (or replays) the joint runs of `hypotheses` on `store`.
pub fn execute(
    cx: RunContext,
    hypotheses: &[usize],
    screening: &sweep::Prepared,
    store: &mut RunStore,
    reporter: &mut dyn Reporter,
) -> Result<JointRuns, Error> {
    let (study, sim, options) = (cx.study, cx.sim, cx.options);
    let plan = Plan::joint(study, sim, hypotheses);
    let names: Vec<String> = hypotheses
        .iter()
        .map(|&k| format!("'{}'", study.diagnosis.hypotheses[k].name))
        .collect();
    reporter.report(Event::Note(format!(
        "extending {} with the solver in the loop: {} more run(s) over the parameters and the extension's ranges",
        names.join(" and "),
        plan.runs.len()
    )));
    let rendered = sweep::prepare_after(study, &crate::extract::adapters::solver(sim)?, &plan, Some(screening))?;
    write_plan(study, hypotheses, &options.out)?;
    let (swept, outcomes) = runs::sweep_plan(cx, &plan, &rendered, store, reporter)?;
    let usable = swept.usable(&sim.quality);
    let flags = swept.flags(&sim.quality.gates);
    Ok(JointRuns {
        plan,
        rendered,
        swept,
        outcomes,
        flags,
        usable,
        edges: Vec::new(),
        unchecked: Vec::new(),
        running: Vec::new(),
    })
}

/// One hypothesis's extended model: the study with the ranged variables among its parameters (and
/// only the term hypotheses left), the surrogates over the joint space, the emulator's data.
pub struct ExtendedModel {
    pub hypothesis: usize,
    pub study: Study,
    pub surrogates: SurrogateModel,
    pub data: SimulationData,
    pub runs: LoopRuns,
    /// Its emulators were checked by solver runs at the decision's fitted point (or the plan was
    /// fixed, see [`JointRuns::unchecked`]).
    pub checked: bool,
    /// Its loop is still running ([`JointRuns::running`]).
    pub running: bool,
}

/// The extended model of hypothesis `k` from its joint runs (`joint`) and its screening runs
/// (`screening`, the study's first plan, whose extension runs sit at the probe values).
pub fn extended_model(
    study: &Study,
    sim: &SolverSimulation,
    k: usize,
    screening: (&Plan, &[Option<f64>]),
    joint: &JointRuns,
) -> Result<ExtendedModel, Error> {
    let hypothesis = &study.diagnosis.hypotheses[k];
    let ranges = hypothesis.ranges();
    let extended = extended_study(study, k);
    let bounds = joint_bounds(study, ranges);
    let runs: Vec<FitRun> = screening
        .0
        .runs
        .iter()
        .zip(screening.1.iter().copied())
        .chain(joint.plan.runs.iter().zip(joint.usable.iter().copied()))
        .filter_map(|(run, y)| {
            Some(FitRun {
                run,
                point: joint.point(k, ranges, run)?,
                y,
                check: run.role == RunRole::JointCheck(k),
            })
        })
        .collect();
    let designs = fit_surrogates(study, sim, &bounds, &runs)
        .into_iter()
        .map(|d| {
            d.map_err(|(name, e)| {
                Error::Failed(format!(
                    "hypothesis '{}', design `{name}`: cannot fit the surrogate over the joint space: {e}",
                    hypothesis.name
                ))
            })
        })
        .collect::<Result<Vec<DesignSurrogate>, Error>>()?;
    let worst_check = designs
        .iter()
        .filter_map(|d| d.check.max_relative_error)
        .fold(None, |w: Option<f64>, e| Some(w.map_or(e, |w| w.max(e))));
    let data = emulator_data(&runs);
    let joint_runs = runs
        .iter()
        .filter(|r| matches!(r.run.role, RunRole::Joint(_) | RunRole::JointCheck(_)));
    let planned = joint_runs.clone().count();
    Ok(ExtendedModel {
        checked: !joint.unchecked.contains(&k),
        running: joint.running.contains(&k),
        hypothesis: k,
        study: extended,
        surrogates: SurrogateModel { designs },
        data,
        runs: LoopRuns {
            planned,
            succeeded: joint_runs.filter(|r| r.y.is_some()).count(),
            samples_per_design: samples_per_design(study, sim, bounds.dim(), &runs),
            surrogate_check_error: worst_check,
            checked: !joint.unchecked.contains(&k),
        },
    })
}

/// Runs per design the joint surrogates were fitted to (check runs not counted): the fixed design's
/// size, or with sequential sampling the most any design got (its probes and the baseline's runs at
/// the joint space's edge included).
fn samples_per_design(study: &Study, sim: &SolverSimulation, dim: usize, runs: &[FitRun]) -> usize {
    if sim.sampling.sequential.is_none() {
        return crate::plan::sweep::joint_samples(study, sim, dim);
    }
    let mut per: indexmap::IndexMap<&str, usize> = indexmap::IndexMap::new();
    for r in runs.iter().filter(|r| !r.check && r.y.is_some()) {
        *per.entry(r.run.design.as_str()).or_insert(0) += 1;
    }
    per.values().copied().max().unwrap_or(0)
}

/// The study whose parameters are θ and hypothesis `k`'s ranged variables, and whose hypotheses
/// are the study's terms (what may still be missing from the extended model).
fn extended_study(study: &Study, k: usize) -> Study {
    let mut extended = study.clone();
    extended
        .parameters
        .extend(study.diagnosis.hypotheses[k].ranges().iter().cloned());
    extended
        .diagnosis
        .hypotheses
        .retain(|h| matches!(h.kind, HypothesisKind::Term(_)));
    // A term reads its values by position (design variables, parameters, constants, y): compiled
    // for the study's parameters, it must be compiled again for the enlarged set, or it would read
    // an extension variable where a constant or y stands.
    let symbols = extended.term_symbols();
    for h in &mut extended.diagnosis.hypotheses {
        if let HypothesisKind::Term(expr) = &h.kind {
            let again = crate::study::Expression::compile(expr.text(), &symbols).expect("compiled for fewer symbols");
            h.kind = HypothesisKind::Term(again);
        }
    }
    extended.calibration.splits.clear();
    extended
}

/// The extended model as the diagnosis sees it ([`diagnose::LoopModel`]): the extended study's
/// terms as candidates, and the other extension hypotheses' screening effects (`extensions`, the
/// surrogates of their screening runs, over θ) beside them, so that each can be tested with this
/// model as the base.
pub fn loop_model<'m>(
    study: &Study,
    m: &'m ExtendedModel,
    baseline: &std::sync::Arc<dyn Model + Send>,
    extensions: &[(usize, std::sync::Arc<dyn Model + Send>)],
) -> diagnose::LoopModel<'m> {
    let mut inputs = diagnose::inputs_from_study(&m.study, &m.surrogates);
    let at = inputs.observations.iter().map(|o| (o.design.as_slice(), o.mean));
    inputs.emulator = crate::emulate::Uncertainty::of_surrogates(&m.surrogates, at);
    // The library search runs once, on the final decision (from the screening's inputs).
    inputs.library = None;
    let p = study.parameters.len();
    for (j, ext) in extensions.iter().filter(|(j, _)| *j != m.hypothesis) {
        let h = &study.diagnosis.hypotheses[*j];
        let variables = h.extension().unwrap_or_default();
        inputs.hypotheses.push(diagnose::Shape::effect(
            h.name.clone(),
            variables,
            ext.clone(),
            baseline.clone(),
            p,
        ));
    }
    diagnose::LoopModel {
        hypothesis: study.diagnosis.hypotheses[m.hypothesis].name.clone(),
        inputs,
        checked: m.checked,
        running: m.running,
        refit: None,
    }
}

/// Calibrates an extended model with the study's methods, and records it with its own diagnosis
/// (`own`, what it leaves unexplained) against the final one (`baseline`).
pub fn assess(
    study: &Study,
    m: &ExtendedModel,
    baseline: &Diagnosis,
    own: &Diagnosis,
) -> Result<SolverExtension, Error> {
    // Least squares only: the extended model's uncertainty is the diagnosis's (its fit to the
    // tests with the loop's emulator); a second Bayesian run over θ × the extension would repeat
    // it at many times the cost.
    let mut only_ls = m.study.clone();
    only_ls.calibration.methods = vec![crate::calibrate::Method::LeastSquares];
    let s = &only_ls;
    let model = &m.surrogates as &dyn Model;
    let calibration = calibrate(s, &problem(s, model), Some(&m.data));
    let diagnosis = own;
    let hypothesis = &study.diagnosis.hypotheses[m.hypothesis];
    let extension = hypothesis.extension_spec().expect("chosen: an extension");
    let variables = extension
        .ranges
        .iter()
        .map(|r| {
            let range = VariableRange {
                min: r.min,
                max: r.max,
                unit: r.unit.clone(),
            };
            (r.name.clone(), range)
        })
        .collect();
    let fixed = extension
        .screening
        .iter()
        .filter(|(n, _)| !extension.ranges.iter().any(|r| &r.name == n))
        .cloned()
        .collect();
    let names: Vec<String> = s.parameters.iter().map(|p| p.name.clone()).collect();
    let calibrated = Calibrated {
        methods: calibration
            .methods
            .iter()
            .map(|(method, outcome)| (method.key().to_string(), MethodEstimate::of(&names, outcome)))
            .collect(),
        identifiable: calibration.identifiability.identifiable,
        identifiability: calibration.identifiability.note.clone(),
    };
    Ok(SolverExtension::assess(
        &hypothesis.name,
        variables,
        fixed,
        m.runs.clone(),
        calibrated,
        baseline,
        diagnosis,
    ))
}
