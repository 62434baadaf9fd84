//! The sweep of a solver study: every planned run rendered, keyed, and — unless the store already
//! holds its success — run by the [`Executor`], its progress shown by the caller's display.
//!
//! ```text
//! Plan ──render──► Prepared {key per planned run, inputs per key} ──store.prepare──► RunSpec
//!      ──Executor──► RunRecord (committed) ──► responses per planned run
//! ```
//!
//! Keys are computed from the rendered bytes before anything is written, so a finished run is
//! found again without touching the disk, and editing a template changes exactly the keys whose
//! rendered inputs change. Planned runs with equal inputs share one key and one run.
//!
//! # Design note
//!
//! **States of a planned run in a sweep.** rendered (in memory, keyed) → *finished earlier*
//! (a success in the store: reused, not touched) or → prepared (directory written) → executed by
//! one of three sources — the local [`Executor`], Slurm jobs ([`run_slurm`]) or a recording
//! ([`replay_runs`]: judged by the same adapter, no solver) → committed record → response. The
//! [`SweepResult`] is read back from the store's records in plan order, so what the pipeline fits
//! is exactly what is on disk, whichever source ran the runs.
//!
//! **Invariants.** Nothing is written before every planned run has rendered (a template error
//! leaves the output directory as it was). Meshes are written once, named by the hash of their
//! bytes, before any run that includes them. A local sweep refuses to start while the Slurm
//! journal lists runs of this output directory (they belong to jobs; `--executor slurm`
//! re-attaches). Signals ([`Signals`]) cancel the sweep; after the sweep a signal ends `lab` at
//! once (exit 130), since nothing after it needs cleaning up.
//!
//! **What a kill leaves.** What the store and the executor say: committed records, and run
//! directories without a record that the next `lab run` redoes; a replayed run is committed or
//! not, never half-replayed. Written meshes are complete (atomic writes) and reused.
//!
//! **Why.** Keys from rendered bytes make the three sources interchangeable and a replay exact to
//! the bit; reading responses back from the records (not from what this pass saw) makes a resumed
//! sweep and a fresh one give the same numbers.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use tokio::sync::mpsc;

use super::adapter::judge_outputs;
use super::quality::{Flag, Quality};
use super::replay::{self, InputDigest, Manifest};
use super::store::{RUNS_DIR, run_key, write_atomic};
use super::{Adapter, CancelReason, Canceller, Executor, OutcomeClass, RunRecord, RunSpec, RunStore, now_ms, progress};
use crate::error::{Error, InputError};
use crate::plan::Plan;
use crate::render::mesh::{self, TubeSpec};
use crate::render::{self, Inputs};
use crate::study::settings::Gates;
use crate::study::{QualitySettings, SolverSimulation, Study};

/// Directory (under `--out`) of the generated meshes, one file per design, named by content.
pub const MESHES_DIR: &str = "meshes";

/// The run of every planned run, rendered in memory.
pub struct Prepared {
    /// The key of each planned run, in plan order.
    pub keys: Vec<String>,
    /// The inputs of each distinct key.
    pub inputs: BTreeMap<String, Inputs>,
    /// Generated meshes: path relative to `--out` → bytes (written once, shared by a design's runs).
    pub meshes: BTreeMap<PathBuf, Vec<u8>>,
    /// The mesh each planned run includes (path relative to `--out`), in plan order.
    pub run_mesh: Vec<Option<PathBuf>>,
    /// Each design's mesh (path relative to `--out`).
    pub design_mesh: BTreeMap<String, PathBuf>,
}

impl Prepared {
    /// `more`'s runs after these (a later batch rendered apart).
    pub fn append(&mut self, more: Prepared) {
        self.keys.extend(more.keys);
        self.inputs.extend(more.inputs);
        self.meshes.extend(more.meshes);
        self.run_mesh.extend(more.run_mesh);
        self.design_mesh.extend(more.design_mesh);
    }
}

/// A study's solver as the run engine drives it: its settings and the adapter that judges its runs
/// (made by the extract stage, which knows every adapter: `crate::extract::adapters::solver`).
#[derive(Clone)]
pub struct Solver<'s> {
    pub sim: &'s SolverSimulation,
    pub adapter: Arc<dyn Adapter>,
}

