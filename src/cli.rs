//! The command line (contract: `lab run | check | status | report`). Errors are printed here, once,
//! and mapped to the contract's exit codes: 0 done, 1 runs or numerics failed, 2 invalid input or
//! usage, 130 interrupted.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Parser, Subcommand, ValueEnum};

use std::collections::BTreeMap;

use crate::calibrate::Model;
use crate::error::{Error, InputError};
use crate::execute::store::Snapshot;
use crate::execute::sweep::{self, Signals};
use crate::execute::{OutcomeClass, RunStore, lock, progress};
use crate::pipeline;
use crate::plan::Plan;
use crate::report::data::ReportData;
use crate::report::{self, Results};
use crate::study::{self, Simulation, SolverSimulation, Study};

#[derive(Parser, Debug)]
#[command(name = "lab", version, about = "Calibrate simulation models against tests")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Plan, run (or replay) the simulations, calibrate, diagnose; write results.json and report.html.
    Run {
        study: PathBuf,
        /// Output directory [default: lab-out/<study name> beside the study file].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Simulations run at once [default: number of cores].
        #[arg(long)]
        jobs: Option<usize>,
        #[arg(long, value_enum, default_value_t = Executor::Local)]
        executor: Executor,
        /// Serve runs from recordings in DIR instead of starting the solver.
        #[arg(long, value_name = "DIR")]
        replay: Option<PathBuf>,
        /// Copy each finished run's outputs into DIR.
        #[arg(long, value_name = "DIR")]
        record: Option<PathBuf>,
    },
    /// Validate the study and everything it references, without running anything.
    Check { study: PathBuf },
    /// Counts of the study's runs: done / failed / running / pending.
    Status {
        study: PathBuf,
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Mean crush force (energy / stroke) of a test machine's force–displacement CSV.
    Extract {
        /// CSV with displacement [mm] and force [kN or N] columns.
        curve: PathBuf,
        /// Stroke window `S0:S1` in mm.
        #[arg(long, default_value = "5:60")]
        window: String,
    },
    /// Inside a Slurm job: run the given runs of the study and commit their records (internal).
    #[command(hide = true)]
    SlurmWorker {
        #[arg(long)]
        study: PathBuf,
        #[arg(long)]
        out: PathBuf,
        #[arg(long, default_value_t = 1)]
        jobs: usize,
        keys: Vec<String>,
    },
    /// Rewrite the report from what is recorded.
    Report {
        study: PathBuf,
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Executor {
    Local,
    Slurm,
}

/// Parses the arguments, runs the command, prints any error once; returns the exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            // clap: 0 for --help/--version, 2 for usage errors — as the contract wants.
            return e.exit_code();
        }
    };
    match execute(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

fn execute(command: Command) -> Result<i32, Error> {
    match command {
        Command::Run {
            study,
            out,
            executor,
            jobs,
            replay,
            record,
        } => {
            let started = Instant::now();
            let study = study::load(&study)?;
            if replay.is_some() && record.is_some() {
                return Err(Error::Input(InputError::file(
                    &study.path,
                    "--replay and --record together: a replay starts no solver, so there is nothing new to record",
                )));
            }
            let out = out_dir(&study, out);
            if let Simulation::Expression(_) = &study.simulation
                && (replay.is_some() || record.is_some())
            {
                eprintln!(
                    "note: `{}` has a closed-form simulation; nothing to record or replay",
                    study.name
                );
            }
            match &study.simulation {
                Simulation::Expression(_) => {
                    if executor == Executor::Slurm {
                        eprintln!(
                            "note: `{}` has a closed-form simulation; nothing to submit to Slurm",
                            study.name
                        );
                    }
                    run(&study, &out, started)
                }
                Simulation::Solver(sim) => {
                    let modes = Modes {
                        replay: replay_dir(sim, replay),
                        record,
                        slurm: executor == Executor::Slurm,
                    };
                    run_solver(&study, sim, &out, jobs.unwrap_or_else(default_jobs), &modes, started)
                }
            }
        }
        Command::SlurmWorker { study, out, jobs, keys } => {
            let study = study::load(&study)?;
            let Simulation::Solver(sim) = &study.simulation else {
                return Err(Error::Failed("slurm-worker: not a solver study".into()));
            };
            sweep::worker(&study, sim, &out, jobs, &keys)
        }
        Command::Check { study } => {
            let study = study::load(&study)?;
            if let Simulation::Solver(sim) = &study.simulation {
                // Renders every planned run in memory: undefined template variables show up here.
                let plan = Plan::new(&study, sim);
                sweep::prepare(&study, sim, &plan)?;
                println!("ok: {} planned solver run(s) render", plan.runs.len());
            }
            println!(
                "ok: study `{}`: {} design variable(s), {} parameter(s), {} tested design(s), {} training, {} validation",
                study.name,
                study.design.len(),
                study.parameters.len(),
                study.experiments.designs.len(),
                study.training.len(),
                study.validation.len()
            );
            let curves = &study.experiments.curves;
            if !curves.is_empty() {
                println!(
                    "ok: {} force-displacement curve(s) of {} design(s) read",
                    curves.iter().map(|c| c.specimens.len()).sum::<usize>(),
                    curves.len()
                );
            }
            Ok(0)
        }
        Command::Status { study, out } => {
            let study = study::load(&study)?;
            let Simulation::Solver(sim) = &study.simulation else {
                println!(
                    "study `{}`: closed-form simulation, no solver runs (done 0, failed 0, running 0, pending 0)",
                    study.name
                );
                return Ok(0);
            };
            status(&study, sim, &out_dir(&study, out))
        }
        Command::Extract { curve, window } => {
            use crate::extract::crush;
            let bad = || InputError::file(&curve, format!("--window `{window}`: give S0:S1 in mm, e.g. 5:60"));
            let (a, b) = window.split_once(':').ok_or_else(bad)?;
            let (s0, s1) = (
                a.trim().parse::<f64>().map_err(|_| bad())?,
                b.trim().parse::<f64>().map_err(|_| bad())?,
            );
            let data = crush::read_test_csv(&curve, crush::CsvOptions::default())?;
            let r = crush::crush_force(&data, crush::Window { s0, s1 })
                .map_err(|e| InputError::file(&curve, e.to_string()))?;
            println!(
                "mean crush force {} kN over {s0}-{s1} mm (energy {} J, peak {} kN at {} mm)",
                r.mean_force, r.energy, r.peak_force, r.peak_at
            );
            Ok(0)
        }
        Command::Report { study, out } => {
            let study = study::load(&study)?;
            let dir = out_dir(&study, out);
            let results = Results::read(&dir.join("results.json")).map_err(|e| {
                Error::Failed(format!(
                    "{}: {e} (run `lab run` first)",
                    dir.join("results.json").display()
                ))
            })?;
            let data_file = dir.join(ReportData::FILE_NAME);
            let data = match ReportData::read(&data_file) {
                Ok(d) => Some(d),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
                Err(e) => {
                    eprintln!(
                        "warning: {}: {e}; the report leaves out what it holds",
                        data_file.display()
                    );
                    None
                }
            };
            write_report(&dir, &results, data.as_ref())?;
            println!("wrote {}", dir.join("report.html").display());
            Ok(0)
        }
    }
}

fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn run(study: &Study, out: &Path, started: Instant) -> Result<i32, Error> {
    std::fs::create_dir_all(out)
        .map_err(|e| InputError::file(out, format!("cannot create the output directory: {e}")))?;
    let Some(model) = pipeline::model(study) else {
        return Err(Error::Failed("internal: a closed-form run of a solver study".into()));
    };
    let problem = pipeline::problem(study, model.as_ref());
    let calibration = pipeline::calibrate(study, &problem, None);
    let diagnosis = pipeline::diagnose(study, model.as_ref());
    let results = Results::build(study, model.as_ref(), &calibration, diagnosis);
    let mut data = ReportData::build(study, model.as_ref(), &calibration);
    data.force_displacement = report::curves::design_curves(study, None, None);
    data.wall_time_s = Some(started.elapsed().as_secs_f64());
    finish(out, &results, &data)
}

/// Where runs come from besides the solver, and where they go.
struct Modes {
    replay: Option<PathBuf>,
    record: Option<PathBuf>,
    /// `--executor slurm`: runs go to Slurm jobs.
    slurm: bool,
}

/// The replay directory: `--replay DIR`, else the study's `simulation.replay` when the solver
/// program is not on PATH (a note says so), else none (live).
fn replay_dir(sim: &SolverSimulation, replay: Option<PathBuf>) -> Option<PathBuf> {
    if replay.is_some() {
        return replay;
    }
    let default = sim.replay.clone()?;
    let program = &sim.command[0];
    if on_path(program) {
        return None;
    }
    eprintln!(
        "note: solver `{program}` is not on PATH: replaying the study's recordings in {}",
        default.display()
    );
    Some(default)
}

/// Whether `program` would be found: a path that exists, or an executable file on PATH.
fn on_path(program: &str) -> bool {
    use std::os::unix::fs::PermissionsExt;
    let executable = |p: &Path| {
        p.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    };
    if program.contains('/') {
        return executable(Path::new(program));
    }
    std::env::var_os("PATH").is_some_and(|path| std::env::split_paths(&path).any(|dir| executable(&dir.join(program))))
}

/// Plans, renders, runs (or replays) what is not finished, fits the surrogates, calibrates, writes.
fn run_solver(
    study: &Study,
    sim: &SolverSimulation,
    out: &Path,
    jobs: usize,
    modes: &Modes,
    started: Instant,
) -> Result<i32, Error> {
    let plan = Plan::new(study, sim);
    let prepared = sweep::prepare(study, sim, &plan)?;
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    let signals = Signals::install(&runtime)?;
    let mut store = crate::execute::open_store(out)?;
    sweep::write_meshes(out, &prepared)?;
    let swept = match &modes.replay {
        Some(dir) => {
            if !dir.is_dir() {
                return Err(Error::Failed(format!(
                    "replay directory {} does not exist",
                    dir.display()
                )));
            }
            let (swept, misses) = sweep::replay_runs(study, sim, &plan, &prepared, &mut store, dir)?;
            if !misses.is_empty() {
                let shown: Vec<&String> = misses.iter().take(5).collect();
                let more = if misses.len() > 5 {
                    format!("\n... and {} more", misses.len() - 5)
                } else {
                    String::new()
                };
                return Err(Error::Failed(format!(
                    "{} planned run(s) have no recording:\n{}{more}",
                    misses.len(),
                    shown.iter().map(|m| format!("- {m}")).collect::<Vec<_>>().join("\n")
                )));
            }
            swept
        }
        None if modes.slurm => sweep::run_slurm(&mut store, study, sim, &prepared, &signals)?,
        None => sweep::run(&runtime, &mut store, sim, &prepared, jobs, &signals.canceller)?,
    };
    signals.sweep_done();
    if let Some(dir) = &modes.record {
        let n = sweep::record(study, sim, &plan, &prepared, &store, dir)?;
        eprintln!("recorded {n} run(s) into {}", dir.display());
    }
    let failed = print_outcomes(&plan, &prepared.keys, &swept, &store);
    if signals.interrupted() {
        eprintln!(
            "interrupted: finished runs are kept in {}; `lab run` again resumes",
            out.display()
        );
        return Err(Error::Interrupted);
    }
    if !swept.errors.is_empty() {
        return Err(Error::Failed(swept.errors.join("\n")));
    }
    let surrogates = pipeline::surrogates(study, sim, &plan, &swept.responses)?;
    let problem = pipeline::problem(study, &surrogates as &dyn Model);
    let runs = pipeline::simulation_data(&plan, &swept.responses);
    let calibration = pipeline::calibrate(study, &problem, Some(&runs));
    let diagnosis = pipeline::diagnose_solver(study, sim, &plan, &swept.responses, &surrogates);
    let mut results = Results::build(study, &surrogates, &calibration, diagnosis).with_surrogates(&surrogates);
    if !study.splits.is_empty() {
        results.splits = Some(
            study
                .splits
                .iter()
                .map(|split| calibrate_split(study, split, &surrogates, &runs))
                .collect(),
        );
    }
    let succeeded = swept.responses.iter().filter(|r| r.is_some()).count();
    let planned = plan.runs.len();
    results.runs = Some(report::results::RunsResult {
        planned,
        succeeded,
        failed: planned - succeeded,
        replayed_from: modes.replay.as_ref().map(|d| d.display().to_string()),
    });
    let mut data = ReportData::build(study, &surrogates, &calibration).with_runs(
        study,
        &plan,
        &prepared.keys,
        &swept.responses,
        &surrogates,
        &store,
    );
    let outputs = report::curves::RunOutputs {
        plan: &plan,
        keys: &prepared.keys,
        responses: &swept.responses,
        dirs: output_dirs(&store, sim, modes),
    };
    let reference = report::data::reference(&calibration);
    data.force_displacement = report::curves::design_curves(study, Some(&outputs), reference.as_ref());
    data.wall_time_s = Some(started.elapsed().as_secs_f64());
    let code = finish(out, &results, &data)?;
    if let Some(splits) = &results.splits {
        print!("{}", splits_table(splits));
    }
    Ok(if failed > 0 { 1 } else { code })
}

/// Where finished runs' outputs are, as `<dir>/<key>/`: the store's run directories (live runs),
/// then `--replay` and the study's `simulation.replay` (runs replayed now or by an earlier `lab run`).
fn output_dirs(store: &RunStore, sim: &SolverSimulation, modes: &Modes) -> Vec<PathBuf> {
    let mut dirs = vec![store.out().join(crate::execute::store::RUNS_DIR)];
    dirs.extend(modes.replay.iter().cloned());
    if let Some(d) = &sim.replay
        && !dirs.contains(d)
    {
        dirs.push(d.clone());
    }
    dirs
}

/// Calibrates the study again with a split's training and validation designs.
fn calibrate_split(
    study: &Study,
    split: &study::Split,
    surrogates: &crate::fit::SurrogateModel,
    runs: &crate::calibrate::bayesian::SimulationData,
) -> report::results::SplitResult {
    let mut s = study.clone();
    s.training = split.training.clone();
    s.validation = split.validation.clone();
    let problem = pipeline::problem(&s, surrogates as &dyn Model);
    let calibration = pipeline::calibrate(&s, &problem, Some(runs));
    let not_diagnosed = Err(crate::calibrate::CalibrationError::Numerics(
        "not diagnosed per split".into(),
    ));
    let results = Results::build(&s, surrogates, &calibration, not_diagnosed);
    report::results::SplitResult::from_results(&s, &results)
}

/// The splits as a text table: per split and method, the parameters and the errors.
fn splits_table(splits: &[report::results::SplitResult]) -> String {
    use std::fmt::Write;
    let mut t = String::from("\ntrain/validate splits:\n");
    for split in splits {
        let _ = writeln!(
            t,
            "  train {} / validate {}",
            split.training.join(", "),
            split.validation.join(", ")
        );
        for (method, m) in &split.methods {
            if let Some(e) = &m.error {
                let _ = writeln!(t, "    {method:<14} failed: {e}");
                continue;
            }
            let params: Vec<String> = m.parameters.iter().map(|(k, v)| format!("{k} = {v:.1}")).collect();
            let truth: Vec<String> = m
                .parameter_error
                .iter()
                .flatten()
                .map(|(k, e)| format!("{k} {:+.1} % vs truth", 100.0 * e))
                .collect();
            let pct = |e: Option<f64>| e.map_or("-".to_string(), |e| format!("{:.2} %", 100.0 * e));
            let _ = writeln!(
                t,
                "    {method:<14} {}{}  training error {}  validation error {}",
                params.join(", "),
                if truth.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", truth.join(", "))
                },
                pct(m.training_error),
                pct(m.validation_error)
            );
        }
    }
    t
}

