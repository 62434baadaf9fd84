//! The solver runs a seeded family spends, beside those of the fixed design it used before
//! (issue 30): each case's `sampling.replaces.runs` counts that design's runs on the same case
//! without running them.

use serde_json::Value;

thread_local! {
    /// Solver runs made by this thread's cases: each test runs on a thread of its own, so a
    /// family's total is not swollen by another test running beside it.
    static RUNS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// The runs the fixed design would have made on the same cases.
    static FIXED: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// Adds a case's runs, and those its fixed design would have made, to this thread's tallies.
pub fn tally(results: &Value, runs: u64) {
    RUNS.with(|n| n.set(n.get() + runs));
    let fixed = results["sampling"]["replaces"]["runs"].as_u64().unwrap_or(0);
    FIXED.with(|n| n.set(n.get() + fixed));
}

/// This thread's solver runs so far.
pub fn runs() -> u64 {
    RUNS.with(std::cell::Cell::get)
}

/// A sequential family spends at most a third of the runs its fixed design `fixed_design` would
/// have (not asserted when `LAB_FAMILY_SAMPLING` sets another sampling).
pub fn assert_a_third_of(fixed_design: &str) {
    let (runs, fixed) = (runs(), FIXED.with(std::cell::Cell::get));
    eprintln!("{runs} solver runs where the fixed design {fixed_design} would have made {fixed}");
    if std::env::var("LAB_FAMILY_SAMPLING").is_err() {
        assert!(
            fixed > 0 && runs * 3 <= fixed,
            "{runs} runs against the fixed design's {fixed}"
        );
    }
}

/// `f` over `items` on as many threads as the machine has cores, the results in the items' order:
/// a family's cases are independent `lab run`s, each using less than the machine. The runs each
/// call tallies on its worker thread are added to this thread's tallies.
pub fn in_parallel<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .min(items.len().max(1));
    let next = AtomicUsize::new(0);
    let mut out: Vec<(usize, R, u64, u64)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(item) = items.get(i) else { break done };
                        let before = (runs(), FIXED.with(std::cell::Cell::get));
                        let r = f(item);
                        let after = (runs(), FIXED.with(std::cell::Cell::get));
                        done.push((i, r, after.0 - before.0, after.1 - before.1));
                    }
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    out.sort_by_key(|o| o.0);
    out.into_iter()
        .map(|(_, r, made, fixed)| {
            RUNS.with(|n| n.set(n.get() + made));
            FIXED.with(|n| n.set(n.get() + fixed));
            r
        })
        .collect()
}