/// Renders every planned run and computes its key. Template errors name the template and line.
///
/// With `simulation.mesh`, each design's mesh is generated once, named by the hash of its bytes
/// (`meshes/<design>-<hash>.k` under `--out`) and given to the templates as `mesh_file`, the path
/// from the run directory (`../../meshes/...`): the deck's text, hence the run key, changes
/// exactly when the mesh's bytes do.
pub fn prepare(study: &Study, solver: &Solver, plan: &Plan) -> Result<Prepared, Error> {
    prepare_after(study, solver, plan, None)
}

/// [`prepare`], taking the meshes an `earlier` preparation of the same study generated (the loop's
/// runs after the screening's: a design's mesh depends on the design alone).
pub fn prepare_after(
    study: &Study,
    solver: &Solver,
    plan: &Plan,
    earlier: Option<&Prepared>,
) -> Result<Prepared, Error> {
    let sim = solver.sim;
    let renderer = sim.inputs.renderer()?;
    let identity = solver.adapter.identity();
    let mut prepared = Prepared {
        keys: Vec::with_capacity(plan.runs.len()),
        inputs: BTreeMap::new(),
        meshes: earlier.map(|e| e.meshes.clone()).unwrap_or_default(),
        run_mesh: Vec::with_capacity(plan.runs.len()),
        design_mesh: earlier.map(|e| e.design_mesh.clone()).unwrap_or_default(),
    };
    if let Some(spec) = &sim.inputs.mesh {
        for (design, path, text) in new_meshes(spec, plan, &prepared.design_mesh)? {
            prepared.meshes.insert(path.clone(), text);
            prepared.design_mesh.insert(design, path);
        }
    }
    let includes = deck_includes(sim, &mut prepared.meshes);
    for run in &plan.runs {
        let mut context = render::run_context(study, run);
        if let Some(variable) = sim.inputs.seeds.as_ref().and_then(|s| s.variable.as_ref()) {
            context.insert(variable.clone(), &(run.seed + 1));
        }
        let mut mesh_path = prepared.design_mesh.get(&run.design).cloned();
        if let Some(path) = &mesh_path {
            context.insert("mesh_file", &format!("../../{}", path.display()));
        }
        for (key, design, path) in includes
            .iter()
            .filter(|i| i.1.as_ref().is_none_or(|d| *d == run.design))
        {
            context.insert(key.clone(), &format!("../../{}", path.display()));
            if design.is_some() {
                mesh_path = mesh_path.or(Some(path.clone()));
            }
        }
        prepared.run_mesh.push(mesh_path);
        let mut inputs =
            render::inputs(&renderer, &sim.inputs.files, &context).map_err(|e| with_run(e, &run.design))?;
        inputs.extend(nodal_noise_seed(sim, run).map(|s| (PathBuf::from(SEED_FILE), s.to_string().into_bytes())));
        let key = run_key(&inputs, &sim.execution.command, &identity);
        prepared.keys.push(key.clone());
        prepared.inputs.entry(key).or_insert(inputs);
    }
    Ok(prepared)
}

/// The deck's files a study writes once rather than into every run: each design's file of a
/// per-design include (`deck.per_design`), and every include no run changes
/// ([`crate::base::deck::Deck::shared`]); each named by the hash of its bytes under the meshes
/// directory (`meshes/<design>-<hash>-<name>`, `meshes/<hash>-<name>`) and added to `meshes`. Per
/// file: its context key, the design it belongs to (`None`: every design) and its path relative
/// to `--out`.
fn deck_includes(
    sim: &crate::study::SolverSimulation,
    meshes: &mut BTreeMap<PathBuf, Vec<u8>>,
) -> Vec<(String, Option<String>, PathBuf)> {
    use crate::base::deck::{include_key, shared_key};
    let Some(deck) = &sim.inputs.deck else {
        return Vec::new();
    };
    let mut add = |prefix: &str, name: &std::path::Path, bytes: &[u8], hash: &str| {
        let name = name.file_name().unwrap_or_default().to_string_lossy().into_owned();
        let path = PathBuf::from(MESHES_DIR).join(format!("{prefix}{}-{name}", &hash[..16]));
        meshes.entry(path.clone()).or_insert_with(|| bytes.to_vec());
        path
    };
    let mut out = Vec::new();
    for (k, p) in deck.per_design.iter().enumerate() {
        for (design, (_, bytes, hash)) in &p.files {
            let path = add(&format!("{design}-"), std::path::Path::new(&p.include), bytes, hash);
            out.push((include_key(k), Some(design.clone()), path));
        }
    }
    for &k in &deck.shared {
        let f = &deck.files[k];
        let path = add("", &f.output, f.source.as_bytes(), &f.hash);
        out.push((shared_key(k), None, path));
    }
    out
}

