//! The executor against the fake solver: every outcome class, retries, timeouts that kill the whole
//! process group, cancellation that keeps finished results.

use crate::solvers;

use std::time::Duration;

use lab::execute::{
    Backoff, CancelReason, Event, Outcome, OutcomeClass, ResponseProblem, RetryPolicy, RunRecord, RunSpec, RunStore,
};
use solvers::*;

async fn run_one(store: &RunStore, spec: RunSpec) -> (RunRecord, Vec<Event>) {
    let (ex, mut rx) = executor(store, 1);
    let summary = ex.run(vec![spec]).await;
    assert!(summary.errors.is_empty(), "{:?}", summary.errors);
    assert_eq!(summary.records.len(), 1);
    (summary.records.into_iter().next().unwrap(), drain(&mut rx))
}

fn bad_response(o: &Outcome) -> ResponseProblem {
    match o {
        Outcome::BadResponse { problem, .. } => *problem,
        other => panic!("expected a bad response, got {other:?}"),
    }
}

#[tokio::test]
async fn every_outcome_class_is_produced_and_classified() {
    let out = tempfile::tempdir().unwrap();
    let store = RunStore::open(out.path()).unwrap();
    let specs = vec![
        spec(&store, "a", &["ok", "0.30472"]),
        spec(&store, "b", &["exit", "3"]),
        spec(&store, "c", &["failtext"]),
        spec(&store, "d", &["noresp"]),
        spec(&store, "e", &["emptyresp"]),
        spec(&store, "f", &["garbage"]),
        spec(&store, "g", &["selfkill", "9"]),
        spec(&store, "h", &["selfkill", "15"]),
    ];
    let keys: Vec<String> = specs.iter().map(|s| s.key.clone()).collect();
    let mut missing = specs[0].clone();
    missing.argv = vec!["/nonexistent/solver".into()];
    missing.key = "missing-solver".into();
    missing.dir = store.prepare("missing-solver", &[]).unwrap();

    let mut all = specs;
    all.push(missing);
    let (ex, _rx) = executor(&store, 4);
    let summary = ex.run(all).await;
    assert!(summary.errors.is_empty() && summary.cancelled.is_none(), "{summary:?}");
    let by_key = |k: &str| {
        summary
            .records
            .iter()
            .find(|r| r.key == k)
            .unwrap_or_else(|| panic!("no record for {k}"))
    };

    let ok = by_key(&keys[0]);
    assert_eq!(
        (&ok.outcome, ok.response, ok.attempts),
        (&Outcome::Success, Some(0.30472), 1)
    );
    assert_eq!(by_key(&keys[1]).outcome, Outcome::NonZeroExit { code: 3 });
    match &by_key(&keys[2]).outcome {
        // The solver exited 0 and wrote a valid response: the failure text alone marks it failed.
        Outcome::FailureText { file, line } => {
            assert_eq!(file, "lab.stdout");
            assert!(line.contains("E r r o r"), "{line}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(bad_response(&by_key(&keys[3]).outcome), ResponseProblem::Missing);
    assert_eq!(bad_response(&by_key(&keys[4]).outcome), ResponseProblem::Empty);
    assert_eq!(bad_response(&by_key(&keys[5]).outcome), ResponseProblem::Unparseable);
    assert_eq!(by_key(&keys[6]).outcome, Outcome::Signal { signal: 9 });
    assert_eq!(by_key(&keys[7]).outcome, Outcome::Signal { signal: 15 });
    assert_eq!(by_key("missing-solver").outcome, Outcome::NonZeroExit { code: 127 });
    let stderr = std::fs::read_to_string(store.run_dir("missing-solver").join("lab.stderr")).unwrap();
    assert!(stderr.contains("cannot start `/nonexistent/solver`"), "{stderr}");
    // Only the success carries a response.
    assert_eq!(summary.records.iter().filter(|r| r.response.is_some()).count(), 1);
}

fn retry_policy(max_attempts: u32, retry_on: Vec<OutcomeClass>) -> RetryPolicy {
    RetryPolicy {
        max_attempts,
        retry_on,
        backoff: Backoff::Fixed(Duration::from_millis(10)),
    }
}

#[tokio::test]
async fn retries_follow_the_policy() {
    let out = tempfile::tempdir().unwrap();
    let store = RunStore::open(out.path()).unwrap();

    // Fails twice, succeeds on the third attempt; one Retrying event per failed attempt.
    let mut s = spec(&store, "1", &["flaky", "2", "7.5"]);
    s.retry = retry_policy(3, vec![OutcomeClass::NonZeroExit]);
    let key = s.key.clone();
    let (rec, events) = run_one(&store, s).await;
    assert_eq!(
        (&rec.outcome, rec.response, rec.attempts),
        (&Outcome::Success, Some(7.5), 3)
    );
    let retrying: Vec<u32> = events
        .iter()
        .filter_map(|e| match e {
            Event::Retrying {
                key: k,
                attempt,
                outcome,
                ..
            } if *k == key => {
                assert_eq!(outcome, &Outcome::NonZeroExit { code: 1 });
                Some(*attempt)
            }
            _ => None,
        })
        .collect();
    assert_eq!(retrying, vec![1, 2]);
    assert!(matches!(events.last(), Some(Event::Finished { .. })), "{events:?}");

    // Too few attempts: the last failure is the record.
    let mut s = spec(&store, "2", &["flaky", "2", "7.5"]);
    s.retry = retry_policy(2, vec![OutcomeClass::NonZeroExit]);
    let (rec, _) = run_one(&store, s).await;
    assert_eq!((&rec.outcome, rec.attempts), (&Outcome::NonZeroExit { code: 1 }, 2));

    // A class not listed is final at once.
    let mut s = spec(&store, "3", &["flaky", "2", "7.5"]);
    s.retry = retry_policy(5, vec![OutcomeClass::Timeout]);
    let (rec, _) = run_one(&store, s).await;
    assert_eq!((&rec.outcome, rec.attempts), (&Outcome::NonZeroExit { code: 1 }, 1));
}

// The timeout tests use a 1 s timeout so that python has started and written its pid files well
// before it fires (it needs ~50 ms); the pid files are checked to exist, so a too-early kill fails
// the test instead of passing it vacuously.
#[tokio::test]
async fn timeout_kills_the_solver_and_its_grandchild() {
    let out = tempfile::tempdir().unwrap();
    let store = RunStore::open(out.path()).unwrap();
    let mut s = spec(&store, "t", &["hang"]);
    s.timeout = Some(Duration::from_secs(1));
    let dir = s.dir.clone();
    let (rec, _) = run_one(&store, s).await;
    assert_eq!(rec.outcome, Outcome::Timeout);
    assert_eq!(rec.response, None);
    for name in ["solver.pid", "grandchild.pid"] {
        let pid = read_pid(&dir.join(name));
        assert!(
            wait_gone(pid, Duration::from_secs(2)),
            "{name} {pid} still alive after the timeout"
        );
    }
}

#[tokio::test]
async fn timeout_escalates_to_sigkill_when_sigterm_is_ignored() {
    let out = tempfile::tempdir().unwrap();
    let store = RunStore::open(out.path()).unwrap();
    let mut s = spec(&store, "t", &["stubborn"]);
    s.timeout = Some(Duration::from_secs(1));
    let dir = s.dir.clone();
    let (mut ex, _rx) = executor(&store, 1);
    ex.grace = Duration::from_millis(300);
    let summary = ex.run(vec![s]).await;
    assert_eq!(summary.records[0].outcome, Outcome::Timeout);
    for name in ["solver.pid", "grandchild.pid"] {
        let pid = read_pid(&dir.join(name));
        assert!(
            wait_gone(pid, Duration::from_secs(2)),
            "{name} {pid} survived SIGTERM + SIGKILL"
        );
    }
}

#[tokio::test]
async fn cancel_keeps_finished_results_and_ends_running_children() {
    let out = tempfile::tempdir().unwrap();
    let store = RunStore::open(out.path()).unwrap();
    let quick = vec![spec(&store, "q1", &["ok", "1"]), spec(&store, "q2", &["ok", "2"])];
    let slow: Vec<RunSpec> = (0..3)
        .map(|i| spec(&store, &format!("s{i}"), &["slow", "60", "9"]))
        .collect();
    let never = spec(&store, "never", &["ok", "3"]);
    let mut all = quick.clone();
    all.extend(slow.iter().cloned());
    all.push(never.clone());

    // 3 slots: the quick runs finish, then the three slow runs hold every slot, so `never` waits.
    let (mut ex, mut rx) = executor(&store, 3);
    ex.grace = Duration::from_secs(2);
    let canceller = ex.canceller.clone();
    let slow_pids: Vec<_> = slow.iter().map(|s| s.dir.join("solver.pid")).collect();
    let driver = async {
        let mut finished = 0;
        while finished < 2 {
            if let Some(Event::Finished { .. }) = rx.recv().await {
                finished += 1;
            }
        }
        for p in &slow_pids {
            assert!(
                wait_for_file(p, Duration::from_secs(10)).await,
                "slow run never started: {}",
                p.display()
            );
        }
        canceller.cancel(CancelReason::Signal);
    };
    let (summary, ()) = tokio::join!(ex.run(all), driver);

    assert_eq!(summary.cancelled, Some(CancelReason::Signal));
    assert!(summary.errors.is_empty(), "{:?}", summary.errors);
    let mut committed: Vec<&str> = summary.records.iter().map(|r| r.key.as_str()).collect();
    committed.sort();
    let mut expected: Vec<&str> = quick.iter().map(|s| s.key.as_str()).collect();
    expected.sort();
    assert_eq!(committed, expected);
    let mut interrupted = summary.interrupted.clone();
    interrupted.sort();
    let mut slow_keys: Vec<String> = slow.iter().map(|s| s.key.clone()).collect();
    slow_keys.sort();
    assert_eq!(interrupted, slow_keys);
    assert_eq!(summary.not_started, vec![never.key.clone()]);
    for p in &slow_pids {
        let pid = read_pid(p);
        assert!(
            wait_gone(pid, Duration::from_secs(2)),
            "slow solver {pid} still alive after cancel"
        );
    }
    drop(store);

    // On disk: exactly the finished results; the interrupted runs are half-done and get cleaned.
    let store = RunStore::open(out.path()).unwrap();
    let mut on_disk: Vec<&str> = store.records().map(|r| r.key.as_str()).collect();
    on_disk.sort();
    assert_eq!(on_disk, expected);
    assert!(quick.iter().all(|s| store.is_finished(&s.key)));
    let mut cleaned = store.cleaned().to_vec();
    cleaned.sort();
    let mut unfinished = slow_keys.clone();
    unfinished.push(never.key.clone());
    unfinished.sort();
    assert_eq!(cleaned, unfinished);
}
