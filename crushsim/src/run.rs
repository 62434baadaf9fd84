//! The `crushsim` command line and the test-only failure switch.
//!
//! `crushsim i=main.k [ncpu=N] [memory=SIZE] [o=d3hsp]` (LS-DYNA style `key=value` arguments;
//! `ncpu` and `memory` are accepted and echoed, nothing else uses them). Outputs go to the
//! current directory, as LS-DYNA's do. A bad deck prints `*** Error` with file and line, writes
//! d3hsp/messag ending in the error-termination line, and exits 1; bad arguments exit 2.
//!
//! **Failure switch** (for the run engine's tests; real LS-DYNA would reject the keyword):
//!
//! ```text
//! *CRUSHSIM_TEST
//! mode      value
//! ```
//!
//! | mode | what crushsim does | breaks |
//! |---|---|---|
//! | `error` | all outputs, but d3hsp/messag/stdout end in ` E r r o r    t e r m i n a t i o n`; exit `value` (default 0) | termination line |
//! | `exit` | a normal run, then exit code `value` (default 3) | exit code |
//! | `nooutput` | normal termination, exit 0, but no rcforc/glstat/nodout | outputs |
//! | `garbage` | normal termination, exit 0, rcforc (and binout, when the deck asks for it) is deterministic binary garbage | outputs parse |
//! | `hang` | sleeps `value` seconds (default 3600) before running | time limit |
//! | `signal` | kills itself with signal `value` (default 9) after the banner | killed |
//! | `gap` | output number `value` (default: the middle one) left out of rcforc, nodout and glstat | complete times |
//! | `early` | histories stop at `value` × the termination time (default 0.5); normal termination | reaches the end time |
//! | `unpaired` | rcforc lacks the last interface's master row at the middle output | rcforc pairs |
//! | `missnode` | nodout's middle block lacks the history nodes' rows | nodout nodes |
//! | `hourglass` | hourglass / internal energy = `value` (default 0.2), their sum as before | hourglass gate |
//! | `energy` | spurious sliding energy grows to `value` (default 0.1) of the balance | energy gate |
//! | `addedmass` | glstat reports `value` (default 0.02) added mass | added-mass gate |
//!
//! The last seven change only what is written, never the force history: the response of a run
//! that passes the checks is the same with or without them.
//!
//! **Start log** (a test hook, as in `studies/solvers/beam.py`): when `LAB_TEST_SOLVER_LOG` names a
//! file, each start appends one line `start <name of the current directory>` to it, so a test can
//! count how often each run was executed (e.g. exactly once across a `lab` killed and rerun).

use std::path::{Path, PathBuf};
use std::time::Duration;

use super::assemble;
use super::binout;
use super::model::{DeckError, Model};
use super::output::{self, error_termination, normal_termination};
use super::physics::{self, History};

/// Parsed command line.
#[derive(Debug, Clone, PartialEq)]
pub struct Args {
    pub input: PathBuf,
    pub ncpu: Option<String>,
    pub memory: Option<String>,
    pub ignored: Vec<String>,
}

pub const USAGE: &str = "usage: crushsim i=main.k [ncpu=N] [memory=SIZE]";

/// Reads LS-DYNA style `key=value` arguments (keys case-insensitive).
pub fn parse_args(args: &[String]) -> Result<Args, String> {
    let mut parsed = Args {
        input: PathBuf::new(),
        ncpu: None,
        memory: None,
        ignored: Vec::new(),
    };
    for a in args {
        match a.split_once('=') {
            Some((k, v)) if k.eq_ignore_ascii_case("i") => parsed.input = PathBuf::from(v),
            Some((k, v)) if k.eq_ignore_ascii_case("ncpu") => parsed.ncpu = Some(v.to_string()),
            Some((k, v)) if k.eq_ignore_ascii_case("memory") => parsed.memory = Some(v.to_string()),
            _ => parsed.ignored.push(a.clone()),
        }
    }
    if parsed.input.as_os_str().is_empty() {
        return Err(format!("no input deck (i=...)\n{USAGE}"));
    }
    Ok(parsed)
}