/// The meshes of the plan's designs not in `known`: (design, path, bytes), in plan order. Each
/// distinct tube is generated once (designs that differ only in a variable the mesh does not
/// read share the text), the distinct ones in parallel: the text of a fine tube is megabytes.
fn new_meshes(
    spec: &crate::study::MeshSpec,
    plan: &Plan,
    known: &BTreeMap<String, PathBuf>,
) -> Result<Vec<(String, PathBuf, Vec<u8>)>, Error> {
    use rayon::prelude::*;
    let mut designs: Vec<(&str, TubeSpec)> = Vec::new();
    for run in &plan.runs {
        if !known.contains_key(&run.design) && !designs.iter().any(|(d, _)| *d == run.design) {
            let tube = TubeSpec {
                cell: run.design_values[spec.cell_variable],
                diameter: spec.diameter,
                length: spec.length,
                element: spec.element_size,
            };
            designs.push((&run.design, tube));
        }
    }
    let mut tubes: Vec<TubeSpec> = Vec::new();
    for (_, tube) in &designs {
        if !tubes.contains(tube) {
            tubes.push(*tube);
        }
    }
    let texts: Vec<Result<(String, String), String>> = tubes
        .par_iter()
        .map(|tube| {
            let made = match spec.edge_set {
                Some(set) => mesh::include_with_edge_set(tube, set),
                None => mesh::include(tube),
            };
            let (text, _) = made.map_err(|e| e.to_string())?;
            let hash = blake3::hash(text.as_bytes()).to_hex().to_string();
            Ok((text, hash))
        })
        .collect();
    designs
        .into_iter()
        .map(|(design, tube)| {
            let at = tubes
                .iter()
                .position(|t| *t == tube)
                .expect("every design's tube was listed");
            let (text, hash) = texts[at]
                .as_ref()
                .map_err(|e| Error::Failed(format!("design `{design}`: {e}")))?;
            let path = PathBuf::from(MESHES_DIR).join(format!("{design}-{}.k", &hash[..16]));
            Ok((design.to_string(), path, text.clone().into_bytes()))
        })
        .collect()
}

/// Writes the generated meshes under `out` (skipping those already there: they are named by content).
pub fn write_meshes(out: &std::path::Path, prepared: &Prepared) -> Result<(), Error> {
    debug_assert!(RUNS_DIR != MESHES_DIR);
    for (rel, bytes) in &prepared.meshes {
        let path = out.join(rel);
        if path.is_file() {
            continue;
        }
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| Error::Failed(format!("{}: {e}", parent.display())))?;
        }
        write_atomic(&path, bytes).map_err(|e| Error::Failed(format!("{}: {e}", path.display())))?;
    }
    Ok(())
}

/// The manifest of planned run `i`: what a recording of it holds and what a miss compares.
pub fn manifest(study: &Study, solver: &Solver, plan: &Plan, prepared: &Prepared, i: usize) -> Result<Manifest, Error> {
    let run = &plan.runs[i];
    let key = &prepared.keys[i];
    let (sim, adapter) = (solver.sim, &solver.adapter);
    let inputs = prepared.inputs[key]
        .iter()
        .map(|(path, bytes)| (path.display().to_string(), InputDigest::of(bytes)))
        .collect();
    let shared = prepared.run_mesh[i]
        .iter()
        .map(|p| {
            let name = p.file_name().unwrap_or_default().to_string_lossy().into_owned();
            (name, blake3::hash(&prepared.meshes[p]).to_hex().to_string())
        })
        .collect();
    Ok(Manifest {
        key: key.clone(),
        design: run.design.clone(),
        role: run.role.key().to_string(),
        parameters: study.parameter_values(&run.theta),
        command: sim.execution.command.clone(),
        adapter: adapter.identity(),
        inputs,
        shared,
        outputs: adapter.outputs().iter().map(|p| p.display().to_string()).collect(),
        outcome: None,
    })
}

