//! Ctrl-C during `lab run --executor slurm`: leave the jobs running, or cancel them.
//!
//! The jobs run without `lab`: interrupting the watcher need not stop them. When the interrupt is
//! a Ctrl-C (SIGINT) and a person is there (stdin and stderr are terminals), `lab` asks:
//!
//! ```text
//! Interrupted. 3 Slurm job(s) are queued or running.
//! [l]eave them running (default) / [c]ancel them with scancel? (leaves them in 30 s)
//! ```
//!
//! Enter, `l`, end of input, a second Ctrl-C or 30 s without an answer leave them, and `lab` prints
//! the command that re-attaches. `c` runs `scancel` on the journaled job ids (argv, no shell),
//! waits until Slurm reports every one ended, keeps the records their runs committed, marks the
//! other runs `cancelled` (not finished: the next `lab run` submits them again) and removes the
//! journal entries. Without a terminal, or on SIGTERM, the jobs are left running, as before.

use std::io::{BufRead, IsTerminal};
use std::path::Path;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use super::{JobEntry, find_by_name, job_states, journal, read_record, remove_entry, slurm_cmd, write_entry};
use crate::error::Error;
use crate::execute::{Outcome, RunRecord, RunStore};

/// How long the question waits for an answer before leaving the jobs running.
pub const QUESTION_TIMEOUT: Duration = Duration::from_secs(30);
/// How long to wait for cancelled jobs to leave the queue (Slurm's default KillWait is 30 s).
const CANCEL_WAIT: Duration = Duration::from_secs(90);

/// What to do with the jobs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    Leave,
    Cancel,
}

/// Whether a person can be asked: stdin and stderr are both terminals.
pub fn interactive() -> bool {
    std::io::stdin().is_terminal() && std::io::stderr().is_terminal()
}

/// The answer a line typed at the question means; `None` is end of input. Only `c` or `cancel`
/// (any case) cancels: anything else keeps the default, which loses no work.
pub fn parse_answer(line: Option<&str>) -> Answer {
    match line.map(|l| l.trim().to_ascii_lowercase()) {
        Some(a) if a == "c" || a == "cancel" => Answer::Cancel,
        _ => Answer::Leave,
    }
}