/// Runs crushsim with `args` (without the program name) in the current directory; returns the
/// exit code.
pub fn main(args: &[String]) -> i32 {
    let args = match parse_args(args) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("crushsim: {e}");
            return 2;
        }
    };
    if let Some(log) = std::env::var_os("LAB_TEST_SOLVER_LOG") {
        log_start(Path::new(&log));
    }
    println!("{}", output::banner());
    println!(" {}", output::version_line().trim());
    println!(
        " input deck {}  ncpu {}  memory {}",
        args.input.display(),
        args.ncpu.as_deref().unwrap_or("1"),
        args.memory.as_deref().unwrap_or("default")
    );
    for a in &args.ignored {
        println!(" *** Warning: argument {a:?} ignored");
    }
    match assemble::load(&args.input) {
        Ok(model) => run_model(&model),
        Err(e) => deck_error(&e),
    }
}

/// Appends `start <cwd name>` to the test hook's log: one `write` of one line with O_APPEND, so
/// concurrent runs' lines do not interleave.
fn log_start(log: &Path) {
    use std::io::Write;
    let cwd = std::env::current_dir().unwrap_or_default();
    let name = cwd.file_name().unwrap_or_default().to_string_lossy();
    let line = format!("start {name}\n");
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(log)
        .and_then(|mut f| f.write_all(line.as_bytes()));
    if let Err(e) = written {
        eprintln!("crushsim: LAB_TEST_SOLVER_LOG {}: {e}", log.display());
    }
}

fn deck_error(e: &DeckError) -> i32 {
    let line = format!(" *** Error: {e}");
    println!("{line}\n{}", error_termination());
    eprintln!("crushsim: {e}");
    let text = format!(
        "crushsim run\n{}\n\n{}{line}\n\n{}\n",
        output::version_line(),
        output::banner(),
        error_termination()
    );
    let _ = std::fs::write("d3hsp", &text);
    let _ = std::fs::write("messag", &text);
    1
}

/// What the test switch asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Switch {
    None,
    Error(i32),
    Exit(i32),
    NoOutput,
    Garbage,
    Hang(f64),
    Signal(i32),
    /// A defect of the written histories (see [`output::Faults`]).
    Fault(output::Faults),
}

fn switch(m: &Model) -> Result<Switch, String> {
    let Some((mode, value)) = &m.test_switch else {
        return Ok(Switch::None);
    };
    let or = |d: f64| if *value == 0.0 { d } else { *value };
    Ok(match mode.as_str() {
        "error" => Switch::Error(*value as i32),
        "exit" => Switch::Exit(or(3.0) as i32),
        "nooutput" => Switch::NoOutput,
        "garbage" => Switch::Garbage,
        "hang" => Switch::Hang(or(3600.0)),
        "signal" => Switch::Signal(or(9.0) as i32),
        other => Switch::Fault(fault(other, *value).ok_or_else(|| {
            format!(
                "*CRUSHSIM_TEST: unknown mode {other:?} (error, exit, nooutput, garbage, hang, signal, \
                 gap, early, unpaired, missnode, hourglass, energy, addedmass)"
            )
        })?),
    })
}

/// The output defect a test mode asks for; `value` 0 takes the mode's default.
fn fault(mode: &str, value: f64) -> Option<output::Faults> {
    let or = |d: f64| if value == 0.0 { d } else { value };
    let mut f = output::Faults::default();
    match mode {
        "gap" => f.skip_output = Some(if value > 0.0 { value as usize } else { usize::MAX }),
        "early" => f.stop_at = Some(or(0.5)),
        "unpaired" => f.unpaired = true,
        "missnode" => f.missing_node = true,
        "hourglass" => f.hourglass = or(0.2),
        "energy" => f.energy_drift = or(0.1),
        "addedmass" => f.added_mass = Some(or(0.02)),
        _ => return None,
    }
    Some(f)
}

/// The faults with run-dependent defaults filled in: the gap's middle output, the stop time.
fn resolve(mut f: output::Faults, m: &Model, dt: f64) -> output::Faults {
    if f.skip_output == Some(usize::MAX) {
        f.skip_output = Some(output::Faults::middle(m, dt));
    }
    if let Some(fraction) = f.stop_at {
        f.stop_at = Some(fraction * m.run.end_time);
    }
    f
}