/// Copies every planned run with a record into `dir`, unless `dir` already holds it as it ended;
/// returns how many. A failed run is recorded too, with its outcome in the manifest: a replay then
/// fails it as the live run failed and plans around it as the live sequence did.
pub fn record(
    study: &Study,
    solver: &Solver,
    plan: &Plan,
    prepared: &Prepared,
    store: &RunStore,
    dir: &std::path::Path,
) -> Result<usize, Error> {
    let mut done = BTreeSet::new();
    for (i, key) in prepared.keys.iter().enumerate() {
        let Some(ended) = store.record(key) else { continue };
        let failure = (!ended.outcome.is_success()).then(|| ended.outcome.clone());
        let held = replay::find(dir, key).and_then(|at| replay::read_manifest(&at));
        if held.is_some_and(|m| m.outcome == failure) || !done.insert(key.clone()) {
            continue;
        }
        let mut m = manifest(study, solver, plan, prepared, i)?;
        m.outcome = failure;
        replay::record(dir, &store.run_dir(key), &m)
            .map_err(|e| Error::Failed(format!("recording run {key} into {}: {e}", dir.display())))?;
    }
    Ok(done.len())
}

/// What a replay made of the planned runs: the sweep, the runs without a recording (explained,
/// see [`replay::explain_miss`]) and the recordings of successful runs it could not read.
pub struct Replayed {
    pub swept: SweepResult,
    pub misses: Vec<String>,
    pub damaged: Vec<replay::Damaged>,
}

/// Serves every unfinished planned run from its recording in `dir` (no solver is started): the
/// recording is judged by the adapter as a live run's outputs would be, and the record committed;
/// the recording of a failed run commits its recorded outcome.
pub fn replay_runs(
    study: &Study,
    solver: &Solver,
    plan: &Plan,
    prepared: &Prepared,
    store: &mut RunStore,
    dir: &std::path::Path,
) -> Result<Replayed, Error> {
    let adapter = &solver.adapter;
    let reused = prepared.keys.iter().filter(|k| store.is_finished(k)).count();
    let mut misses = Vec::new();
    let mut recorded: Option<Vec<Manifest>> = None;
    let mut seen = BTreeSet::new();
    let mut found = Vec::new();
    for (i, key) in prepared.keys.iter().enumerate() {
        if store.is_finished(key) || !seen.insert(key.clone()) {
            continue;
        }
        match replay::find(dir, key) {
            Some(at) => found.push((i, at)),
            None => {
                let wanted = manifest(study, solver, plan, prepared, i)?;
                let all = recorded.get_or_insert_with(|| replay::manifests(dir));
                misses.push(replay::explain_miss(dir, &wanted, all));
            }
        }
    }
    // Judged in parallel (each in its own scratch directory), committed in plan order a batch at
    // a time: an interrupted replay keeps every batch committed before it.
    let mut damaged = Vec::new();
    for batch in found.chunks(REPLAY_BATCH) {
        use rayon::prelude::*;
        let records: Vec<Result<(RunRecord, bool), Error>> = batch
            .par_iter()
            .map(|(i, at)| replayed(adapter.as_ref(), store.out(), &prepared.inputs[&prepared.keys[*i]], at))
            .collect();
        for ((i, at), record) in batch.iter().zip(records) {
            let (record, recorded_failure) = record?;
            if !record.outcome.is_success() && !recorded_failure {
                let run = &plan.runs[*i];
                damaged.push(replay::Damaged {
                    key: record.key.clone(),
                    at: at.clone(),
                    design: run.design.clone(),
                    parameters: study.parameter_values(&run.theta),
                    outcome: record.outcome.clone(),
                });
            }
            store.commit(record)?;
        }
    }
    let _ = std::fs::remove_dir(store.out().join(REPLAY_SCRATCH)); // only succeeds when empty
    Ok(Replayed {
        swept: SweepResult::from_store(store, prepared, reused, Vec::new()),
        misses,
        damaged,
    })
}

/// The record a recording gives: its recorded failure as it is (`true`), else its outputs judged.
fn replayed(
    adapter: &dyn Adapter,
    out: &std::path::Path,
    inputs: &Inputs,
    at: &std::path::Path,
) -> Result<(RunRecord, bool), Error> {
    let key = at.file_name().unwrap_or_default().to_string_lossy();
    match replay::read_manifest(at).and_then(|m| m.outcome) {
        Some(failed) => Ok((RunRecord::ended(&key, failed, 1, now_ms(), None), true)),
        None => Ok((judge_recording(adapter, out, &key, inputs, at)?, false)),
    }
}

