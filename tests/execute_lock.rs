//! The output-directory lock: a second holder is refused with the first one named; a SIGKILLed
//! holder does not leave the directory stuck.
//!
//! The holder in the cross-process test is this test binary itself, re-run with only
//! `lock_holder_child` selected and `LAB_TEST_LOCK_DIR` set: so the lock is taken by `lab`'s own code
//! in a process that can be SIGKILLed.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use lab::execute::store::StoreError;
use lab::execute::{LockError, OutLock, RunStore};

const ENV: &str = "LAB_TEST_LOCK_DIR";

/// Not a test on its own: does nothing unless started by `sigkilled_holder_does_not_leave_the_lock_stuck`.
#[test]
fn lock_holder_child() {
    let Ok(dir) = std::env::var(ENV) else { return };
    let _lock = OutLock::acquire(Path::new(&dir)).expect("child takes the lock");
    std::fs::write(Path::new(&dir).join("ready"), b"").unwrap();
    std::thread::sleep(Duration::from_secs(60));
}

#[test]
fn second_opener_is_refused_naming_the_holder() {
    let out = tempfile::tempdir().unwrap();
    let first = RunStore::open(out.path()).unwrap();
    let err = RunStore::open(out.path()).unwrap_err();
    match &err {
        StoreError::Lock(LockError::Held { holder: Some(h), .. }) => {
            assert_eq!(h.pid, std::process::id());
            assert!(!h.host.is_empty());
        }
        other => panic!("expected a held lock, got {other:?}"),
    }
    let message = err.to_string();
    assert!(message.contains(&format!("pid {}", std::process::id())), "{message}");
    assert!(message.contains("another lab is running"), "{message}");
    drop(first);
    RunStore::open(out.path()).expect("free again once the holder is dropped");
}

#[test]
fn sigkilled_holder_does_not_leave_the_lock_stuck() {
    let out = tempfile::tempdir().unwrap();
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "execute_lock::lock_holder_child",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(ENV, out.path())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !out.path().join("ready").exists() {
        assert!(start.elapsed() < Duration::from_secs(10), "holder never took the lock");
        std::thread::sleep(Duration::from_millis(10));
    }
    match OutLock::acquire(out.path()) {
        Err(LockError::Held { holder: Some(h), .. }) => assert_eq!(h.pid, child.id()),
        other => panic!("expected the child to hold the lock, got {other:?}"),
    }
    child.kill().unwrap(); // SIGKILL: no destructor runs in the child
    child.wait().unwrap();
    let lock = OutLock::acquire(out.path()).expect("the lock dies with its SIGKILLed holder");
    let text = std::fs::read_to_string(lock.path()).unwrap();
    assert!(
        text.contains(&format!("\"pid\":{}", std::process::id())),
        "lock file names the new holder: {text}"
    );
}