fn run_model(m: &Model) -> i32 {
    let sw = match switch(m) {
        Ok(s) => s,
        Err(e) => {
            return deck_error(&DeckError {
                file: "deck".into(),
                line: 0,
                message: e,
            });
        }
    };
    match sw {
        Switch::Hang(seconds) => {
            println!(" crushsim test switch: hanging for {seconds} s");
            std::thread::sleep(Duration::from_secs_f64(seconds.max(0.0)));
        }
        Switch::Signal(sig) => return kill_self(sig),
        _ => {}
    }
    let history = physics::simulate(m);
    match write_outputs(m, &history, sw) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("crushsim: cannot write outputs: {e}");
            1
        }
    }
}

fn kill_self(sig: i32) -> i32 {
    println!(" crushsim test switch: killing itself with signal {sig}");
    use std::io::Write;
    let _ = std::io::stdout().flush();
    match nix::sys::signal::Signal::try_from(sig) {
        Ok(s) => {
            let _ = nix::sys::signal::raise(s);
            std::thread::sleep(Duration::from_millis(200));
            eprintln!("crushsim: signal {sig} did not end the process");
            1
        }
        Err(_) => {
            eprintln!("crushsim: {sig} is not a signal");
            1
        }
    }
}

fn write(name: &str, text: &str) -> std::io::Result<()> {
    std::fs::write(Path::new(name), text)
}

fn write_outputs(m: &Model, h: &History, sw: Switch) -> std::io::Result<i32> {
    let termination = if matches!(sw, Switch::Error(_)) {
        error_termination()
    } else {
        normal_termination()
    };
    let faults = match sw {
        Switch::Fault(f) => f,
        _ => output::Faults::default(),
    };
    if sw != Switch::NoOutput {
        let b = m.run.binary;
        let ascii = |dt: Option<f64>, flag: i64| dt.filter(|_| flag != 2);
        if let Some(dt) = ascii(m.run.dt_rcforc, b.rcforc) {
            match sw {
                Switch::Garbage => std::fs::write("rcforc", garbage(4096))?,
                _ => write("rcforc", &output::rcforc(m, h, dt, &resolve(faults, m, dt)))?,
            }
        }
        if let Some(dt) = ascii(m.run.dt_glstat, b.glstat) {
            write("glstat", &output::glstat(m, h, dt, &resolve(faults, m, dt)))?;
        }
        if let Some(dt) = ascii(m.run.dt_nodout, b.nodout) {
            write("nodout", &output::nodout(m, h, dt, &resolve(faults, m, dt)))?;
        }
        if b.any_binout() {
            write_binout(m, h, sw, faults)?;
        }
    }
    let mut notes = vec![format!(
        " crushsim: {} steps of {} s",
        h.steps.len() - 1,
        output::e(h.dt, 12, 5).trim()
    )];
    if let Switch::Error(_) = sw {
        notes.push(" *** Error 99999: crushsim test switch: error termination requested".into());
    }
    write(
        "d3hsp",
        &(output::d3hsp(m, h, &(notes.join("\n") + "\n\n" + &termination))),
    )?;
    write("messag", &output::messag(m, &notes, &termination))?;
    println!("{}\n{termination}", notes.join("\n"));
    Ok(match sw {
        Switch::Error(code) | Switch::Exit(code) => code,
        _ => 0,
    })
}

/// The binout of the histories whose BINARY is 2 or 3 (garbage under the `garbage` switch).
fn write_binout(m: &Model, h: &History, sw: Switch, faults: output::Faults) -> std::io::Result<()> {
    if sw == Switch::Garbage {
        return std::fs::write("binout", garbage(4096));
    }
    let to_binout = |dt: Option<f64>, flag: i64| dt.filter(|_| flag >= 2);
    let b = m.run.binary;
    let wanted = binout::Wanted {
        rcforc: to_binout(m.run.dt_rcforc, b.rcforc),
        glstat: to_binout(m.run.dt_glstat, b.glstat),
        nodout: to_binout(m.run.dt_nodout, b.nodout),
    };
    let bytes = binout::binout(m, h, wanted, |dt| resolve(faults, m, dt)).map_err(std::io::Error::other)?;
    std::fs::write("binout", bytes)
}

/// Deterministic bytes that are not an rcforc (a xorshift stream, including invalid UTF-8).
fn garbage(n: usize) -> Vec<u8> {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 24) as u8
        })
        .collect()
}
