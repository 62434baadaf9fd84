//! The command line (contract: `lab run | check | status | report`). Errors are printed here, once,
//! and mapped to the contract's exit codes: 0 done, 1 runs or numerics failed, 2 invalid input or
//! usage, 130 interrupted.

use std::path::{Path, PathBuf};

use clap::{Parser, Subcommand, ValueEnum};

use crate::error::{Error, InputError};
use crate::pipeline;
use crate::report::{self, Results};
use crate::study::{self, Study};

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
        Command::Run { study, out, executor, .. } => {
            let study = study::load(&study)?;
            if executor == Executor::Slurm {
                eprintln!("note: `{}` has a closed-form simulation; nothing to submit to Slurm", study.name);
            }
            run(&study, &out_dir(&study, out))
        }
        Command::Check { study } => {
            let study = study::load(&study)?;
            println!(
                "ok: study `{}`: {} design variable(s), {} parameter(s), {} tested design(s), {} training, {} validation",
                study.name,
                study.design.len(),
                study.parameters.len(),
                study.experiments.designs.len(),
                study.training.len(),
                study.validation.len()
            );
            Ok(0)
        }
        Command::Status { study, .. } => {
            let study = study::load(&study)?;
            println!("study `{}`: closed-form simulation, no solver runs (done 0, failed 0, running 0, pending 0)", study.name);
            Ok(0)
        }
        Command::Report { study, out } => {
            let study = study::load(&study)?;
            let dir = out_dir(&study, out);
            let results = Results::read(&dir.join("results.json"))
                .map_err(|e| Error::Failed(format!("{}: {e} (run `lab run` first)", dir.join("results.json").display())))?;
            write_report(&dir, &results)?;
            println!("wrote {}", dir.join("report.html").display());
            Ok(0)
        }
    }
}

fn run(study: &Study, out: &Path) -> Result<i32, Error> {
    std::fs::create_dir_all(out)
        .map_err(|e| InputError::file(out, format!("cannot create the output directory: {e}")))?;
    let model = pipeline::model(study);
    let problem = pipeline::problem(study, model.as_ref());
    let calibration = pipeline::calibrate(study, &problem);
    let diagnosis = pipeline::diagnose(study, model.as_ref());
    let results = Results::build(study, model.as_ref(), &calibration, diagnosis);
    results.write(&out.join("results.json"))?;
    write_report(out, &results)?;
    print!("{}", report::summary::render(&results));
    println!("\nwrote {}", out.join("results.json").display());
    Ok(if results.any_failed() { 1 } else { 0 })
}

fn write_report(dir: &Path, results: &Results) -> Result<(), Error> {
    report::write_atomic(&dir.join("report.html"), report::html::render(results).as_bytes())?;
    Ok(())
}

/// `--out`, or `lab-out/<study name>` beside the study file.
fn out_dir(study: &Study, out: Option<PathBuf>) -> PathBuf {
    out.unwrap_or_else(|| study.path.parent().unwrap_or(Path::new(".")).join("lab-out").join(&study.name))
}
