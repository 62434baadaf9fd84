//! The command line (contract: `lab run | check | status | report`): parses the arguments, installs
//! signal handling, calls the pipeline ([`crate::pipeline`]), prints what it returns and maps errors
//! to the contract's exit codes (0 done, 1 runs or numerics failed, 2 invalid input or usage, 130
//! interrupted). Errors are printed here, once; nothing else is done here.

use std::path::{Path, PathBuf};

use clap::{Parser, Subcommand, ValueEnum};

use crate::error::{Error, InputError};
use crate::execute::sweep::Signals;
use crate::extract::crush;
use crate::pipeline::{self, Engine, ExecutorKind, RunOptions, verbs};
use crate::report;
use crate::study::{self, Study};

#[path = "cli_print.rs"]
mod print;
use print::{Stderr, extract, status};

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
        /// Search a library of shapes for a missing term when no listed hypothesis explains the
        /// misfit (`diagnosis.discover: true` for this run).
        #[arg(long)]
        discover: bool,
        /// Print the diagnosis's evidence lines after the tables (the report always has them).
        #[arg(long, short)]
        verbose: bool,
    },
    /// Validate the study and everything it references, without running anything.
    Check { study: PathBuf },
    /// Counts of the study's runs: done / failed / running / pending.
    Status {
        study: PathBuf,
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Mean crush force (energy / stroke) of a test machine's force–displacement CSV, or of an
    /// LS-DYNA binout (a file or a run directory), whose histories it also lists and prints.
    Extract {
        /// CSV with displacement [mm] and force [kN or N] columns, or a binout, or a run directory.
        curve: PathBuf,
        /// Stroke window `S0:S1` in mm.
        #[arg(long, default_value = "5:60")]
        window: String,
        /// binout: list its histories and variables.
        #[arg(long, conflicts_with = "series")]
        list: bool,
        /// binout: one variable over time in lasso-python's naming, e.g. rwforc/forces/normal_force.
        #[arg(long)]
        series: Option<String>,
        /// With --series: print `{"time": [...], "values": [...]}`.
        #[arg(long, requires = "series")]
        json: bool,
    },
    // --- issue 24: `lab compare` ---
    /// Curve metrics (mse, pcm, Frechet, DTW, area) of a computed force–displacement CSV against a target.
    Compare {
        /// Target curve A (the test): CSV with displacement [mm] and force [kN or N] columns.
        a: PathBuf,
        /// Computed curve B (the simulation), same format.
        b: PathBuf,
        /// Stroke window `S0:S1` in mm: both curves resampled on one grid there, every metric on it.
        #[arg(long, value_parser = verbs::parse_window)]
        window: Option<crush::Window>,
        /// Grid points over the window (and for mse without one).
        #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(2..=1_000_000))]
        points: u32,
        /// Print the metrics as JSON.
        #[arg(long)]
        json: bool,
    },
    // --- end issue 24 ---
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
            discover,
            verbose,
        } => {
            let mut study = study::load(&study)?;
            study.diagnosis.discover |= discover;
            if replay.is_some() && record.is_some() {
                return Err(Error::Input(InputError::file(
                    &study.path,
                    "--replay and --record together: a replay starts no solver, so there is nothing new to record",
                )));
            }
            let options = RunOptions {
                out: out_dir(&study, out),
                jobs: jobs.unwrap_or_else(default_jobs),
                executor: match executor {
                    Executor::Local => ExecutorKind::Local,
                    Executor::Slurm => ExecutorKind::Slurm,
                },
                replay,
                record,
            };
            run(&study, &options, verbose)
        }
        Command::SlurmWorker { study, out, jobs, keys } => {
            verbs::slurm_worker(&study::load(&study)?, &out, jobs, &keys)
        }
        Command::Check { study } => check(&study::load(&study)?),
        Command::Status { study, out } => {
            let study = study::load(&study)?;
            let out = out_dir(&study, out);
            status(&study, &out)
        }
        Command::Extract {
            curve,
            window,
            list,
            series,
            json,
        } => extract(&curve, &window, list, series, json),
        Command::Compare {
            a,
            b,
            window,
            points,
            json,
        } => compare(&a, &b, window, points as usize, json),
        Command::Report { study, out } => {
            let dir = out_dir(&study::load(&study)?, out);
            if let Some(warning) = report::run::rewrite_report(&dir)? {
                eprintln!("warning: {warning}");
            }
            println!("wrote {}", dir.join("report.html").display());
            Ok(0)
        }
    }
}

fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `lab run`: installs the signal handlers, runs the pipeline, prints the summary.
fn run(study: &Study, options: &RunOptions, verbose: bool) -> Result<i32, Error> {
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    let signals = Signals::install(&runtime)?;
    let engine = Engine {
        runtime: &runtime,
        signals: &signals,
    };
    let outcome = pipeline::run(study, options, &engine, &mut Stderr)?;
    let written = report::run::write_run(study, outcome, &options.out)?;
    print!("{}", report::summary::render(&written.results, verbose));
    if let Some(splits) = &written.results.stated.splits {
        print!("{}", report::summary::splits(splits));
    }
    println!("\nwrote {}", options.out.join("results.json").display());
    println!("wrote {}", options.out.join("report.html").display());
    Ok(written.exit_code())
}

/// `lab check`: validates, then says what was read.
fn check(study: &Study) -> Result<i32, Error> {
    let checked = verbs::check(study)?;
    let budget = checked.budget;
    match (checked.rendered_runs, budget) {
        (Some(n), Some(budget)) => println!(
            "ok: the {n} run(s) of the initial design render; sampled sequentially, batches follow until the \
             emulators are within the tolerance, at most {budget} solver run(s) in all"
        ),
        (Some(n), None) => println!("ok: {n} planned solver run(s) render"),
        _ => {}
    }
    if let Some((fixed, with)) = &checked.replaces {
        println!(
            "in place of a {}: {} solver run(s), {with} with the solver in the loop for every extension",
            fixed.design(),
            fixed.runs
        );
    }
    if checked.loop_runs > 0 {
        match budget {
            Some(_) => println!(
                "ok: the solver in the loop's decks (extensions with ranges) render, {} checked over the joint space",
                checked.loop_runs
            ),
            None => println!(
                "ok: {} run(s) the solver in the loop may add (extensions with ranges) render",
                checked.loop_runs
            ),
        }
    }
    if let crate::study::Simulation::Solver(sim) = &study.simulation
        && let Some(s) = &sim.inputs.seeds
    {
        let by = (s.variable.as_ref()).map_or("the starter's -rseed".to_string(), |v| {
            format!("`{v}` = 1 … {}", s.count)
        });
        println!(
            "ok: the confirmation runs are made at {} seeds of the solver's imperfection ({by})",
            s.count
        );
    }
    println!(
        "ok: study `{}`: {} design variable(s), {} parameter(s), {} tested design(s), {} training, {} validation",
        study.name,
        study.design.len(),
        study.parameters.len(),
        study.experiments.designs.len(),
        study.split.training.len(),
        study.split.validation.len()
    );
    let (specimens, designs) = checked.curves;
    if designs > 0 {
        println!("ok: {specimens} force-displacement curve(s) of {designs} design(s) read");
    }
    if let crate::study::Simulation::Solver(sim) = &study.simulation
        && let Some(deck) = &sim.inputs.deck
    {
        let (set, left) = deck.settings();
        let set: Vec<String> = set.iter().map(|(s, d)| format!("{d} ({s})")).collect();
        println!(
            "ok: deck {} and {} included file(s): each run sets {}",
            deck.files[0].file.display(),
            deck.files.len() - 1 + deck.per_design.len(),
            set.join(", ")
        );
        if !left.is_empty() {
            println!("    *PARAMETER entries left as the deck has them: {}", left.join(", "));
        }
    }
    Ok(0)
}

// --- issue 24: `lab compare` ---
/// `lab compare A B [--window S0:S1] [--points N] [--json]`: prints, writes nothing.
fn compare(a: &Path, b: &Path, window: Option<crush::Window>, points: usize, json: bool) -> Result<i32, Error> {
    let c = verbs::compare(a, b, window, points)?;
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&c).map_err(|e| Error::Failed(e.to_string()))?
        );
    } else {
        print!("{}", c.table());
    }
    Ok(0)
}
// --- end issue 24 ---

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