/// Every recording in `dir` of a run that succeeded, except `skip`'s, judged by `adapter` from the
/// inputs its manifest keeps: those it cannot read as finished runs. A recording whose inputs the
/// manifest does not keep whole is not judged.
pub fn damaged_recordings(
    adapter: &dyn Adapter,
    out: &std::path::Path,
    dir: &std::path::Path,
    skip: &BTreeSet<String>,
) -> Vec<replay::Damaged> {
    use rayon::prelude::*;
    let manifests: Vec<Manifest> = replay::manifests(dir)
        .into_iter()
        .filter(|m| m.outcome.is_none() && !skip.contains(&m.key))
        .collect();
    let damaged = manifests
        .par_iter()
        .filter_map(|m| {
            let inputs: Option<Inputs> = m
                .inputs
                .iter()
                .map(|(path, d)| d.text.as_ref().map(|t| (PathBuf::from(path), t.clone().into_bytes())))
                .collect();
            let at = dir.join(&m.key);
            let record = judge_recording(adapter, out, &m.key, &inputs?, &at).ok()?;
            (!record.outcome.is_success()).then(|| replay::Damaged {
                key: m.key.clone(),
                at,
                design: m.design.clone(),
                parameters: m.parameters.clone(),
                outcome: record.outcome,
            })
        })
        .collect();
    let _ = std::fs::remove_dir(out.join(REPLAY_SCRATCH)); // only succeeds when empty
    damaged
}

/// Recordings judged at once between two commits.
const REPLAY_BATCH: usize = 32;

/// A recording judged by the adapter as a live run's outputs would be: the record to commit.
fn judge_recording(
    adapter: &dyn Adapter,
    out: &std::path::Path,
    key: &str,
    inputs: &Inputs,
    recording: &std::path::Path,
) -> Result<RunRecord, Error> {
    let started = now_ms();
    let scratch = judging_dir(out, key, inputs, recording)?;
    let (outcome, judged) = judge_outputs(adapter, &scratch.0);
    Ok(RunRecord::ended(key, outcome, 1, started, judged))
}

/// Directory (under `--out`) where a replayed run is judged, then removed.
pub const REPLAY_SCRATCH: &str = ".replay";

/// A scratch directory laid out as a live run's: the run's rendered inputs (the deck the adapter
/// reads its output intervals from) and the recording's outputs, copied. Removed after judging
/// ([`ScratchDir`]), so a replay leaves no run directory behind.
fn judging_dir(
    out: &std::path::Path,
    key: &str,
    inputs: &Inputs,
    recording: &std::path::Path,
) -> Result<ScratchDir, Error> {
    let dir = out.join(REPLAY_SCRATCH).join(key);
    let fail = |p: &std::path::Path, e: std::io::Error| Error::Failed(format!("{}: {e}", p.display()));
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| fail(&dir, e))?;
    }
    let scratch = ScratchDir(dir.clone());
    for (rel, bytes) in inputs {
        if !rel.components().all(|c| matches!(c, std::path::Component::Normal(_))) {
            continue; // refused by RunStore::prepare for live runs as well
        }
        let path = dir.join(rel);
        std::fs::create_dir_all(path.parent().unwrap_or(&dir)).map_err(|e| fail(&path, e))?;
        std::fs::write(&path, bytes).map_err(|e| fail(&path, e))?;
    }
    std::fs::create_dir_all(&dir).map_err(|e| fail(&dir, e))?;
    for entry in std::fs::read_dir(recording).map_err(|e| fail(recording, e))? {
        let entry = entry.map_err(|e| fail(recording, e))?;
        if entry.file_name() == replay::MANIFEST || !entry.path().is_file() {
            continue;
        }
        std::fs::copy(entry.path(), dir.join(entry.file_name())).map_err(|e| fail(&entry.path(), e))?;
    }
    Ok(scratch)
}

/// A directory removed when dropped (its parent, shared by the recordings judged at once, is
/// removed by [`replay_runs`] at the end).
struct ScratchDir(PathBuf);

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn with_run(mut e: InputError, design: &str) -> InputError {
    e.message = format!("{} (rendering design `{design}`)", e.message);
    e
}

/// Signal handling for the whole of `lab run`: during the sweep a signal cancels it (a second one
/// kills the children at once); after the sweep (fitting, calibrating) a signal exits 130 at once,
/// since tokio's handler replaces the default action for the rest of the process.
pub struct Signals {
    pub canceller: Canceller,
    after_sweep: Arc<AtomicBool>,
    /// Whether the first signal was SIGINT (Ctrl-C) rather than SIGTERM.
    first_was_interrupt: Arc<AtomicBool>,
}

