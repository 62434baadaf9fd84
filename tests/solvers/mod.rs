//! Helpers shared by the `execute_*` tests: the fake solver and runs built on it.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use lab::execute::store::run_key;
use lab::execute::{Adapter, CommandAdapter, Event, Executor, RetryPolicy, RunSpec, RunStore};
use tokio::sync::mpsc;

pub fn fake_solver() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/solvers/fake_solver.py")
}

pub fn adapter() -> Arc<CommandAdapter> {
    Arc::new(
        CommandAdapter::new(
            "resp.txt",
            r"value\s*=\s*(\S+)",
            &[r"E r r o r\s+t e r m i n a t i o n"],
        )
        .unwrap(),
    )
}

/// A run of the fake solver in `mode`; `input` is the content of its one input file (so runs with
/// equal modes can still differ in key).
pub fn spec(store: &RunStore, input: &str, mode: &[&str]) -> RunSpec {
    let mut argv = vec!["python3".to_string(), fake_solver().display().to_string()];
    argv.extend(mode.iter().map(|s| s.to_string()));
    let inputs = vec![(PathBuf::from("input.txt"), input.as_bytes().to_vec())];
    let key = run_key(&inputs, &argv, &adapter().identity());
    let dir = store.prepare(&key, &inputs).unwrap();
    RunSpec {
        key,
        dir,
        argv,
        timeout: Some(Duration::from_secs(20)),
        outputs: vec!["resp.txt".into()],
        retry: RetryPolicy::none(),
    }
}

pub fn executor(store: &RunStore, jobs: usize) -> (Executor, mpsc::UnboundedReceiver<Event>) {
    let (tx, rx) = mpsc::unbounded_channel();
    let mut ex = Executor::new(jobs, adapter(), store.committer());
    ex.events = Some(tx);
    (ex, rx)
}

pub fn drain(rx: &mut mpsc::UnboundedReceiver<Event>) -> Vec<Event> {
    let mut events = Vec::new();
    while let Ok(e) = rx.try_recv() {
        events.push(e);
    }
    events
}

/// Whether process `pid` is gone. A killed process whose parent has not reaped it yet is a zombie:
/// it still answers `kill(pid, 0)` but runs no code, so a zombie counts as gone.
pub fn is_gone(pid: i32) -> bool {
    if nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), None).is_err() {
        return true;
    }
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // Field 3 is the state; the command name in field 2 is parenthesised and may hold spaces.
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| rest.trim_start().starts_with('Z')),
        Err(_) => true,
    }
}

/// Waits up to `limit` for `pid` to be gone. Death after SIGKILL is asynchronous (the kernel tears
/// the process down after `kill` returns), hence a bounded wait instead of a single check.
pub fn wait_gone(pid: i32, limit: Duration) -> bool {
    let start = Instant::now();
    while start.elapsed() < limit {
        if is_gone(pid) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    is_gone(pid)
}

pub fn read_pid(path: &Path) -> i32 {
    std::fs::read_to_string(path).unwrap().trim().parse().unwrap()
}

/// Waits up to `limit` for `path` to exist.
pub async fn wait_for_file(path: &Path, limit: Duration) -> bool {
    let start = Instant::now();
    while start.elapsed() < limit {
        if path.exists() {
            return true;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    path.exists()
}
