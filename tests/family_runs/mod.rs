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
        assert!(fixed > 0 && runs * 3 <= fixed, "{runs} runs against the fixed design's {fixed}");
    }
}