/// Asks on stderr and reads one line of `input`; leaves the jobs when no answer comes within
/// `timeout` or `give_up` turns true (a second Ctrl-C).
pub fn ask<R: BufRead + Send + 'static>(
    jobs: usize,
    mut input: R,
    timeout: Duration,
    give_up: &dyn Fn() -> bool,
) -> Answer {
    eprint!(
        "\nInterrupted. {jobs} Slurm job(s) are queued or running.\n\
         [l]eave them running (default) / [c]ancel them with scancel? (leaves them in {} s) ",
        timeout.as_secs()
    );
    let (tx, rx) = mpsc::channel();
    // A thread, because a read from a terminal cannot be given a timeout; if no line comes it
    // stays blocked until `lab` exits, which it does right after.
    std::thread::spawn(move || {
        let mut line = String::new();
        let read = match input.read_line(&mut line) {
            Ok(0) | Err(_) => None,
            Ok(_) => Some(line),
        };
        let _ = tx.send(read);
    });
    let deadline = Instant::now() + timeout;
    loop {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(line) => break parse_answer(line.as_deref()),
            Err(mpsc::RecvTimeoutError::Disconnected) => break Answer::Leave,
            Err(mpsc::RecvTimeoutError::Timeout) if give_up() || Instant::now() >= deadline => {
                eprintln!();
                break Answer::Leave;
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
    }
}

/// A word as a POSIX shell reads it back: unquoted when it is plain, else single-quoted.
fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-./=:,+@%".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// The command that re-attaches to the jobs: `lab run STUDY --executor slurm --out DIR`.
pub fn reattach_command(study: &Path, out: &Path) -> String {
    format!(
        "lab run {} --executor slurm --out {}",
        shell_word(&study.display().to_string()),
        shell_word(&out.display().to_string())
    )
}

/// What [`cancel`] did.
#[derive(Debug, Default)]
pub struct Cancelled {
    pub jobs: Vec<String>,
    /// Runs marked `cancelled` (they had committed nothing).
    pub cancelled_runs: usize,
    /// Runs whose committed records were kept (finished before the scancel, or failed).
    pub kept_runs: usize,
}

/// Cancels every journaled job of `out` with scancel, waits until Slurm reports each one ended,
/// then settles their runs (see the module doc) and removes their journal entries.
pub fn cancel(out: &Path, store: &mut RunStore) -> Result<Cancelled, Error> {
    let mut entries: Vec<JobEntry> = Vec::new();
    for mut entry in journal(out) {
        if entry.job_id.is_none() {
            entry.job_id = find_by_name(&entry.token);
            if entry.job_id.is_some() {
                write_entry(out, &entry)?;
            }
        }
        entries.push(entry);
    }
    let ids: Vec<String> = entries.iter().filter_map(|e| e.job_id.clone()).collect();
    let mut done = Cancelled {
        jobs: ids.clone(),
        ..Cancelled::default()
    };
    if !ids.is_empty() {
        let args: Vec<&str> = ids.iter().map(String::as_str).collect();
        // scancel complains about jobs that ended meanwhile; the wait below is what counts.
        if let Err(e) = slurm_cmd("scancel", &args) {
            eprintln!("note: {e}");
        }
        wait_ended(&ids)?;
    }
    for entry in &entries {
        for key in &entry.keys {
            if let Some(record) = read_record(out, key).filter(|r| r.ended_ms >= entry.submitted_ms) {
                store.remember(record);
                done.kept_runs += 1;
                continue;
            }
            let job = entry.job_id.clone().unwrap_or_else(|| format!("lab-{}", entry.token));
            let record = RunRecord::ended(key, Outcome::Cancelled { job }, 1, entry.submitted_ms, None);
            store.commit(record).map_err(Error::from)?;
            done.cancelled_runs += 1;
        }
        remove_entry(out, &entry.token);
    }
    Ok(done)
}

/// Waits until Slurm answers that none of `ids` is still pending, running or completing.
fn wait_ended(ids: &[String]) -> Result<(), Error> {
    let deadline = Instant::now() + CANCEL_WAIT;
    loop {
        let poll = job_states(ids);
        let busy: Vec<&String> = ids
            .iter()
            .filter(|id| poll.states.get(*id).is_some_and(|s| !s.is_final()))
            .collect();
        if poll.answered && busy.is_empty() {
            return Ok(());
        }
        if Instant::now() >= deadline {
            return Err(Error::Failed(format!(
                "scancel: Slurm still reports job(s) {} after {} s; their journal entries are kept, \
                 so `lab run --executor slurm` re-attaches to them",
                busy.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", "),
                CANCEL_WAIT.as_secs()
            )));
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_c_cancels() {
        assert_eq!(parse_answer(Some("c\n")), Answer::Cancel);
        assert_eq!(parse_answer(Some("  Cancel \n")), Answer::Cancel);
        for leave in [Some("\n"), Some("l\n"), Some("leave"), Some("x\n"), Some("cc\n"), None] {
            assert_eq!(parse_answer(leave), Answer::Leave, "{leave:?}");
        }
    }

    #[test]
    fn the_question_reads_one_line() {
        let never = || false;
        assert_eq!(
            ask(2, std::io::Cursor::new("c\nl\n"), Duration::from_secs(5), &never),
            Answer::Cancel
        );
        assert_eq!(
            ask(2, std::io::Cursor::new(""), Duration::from_secs(5), &never),
            Answer::Leave
        );
    }

    /// Input that never arrives.
    struct Silent;
    impl std::io::Read for Silent {
        fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
            std::thread::sleep(Duration::from_secs(3600));
            Ok(0)
        }
    }

    #[test]
    fn no_answer_leaves_the_jobs_after_the_timeout() {
        let t = Instant::now();
        let never = || false;
        let input = std::io::BufReader::new(Silent);
        assert_eq!(ask(2, input, Duration::from_millis(300), &never), Answer::Leave);
        let waited = t.elapsed();
        assert!(
            waited >= Duration::from_millis(300) && waited < Duration::from_secs(3),
            "{waited:?}"
        );
    }

    #[test]
    fn a_second_interrupt_leaves_the_jobs_at_once() {
        let t = Instant::now();
        let input = std::io::BufReader::new(Silent);
        assert_eq!(ask(2, input, Duration::from_secs(60), &|| true), Answer::Leave);
        assert!(t.elapsed() < Duration::from_secs(3));
    }

    #[test]
    fn the_reattach_command_quotes_only_what_needs_it() {
        assert_eq!(
            reattach_command(Path::new("studies/honeycomb.yaml"), Path::new("/tmp/out-1")),
            "lab run studies/honeycomb.yaml --executor slurm --out /tmp/out-1"
        );
        assert_eq!(
            reattach_command(Path::new("my study.yaml"), Path::new("it's")),
            r"lab run 'my study.yaml' --executor slurm --out 'it'\''s'"
        );
    }
}