impl Signals {
    /// Installs the handlers; must be called inside `runtime`.
    pub fn install(runtime: &tokio::runtime::Runtime) -> Result<Signals, Error> {
        use tokio::signal::unix::{SignalKind, signal};
        let _guard = runtime.enter();
        let mut term = signal(SignalKind::terminate())?;
        let mut int = signal(SignalKind::interrupt())?;
        let canceller = Canceller::new();
        let after_sweep = Arc::new(AtomicBool::new(false));
        let first_was_interrupt = Arc::new(AtomicBool::new(false));
        let (c, after, first) = (canceller.clone(), after_sweep.clone(), first_was_interrupt.clone());
        runtime.spawn(async move {
            let mut reason = CancelReason::Signal;
            loop {
                let interrupt = tokio::select! {
                    _ = term.recv() => false,
                    _ = int.recv() => true,
                };
                if reason == CancelReason::Signal {
                    first.store(interrupt, Ordering::SeqCst);
                }
                if after.load(Ordering::SeqCst) {
                    eprintln!("\ninterrupted");
                    std::process::exit(130);
                }
                c.cancel(reason);
                reason = CancelReason::SecondSignal;
            }
        });
        Ok(Signals {
            canceller,
            after_sweep,
            first_was_interrupt,
        })
    }

    /// From now on a signal exits 130 at once.
    pub fn sweep_done(&self) {
        self.after_sweep.store(true, Ordering::SeqCst);
    }

    pub fn interrupted(&self) -> bool {
        self.canceller.reason().is_some_and(|r| r >= CancelReason::Signal)
    }

    /// Whether the sweep was stopped by Ctrl-C (SIGINT), not SIGTERM: only then is a person asked.
    pub fn by_ctrl_c(&self) -> bool {
        self.interrupted() && self.first_was_interrupt.load(Ordering::SeqCst)
    }
}

/// What the sweep left in the store for the plan.
pub struct SweepResult {
    /// The response of each planned run (plan order); `None` when it has no successful record.
    pub responses: Vec<Option<f64>>,
    /// Outcome class of each planned run's record, if any.
    pub classes: Vec<Option<OutcomeClass>>,
    /// Each planned run's sanity figures (glstat energies), when its record has them.
    pub quality: Vec<Option<Quality>>,
    /// Planned runs that were finished before this pass.
    pub reused: usize,
    /// Errors not tied to a run's outcome (a record that could not be committed).
    pub errors: Vec<String>,
}

impl SweepResult {
    /// `more`'s runs after these (a later batch swept apart).
    pub fn append(&mut self, more: SweepResult) {
        self.responses.extend(more.responses);
        self.classes.extend(more.classes);
        self.quality.extend(more.quality);
        self.reused += more.reused;
        self.errors.extend(more.errors);
    }

    /// Every planned run's record as the store holds it, nothing run (`reused`: the finished ones).
    pub fn recorded(store: &RunStore, prepared: &Prepared) -> SweepResult {
        let reused = prepared.keys.iter().filter(|k| store.is_finished(k)).count();
        SweepResult::from_store(store, prepared, reused, Vec::new())
    }

    /// Every planned run's response and outcome class as the store now holds them, in plan order.
    fn from_store(store: &RunStore, prepared: &Prepared, reused: usize, errors: Vec<String>) -> SweepResult {
        let records: Vec<Option<&RunRecord>> = prepared.keys.iter().map(|k| store.record(k)).collect();
        SweepResult {
            responses: records.iter().map(|r| r.and_then(|r| r.response)).collect(),
            classes: records.iter().map(|r| r.map(|r| r.outcome.class())).collect(),
            quality: records.iter().map(|r| r.and_then(|r| r.quality)).collect(),
            reused,
            errors,
        }
    }

    /// The gates each planned run breaks (empty: sound, failed, or no figures to check).
    pub fn flags(&self, gates: &Gates) -> Vec<Vec<Flag>> {
        self.responses
            .iter()
            .zip(&self.quality)
            .map(|(y, q)| match (y, q) {
                (Some(_), Some(q)) => gates.flags(q),
                _ => Vec::new(),
            })
            .collect()
    }

    /// The responses the surrogates are fitted to: a suspect run's is left out unless the study
    /// says `quality.suspect: use`.
    pub fn usable(&self, settings: &QualitySettings) -> Vec<Option<f64>> {
        let flags = self.flags(&settings.gates);
        self.responses
            .iter()
            .zip(&flags)
            .map(|(y, f)| if f.is_empty() || settings.use_suspect { *y } else { None })
            .collect()
    }
}

