//! Writing results: `results.json` and the terminal summary.