/// The outcome table on stderr, and the first failed runs; returns the number of failed runs.
fn print_outcomes(plan: &Plan, keys: &[String], swept: &sweep::SweepResult, store: &RunStore) -> usize {
    let mut classes = BTreeMap::new();
    for class in swept.classes.iter().flatten() {
        *classes.entry(*class).or_insert(0) += 1;
    }
    if let Some(n) = classes.get_mut(&OutcomeClass::Success) {
        *n -= swept.reused.min(*n);
    }
    let missing = swept.classes.iter().filter(|c| c.is_none()).count();
    eprint!("{}", progress::summary_table(&classes, swept.reused, missing));
    let failed: Vec<usize> = (0..plan.runs.len())
        .filter(|&i| swept.classes[i].is_some() && swept.responses[i].is_none())
        .collect();
    for &i in failed.iter().take(5) {
        let (run, key) = (&plan.runs[i], &keys[i]);
        let why = store.record(key).map(|r| r.outcome.to_string()).unwrap_or_default();
        eprintln!(
            "failed: design `{}`, parameters {:?}: {why} (see {})",
            run.design,
            run.theta,
            store.run_dir(key).display()
        );
    }
    failed.len()
}

/// `lab status`: counts of the planned runs in the store, read without taking its lock.
fn status(study: &Study, sim: &SolverSimulation, out: &Path) -> Result<i32, Error> {
    let plan = Plan::new(study, sim);
    let prepared = sweep::prepare(study, sim, &plan)?;
    let snapshot = Snapshot::read(out)?;
    let holder = lock::probe(out).map_err(|e| Error::Failed(e.to_string()))?;
    let (mut done, mut failed, mut running, mut pending) = (0, 0, 0, 0);
    for key in &prepared.keys {
        match snapshot.records.get(key) {
            Some(r) if r.outcome.is_success() => done += 1,
            Some(_) => failed += 1,
            None if holder.is_some() && snapshot.run_dirs.contains(key) => running += 1,
            None => pending += 1,
        }
    }
    println!(
        "study `{}`: {} planned run(s): done {done}, failed {failed}, running {running}, pending {pending}",
        study.name,
        plan.runs.len()
    );
    if let Some(holder) = holder {
        let who = holder.map_or("holder not yet written".to_string(), |h| {
            format!("pid {} on host {}", h.pid, h.host)
        });
        println!("a lab is running on {} ({who})", out.display());
    }
    Ok(0)
}

/// Writes results.json, report-data.json and report.html, prints the summary; 1 when a method failed.
fn finish(out: &Path, results: &Results, data: &ReportData) -> Result<i32, Error> {
    results.write(&out.join("results.json"))?;
    data.write(&out.join(ReportData::FILE_NAME))?;
    write_report(out, results, Some(data))?;
    print!("{}", report::summary::render(results));
    println!("\nwrote {}", out.join("results.json").display());
    Ok(if results.any_failed() { 1 } else { 0 })
}

fn write_report(dir: &Path, results: &Results, data: Option<&ReportData>) -> Result<(), Error> {
    report::write_atomic(&dir.join("report.html"), report::html::render(results, data).as_bytes())?;
    Ok(())
}

/// `--out`, or `lab-out/<study name>` beside the study file.
fn out_dir(study: &Study, out: Option<PathBuf>) -> PathBuf {
    out.unwrap_or_else(|| {
        study
            .path
            .parent()
            .unwrap_or(Path::new("."))
            .join("lab-out")
            .join(&study.name)
    })
}