/// Runs every planned run that has no success in the store, `jobs` at once. `display` gives the
/// display of the runs to do (the caller's reporter decides how progress is shown); the
/// executor's events drive it.
pub fn run(
    runtime: &tokio::runtime::Runtime,
    store: &mut RunStore,
    solver: &Solver,
    prepared: &Prepared,
    jobs: usize,
    canceller: &Canceller,
    display: &mut dyn FnMut(u64) -> indicatif::ProgressBar,
) -> Result<SweepResult, Error> {
    let submitted = super::slurm::journal(store.out());
    if !submitted.is_empty() {
        let ids: Vec<String> = submitted.iter().filter_map(|j| j.job_id.clone()).collect();
        return Err(Error::Failed(format!(
            "{} run(s) of {} are submitted to Slurm (job(s) {}): `lab run --executor slurm` re-attaches to them",
            submitted.iter().map(|j| j.keys.len()).sum::<usize>(),
            store.out().display(),
            ids.join(", ")
        )));
    }
    let reused = prepared.keys.iter().filter(|k| store.is_finished(k)).count();
    let mut specs = Vec::new();
    let mut seen = BTreeSet::new();
    for key in &prepared.keys {
        if store.is_finished(key) || !seen.insert(key.clone()) {
            continue;
        }
        let dir = store.prepare(key, &prepared.inputs[key])?;
        specs.push(spec(solver, key, dir));
    }
    let (tx, rx) = mpsc::unbounded_channel();
    let mut executor = Executor::new(jobs, solver.adapter.clone(), store.committer());
    executor.chain = solver.adapter.chain();
    executor.canceller = canceller.clone();
    executor.events = Some(tx);
    let bar = display(specs.len() as u64);
    let summary = runtime.block_on(async move {
        let reporter = tokio::spawn(progress::report(rx, bar));
        let summary = executor.run(specs).await;
        drop(executor); // closes the event channel: the reporter finishes
        let _ = reporter.await;
        summary
    });
    for record in summary.records {
        store.remember(record);
    }
    Ok(SweepResult::from_store(store, prepared, reused, summary.errors))
}

/// An input of an OpenRadioss run at a seed of its nodal noise other than the study's
/// (`simulation.seeds` without a variable): the seed its starter is given (`-rseed`). An input, so
/// that it is in the run's key and in the run directory a Slurm job reads.
pub const SEED_FILE: &str = "lab-rseed";

/// The nodal noise's seed of an OpenRadioss run at a seed other than the first (see [`SEED_FILE`]).
fn nodal_noise_seed(sim: &SolverSimulation, run: &crate::plan::PlannedRun) -> Option<f64> {
    sim.inputs
        .seeds
        .as_ref()
        .filter(|s| s.variable.is_none() && run.seed > 0)?;
    sim.openradioss.as_ref()?.seed(run.seed)
}

/// The argv of the run in `dir`: the study's command, with the run's own `-rseed` where its
/// inputs hold one ([`SEED_FILE`]).
fn argv(sim: &SolverSimulation, dir: &std::path::Path) -> Vec<String> {
    let mut argv = sim.execution.command.clone();
    // Only a study whose seeds are the starter's looks for the file (no I/O for the others).
    if sim.inputs.seeds.as_ref().is_none_or(|s| s.variable.is_some()) {
        return argv;
    }
    let at = argv.iter().position(|a| a == "-rseed").filter(|i| i + 1 < argv.len());
    if let (Ok(seed), Some(i)) = (std::fs::read_to_string(dir.join(SEED_FILE)), at) {
        argv[i + 1] = seed.trim().to_string();
    }
    argv
}

/// What the executor runs for the run `key` in `dir` (written: its argv may depend on its inputs).
pub fn spec(solver: &Solver, key: &str, dir: PathBuf) -> RunSpec {
    RunSpec {
        key: key.to_string(),
        argv: argv(solver.sim, &dir),
        dir,
        timeout: solver.sim.execution.timeout,
        outputs: solver.adapter.cleared(),
        retry: solver.sim.execution.retry.clone(),
    }
}

