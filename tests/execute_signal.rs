//! Real signals: SIGTERM to `lab` cancels the executor; a second one SIGKILLs the children at once.
//! Its own test binary (one test), because it installs process-wide signal handlers.

#[allow(dead_code)] // the executor helpers; this test uses a few
mod solvers;

use std::time::Duration;

use lab::execute::executor::cancel_on_signals;
use lab::execute::{CancelReason, RunStore};
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use solvers::*;

#[tokio::test]
async fn sigterm_cancels_and_a_second_one_skips_the_grace_period() {
    let out = tempfile::tempdir().unwrap();
    let store = RunStore::open(out.path()).unwrap();
    // `stubborn` ignores SIGTERM: only the escalation to SIGKILL can end it.
    let s = spec(&store, "x", &["stubborn"]);
    let pid_files = [s.dir.join("solver.pid"), s.dir.join("grandchild.pid")];
    let (mut ex, _rx) = executor(&store, 1);
    // A grace period far longer than the test's limit below: the run ends in time only if the
    // second signal skips it.
    ex.grace = Duration::from_secs(60);
    let _signals = cancel_on_signals(ex.canceller.clone()).unwrap();
    let canceller = ex.canceller.clone();
    let me = Pid::this();
    let driver = async {
        assert!(
            wait_for_file(&pid_files[1], Duration::from_secs(10)).await,
            "solver never started"
        );
        kill(me, Signal::SIGTERM).unwrap();
        while canceller.reason().is_none() {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        assert_eq!(canceller.reason(), Some(CancelReason::Signal));
        kill(me, Signal::SIGTERM).unwrap();
    };
    // 20 s: generous against a loaded machine, still far below the 60 s grace period.
    let (summary, ()) = tokio::time::timeout(Duration::from_secs(20), async {
        tokio::join!(ex.run(vec![s.clone()]), driver)
    })
    .await
    .expect("the second signal did not SIGKILL the stubborn solver");
    assert_eq!(summary.cancelled, Some(CancelReason::SecondSignal));
    assert_eq!(summary.interrupted, vec![s.key.clone()]);
    assert!(summary.records.is_empty());
    for p in &pid_files {
        let pid = read_pid(p);
        assert!(
            wait_gone(pid, Duration::from_secs(2)),
            "{} ({pid}) still alive",
            p.display()
        );
    }
}
