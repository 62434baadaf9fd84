//! Ctrl-C during `lab run --executor slurm`, against a real single-node Slurm (scripts/slurm-up.sh).
//!
//! At a terminal — `lab` runs on a pseudo-terminal as its controlling terminal, and the test types
//! Ctrl-C (byte 0x03: the line discipline sends SIGINT to the foreground process group, as a
//! person's keyboard does) — `lab` asks whether to leave the jobs or cancel them: `c` cancels them
//! (squeue no longer shows them, the journal is empty, a rerun executes the cancelled runs and
//! finishes); Enter leaves them running and prints the command that re-attaches, which then
//! finishes the study. Without a terminal, SIGINT leaves the jobs running without asking.
//! Skips with a message when no Slurm answers, except with CI=true.

use crate::slurm_common;

use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use slurm_common::*;

const ARGS: [&str; 6] = [
    "run",
    "cantilever-compliance.yaml",
    "--executor",
    "slurm",
    "--out",
    "out",
];

/// `lab` on a pseudo-terminal: what it writes, and a way to type.
struct Terminal {
    child: Child,
    master: std::fs::File,
    screen: Arc<Mutex<String>>,
}

impl Terminal {
    /// Starts `cmd` with a new pseudo-terminal as its stdin, stdout, stderr and controlling
    /// terminal (a new session), so Ctrl-C typed on it signals `lab` as a keyboard's does.
    fn spawn(mut cmd: std::process::Command) -> Terminal {
        let pty = nix::pty::openpty(None, None).unwrap();
        let slave: OwnedFd = pty.slave;
        cmd.stdin(Stdio::from(slave.try_clone().unwrap()))
            .stdout(Stdio::from(slave.try_clone().unwrap()))
            .stderr(Stdio::from(slave));
        // SAFETY: only async-signal-safe calls (setsid, ioctl) between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                if libc::setsid() < 0 || libc::ioctl(0, libc::TIOCSCTTY as _, 0) < 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = cmd.spawn().unwrap();
        drop(cmd); // closes the parent's copies of the slave: reads end when lab is gone
        let master = std::fs::File::from(pty.master);
        let screen = Arc::new(Mutex::new(String::new()));
        let (mut reader, seen) = (master.try_clone().unwrap(), screen.clone());
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            // Ends with EIO once every holder of the slave has closed it.
            while let Ok(n @ 1..) = reader.read(&mut buf) {
                seen.lock().unwrap().push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        });
        Terminal { child, master, screen }
    }

    fn screen(&self) -> String {
        self.screen.lock().unwrap().clone()
    }

    #[track_caller]
    fn wait_for(&self, text: &str, limit: Duration) {
        assert!(
            wait_until(limit, || self.screen().contains(text)),
            "`{text}` did not appear within {limit:?}; the terminal shows:\n{}",
            self.screen()
        );
    }

    fn type_bytes(&mut self, bytes: &[u8]) {
        self.master.write_all(bytes).unwrap();
    }

    /// Waits for `lab` to exit (at most `limit`); its exit code.
    #[track_caller]
    fn exit_code(&mut self, limit: Duration) -> Option<i32> {
        let mut status = None;
        let exited = wait_until(limit, || {
            status = self.child.try_wait().unwrap();
            status.is_some()
        });
        if !exited {
            let _ = self.child.kill();
            panic!(
                "lab did not exit within {limit:?}; the terminal shows:\n{}",
                self.screen()
            );
        }
        // Let the reader drain what lab wrote last.
        std::thread::sleep(Duration::from_millis(200));
        status.unwrap().code()
    }
}

/// The compliance study in `dir` (9 jobs of 2 runs of `sleep` s each) started on a terminal;
/// returns once every job is submitted, with their ids.
fn start_on_a_terminal(conf: &str, dir: &Path, log: &Path, sleep: &str) -> (Terminal, Vec<String>) {
    compliance_study(dir, "{runs_per_job: 2}");
    let mut cmd = lab(conf, dir, &ARGS);
    cmd.env("LAB_TEST_SOLVER_LOG", log).env("LAB_TEST_SOLVER_SLEEP", sleep);
    let term = Terminal::spawn(cmd);
    term.wait_for("submitted 18 run(s) in 9 Slurm job(s)", Duration::from_secs(60));
    // Normally all 9 are still journaled here; a job that already ended has left the journal.
    let ids = journaled_ids(&dir.join("out"));
    assert!(!ids.is_empty(), "{}", term.screen());
    (term, ids)
}

/// The line after "Re-attach with:" in `text`, as argv.
fn reattach_argv(text: &str) -> Vec<String> {
    let mut lines = text.lines().skip_while(|l| !l.contains("Re-attach with:"));
    lines
        .next()
        .unwrap_or_else(|| panic!("no `Re-attach with:` in:\n{text}"));
    let line = lines.next().unwrap().trim();
    line.split_whitespace().map(str::to_string).collect()
}