/// `lab run --executor slurm`: the sweep submitted to Slurm (see [`super::slurm`]).
pub fn run_slurm(
    store: &mut RunStore,
    study: &Study,
    sim: &SolverSimulation,
    prepared: &Prepared,
    signals: &Signals,
) -> Result<SweepResult, Error> {
    let reused = prepared.keys.iter().filter(|k| store.is_finished(k)).count();
    let settings = sim.execution.slurm.clone().unwrap_or_default();
    let study_path =
        std::fs::canonicalize(&study.path).map_err(|e| Error::Failed(format!("{}: {e}", study.path.display())))?;
    let mut distinct: Vec<String> = Vec::new();
    for key in &prepared.keys {
        if !distinct.contains(key) {
            distinct.push(key.clone());
        }
    }
    let out = store.out().to_path_buf();
    let prepare = |key: &str| -> Result<(), Error> { store_prepare(&out, key, &prepared.inputs[key]) };
    let summary = super::slurm::run(&settings, &study_path, store, &distinct, &signals.canceller, &prepare)?;
    if !summary.left_running.is_empty() {
        leave_or_cancel(store, study, signals, &summary.left_running)?;
    }
    Ok(SweepResult::from_store(store, prepared, reused, summary.errors))
}

/// After an interrupt with jobs still queued or running: asks a person at a terminal whether to
/// cancel them (Ctrl-C only); otherwise leaves them and says how to re-attach.
fn leave_or_cancel(store: &mut RunStore, study: &Study, signals: &Signals, ids: &[String]) -> Result<(), Error> {
    use super::slurm::interrupt::{self, Answer};
    let answer = if signals.by_ctrl_c() && interrupt::interactive() {
        let second = || signals.canceller.reason() == Some(CancelReason::SecondSignal);
        let input = std::io::BufReader::new(std::io::stdin());
        interrupt::ask(ids.len(), input, interrupt::QUESTION_TIMEOUT, &second)
    } else {
        Answer::Leave
    };
    let again = interrupt::reattach_command(&study.path, store.out());
    match answer {
        Answer::Leave => eprintln!(
            "left {} Slurm job(s) queued or running ({}). Re-attach with:\n  {again}\n(`scancel {}` cancels them)",
            ids.len(),
            ids.join(", "),
            ids.join(" ")
        ),
        Answer::Cancel => {
            let out = store.out().to_path_buf();
            eprintln!("cancelling Slurm job(s) {} with scancel...", ids.join(", "));
            match interrupt::cancel(&out, store) {
                Ok(done) => eprintln!(
                    "cancelled {} Slurm job(s): {} run(s) marked cancelled, {} run record(s) kept; \
                     `{again}` runs the rest",
                    done.jobs.len(),
                    done.cancelled_runs,
                    done.kept_runs
                ),
                // Still an interrupt (exit 130): what is left is journaled and re-attached to.
                Err(e) => eprintln!("error: {e}\nRe-attach with:\n  {again}"),
            }
        }
    }
    Ok(())
}

/// [`RunStore::prepare`] without the store (the store is borrowed by the Slurm pass).
fn store_prepare(out: &std::path::Path, key: &str, inputs: &Inputs) -> Result<(), Error> {
    let dir = out.join(super::store::RUNS_DIR).join(key);
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| Error::Failed(format!("{}: {e}", dir.display())))?;
    }
    for (rel, bytes) in inputs {
        let path = dir.join(rel);
        std::fs::create_dir_all(path.parent().unwrap_or(&dir))
            .map_err(|e| Error::Failed(format!("{}: {e}", path.display())))?;
        std::fs::write(&path, bytes).map_err(|e| Error::Failed(format!("{}: {e}", path.display())))?;
    }
    Ok(())
}

/// `lab slurm-worker`: inside a Slurm job, runs `keys` of the study in OUT/runs with the local
/// executor (`jobs` at once) and commits their records; the submitting lab collects them.
pub fn worker(
    _study: &Study,
    solver: &Solver,
    out: &std::path::Path,
    jobs: usize,
    keys: &[String],
) -> Result<i32, Error> {
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    let committer = super::store::Committer::new(out.join(super::store::RESULTS_DIR));
    let specs = keys
        .iter()
        .map(|k| spec(solver, k, out.join(super::store::RUNS_DIR).join(k)))
        .collect::<Vec<RunSpec>>();
    let mut executor = Executor::new(jobs, solver.adapter.clone(), committer);
    executor.chain = solver.adapter.chain();
    let summary = runtime.block_on(executor.run(specs));
    for r in &summary.records {
        println!("{} {}", r.key, r.outcome);
    }
    if !summary.errors.is_empty() {
        return Err(Error::Failed(summary.errors.join("\n")));
    }
    Ok(0)
}