#[test]
fn ctrl_c_at_a_terminal_then_c_cancels_the_jobs() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("solver.log"), tmp.path().join("out"));
    let (mut term, ids) = start_on_a_terminal(&conf, tmp.path(), &log, "1");
    term.type_bytes(b"\x03");
    term.wait_for("[c]ancel them with scancel?", Duration::from_secs(10));
    term.type_bytes(b"c\n");
    assert_eq!(term.exit_code(Duration::from_secs(120)), Some(130), "{}", term.screen());
    let screen = term.screen();
    assert!(screen.contains("cancelled"), "{screen}");
    assert_eq!(queued(&conf, &ids), Vec::<String>::new(), "squeue still shows jobs");
    assert!(journal_files(&out).is_empty(), "journal entries left");
    let cancelled = keys_with(&out, "cancelled");
    let finished = keys_with(&out, "success");
    assert!(
        !cancelled.is_empty(),
        "the jobs were cancelled before their runs finished"
    );
    assert_eq!(
        cancelled.len() + finished.len() + keys_with(&out, "signal").len(),
        18,
        "every run is cancelled, finished, or killed by the scancel"
    );
    // The rerun (no terminal) executes the cancelled runs, keeps the finished ones, and finishes.
    let again = tmp.path().join("again.log");
    let o = lab(&conf, tmp.path(), &ARGS)
        .env("LAB_TEST_SOLVER_LOG", &again)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(!err.contains("re-attached"), "nothing is left to re-attach to: {err}");
    let rerun = started_once(&again);
    assert!(cancelled.is_subset(&rerun), "cancelled {cancelled:?}, rerun {rerun:?}");
    assert!(finished.is_disjoint(&rerun), "a finished run was executed again");
    assert_eq!(keys_with(&out, "success").len(), COMPLIANCE_RUNS);
}

#[test]
fn ctrl_c_at_a_terminal_then_enter_leaves_the_jobs_and_says_how_to_reattach() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("solver.log"), tmp.path().join("out"));
    let (mut term, ids) = start_on_a_terminal(&conf, tmp.path(), &log, "1");
    term.type_bytes(b"\x03");
    term.wait_for("[l]eave them running (default)", Duration::from_secs(10));
    term.type_bytes(b"\n");
    assert_eq!(term.exit_code(Duration::from_secs(30)), Some(130), "{}", term.screen());
    let still = queued(&conf, &ids);
    let screen = term.screen();
    assert!(!still.is_empty(), "the jobs were left running: {screen}");
    assert!(!journal_files(&out).is_empty());
    let argv = reattach_argv(&screen);
    assert_eq!(
        argv,
        [
            "lab",
            "run",
            "cantilever-compliance.yaml",
            "--executor",
            "slurm",
            "--out",
            "out"
        ],
        "{screen}"
    );
    // The printed command re-attaches and finishes; every run executed exactly once.
    let args: Vec<&str> = argv[1..].iter().map(String::as_str).collect();
    let mut rerun = lab(&conf, tmp.path(), &args);
    rerun.stdin(Stdio::null());
    let (_, started) = rerun_reattaches(rerun, &log);
    assert_eq!(started.len(), COMPLIANCE_RUNS);
}

#[test]
fn sigint_without_a_terminal_leaves_the_jobs_without_asking() {
    let Some(conf) = slurm_conf() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("solver.log"), tmp.path().join("out"));
    compliance_study(tmp.path(), "{runs_per_job: 2}");
    let child = lab(&conf, tmp.path(), &ARGS)
        .env("LAB_TEST_SOLVER_LOG", &log)
        .env("LAB_TEST_SOLVER_SLEEP", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // All 9 batch scripts written (each before its journal entry and sbatch) and jobs journaled.
    let scripts = || {
        std::fs::read_dir(out.join("slurm")).map_or(0, |d| {
            d.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "sh"))
            })
            .count()
        })
    };
    assert!(wait_until(Duration::from_secs(60), || scripts() == 9
        && !journaled_ids(&out).is_empty()));
    let ids = journaled_ids(&out);
    let pid = nix::unistd::Pid::from_raw(child.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT).unwrap();
    let o = wait_output(child, Duration::from_secs(20));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(!err.contains("[c]ancel"), "asked without a terminal: {err}");
    assert!(!queued(&conf, &ids).is_empty(), "the jobs were left running: {err}");
    let argv = reattach_argv(&err);
    let args: Vec<&str> = argv[1..].iter().map(String::as_str).collect();
    let (_, started) = rerun_reattaches(lab(&conf, tmp.path(), &args), &log);
    assert_eq!(started.len(), COMPLIANCE_RUNS);
}

/// The child's output once it exits within `limit` (killed and failed otherwise).
#[track_caller]
fn wait_output(mut child: Child, limit: Duration) -> std::process::Output {
    if !wait_until(limit, || child.try_wait().unwrap().is_some()) {
        let _ = child.kill();
        panic!("lab did not exit within {limit:?} of SIGINT");
    }
    child.wait_with_output().unwrap()
}
