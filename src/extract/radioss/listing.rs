//! OpenRadioss's listings: the starter's `<root>_0000.out` and the engine's `<root>_0001.out`.
//!
//! What a run is judged by:
//! - the starter's summary, `N ERROR(S)` and `N WARNING(S)` near the end of its listing;
//! - each message block, a line `ERROR ID :   N` or `WARNING ID :   N` at the start of a line
//!   followed by its title (`** WARNING: INITIAL PENETRATIONS IN INTERFACE`); the summary table
//!   that repeats them inside `|` borders is not counted again;
//! - in the engine's listing, `NORMAL TERMINATION`, `ERROR TERMINATION`, and the lines that say
//!   why a run stopped before its termination time (`** RUN STOPPED: ENERGY ERROR LIMIT REACHED`,
//!   `USER BREAK`): the engine ends such a run with `NORMAL TERMINATION` too;
//! - engine messages: lines starting `** ERROR` / `** WARNING` (after blanks).
//!
//! Line numbers are 1-based.

use std::collections::BTreeMap;

/// One message block of a listing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    pub line: usize,
    pub error: bool,
    /// The `ID :` number, when the listing gives one.
    pub id: Option<u32>,
    pub title: String,
}

/// What a listing says about its run.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Listing {
    /// The starter's `N ERROR(S)` (none in the engine's listing).
    pub error_count: Option<usize>,
    /// The starter's `N WARNING(S)`.
    pub warning_count: Option<usize>,
    pub messages: Vec<Message>,
    /// Line of `NORMAL TERMINATION`.
    pub normal_termination: Option<usize>,
    /// Line of `ERROR TERMINATION`.
    pub error_termination: Option<usize>,
    /// Why the run stopped early: the line and its text (`RUN STOPPED: ...`, `USER BREAK`).
    pub stopped: Option<(usize, String)>,
}

/// Reads a listing's text.
pub fn parse(text: &str) -> Listing {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Listing::default();
    for (i, raw) in lines.iter().enumerate() {
        let line = raw.trim();
        if let Some(n) = count_before(line, "ERROR(S)") {
            out.error_count = Some(n);
        } else if let Some(n) = count_before(line, "WARNING(S)") {
            out.warning_count = Some(n);
        } else if line == "NORMAL TERMINATION" {
            out.normal_termination = Some(i + 1);
        } else if line == "ERROR TERMINATION" {
            out.error_termination = Some(i + 1);
        } else if line.starts_with("** RUN STOPPED") || line == "USER BREAK" {
            out.stopped
                .get_or_insert((i + 1, line.trim_start_matches("** ").to_string()));
        } else if let Some(m) = message(&lines, i) {
            out.messages.push(m);
        }
    }
    out
}

/// `N WORD` alone on a line (the starter's summary).
fn count_before(line: &str, word: &str) -> Option<usize> {
    let mut parts = line.split_whitespace();
    let n = parts.next()?.parse().ok()?;
    (parts.next() == Some(word) && parts.next().is_none()).then_some(n)
}

/// A message block starting at line `i`: `WARNING ID : N` / `ERROR ID : N` at the start of the
/// line with its title on the next, or an engine line `** WARNING ...` / `** ERROR ...`.
fn message(lines: &[&str], i: usize) -> Option<Message> {
    let raw = lines[i];
    for (word, error) in [("WARNING", false), ("ERROR", true)] {
        if let Some(rest) = raw.strip_prefix(word).and_then(|r| r.trim_start().strip_prefix("ID")) {
            let id = rest.trim_start().strip_prefix(':')?.trim().parse().ok()?;
            let title = lines.get(i + 1).map_or("", |t| t.trim()).trim_start_matches("** ");
            return Some(Message {
                line: i + 1,
                error,
                id: Some(id),
                title: title.to_string(),
            });
        }
        let t = raw.trim_start();
        if t.starts_with(&format!("** {word}")) && !lines.get(i.wrapping_sub(1)).is_some_and(|p| p.starts_with(word)) {
            return Some(Message {
                line: i + 1,
                error,
                id: None,
                title: t.trim_start_matches("** ").to_string(),
            });
        }
    }
    None
}

impl Listing {
    /// The warnings, each distinct (id, title) once with how often it occurs, in order of first
    /// appearance: `"3 × WARNING 343: WARNING: INITIAL PENETRATIONS IN INTERFACE"`.
    pub fn warnings(&self) -> Vec<String> {
        let mut order: Vec<(Option<u32>, &str)> = Vec::new();
        let mut counts: BTreeMap<(Option<u32>, &str), usize> = BTreeMap::new();
        for m in self.messages.iter().filter(|m| !m.error) {
            let k = (m.id, m.title.as_str());
            if !counts.contains_key(&k) {
                order.push(k);
            }
            *counts.entry(k).or_default() += 1;
        }
        order
            .into_iter()
            .map(|k| {
                let id = k.0.map(|i| format!(" {i}")).unwrap_or_default();
                format!("{} × WARNING{id}: {}", counts[&k], k.1)
            })
            .collect()
    }

    /// The first error message, as `line: title`.
    pub fn first_error(&self) -> Option<&Message> {
        self.messages.iter().find(|m| m.error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STARTER: &str = "\
 DOMAIN DECOMPOSITION
WARNING ID :   1084
** WARNING IN MATERIAL LAW1
DESCRIPTION :
WARNING ID :    343
** WARNING: INITIAL PENETRATIONS IN INTERFACE
WARNING ID :    343
** WARNING: INITIAL PENETRATIONS IN INTERFACE
|       |---     2 WARNING ID :          343               |
|       | ** WARNING: INITIAL PENETRATIONS IN INTERFACE    |

              0 ERROR(S)
              3 WARNING(S)
";

    #[test]
    fn starter_counts_and_distinct_warnings() {
        let l = parse(STARTER);
        assert_eq!(l.error_count, Some(0));
        assert_eq!(l.warning_count, Some(3));
        assert_eq!(l.messages.len(), 3, "{:?}", l.messages);
        assert_eq!(
            l.warnings(),
            [
                "1 × WARNING 1084: WARNING IN MATERIAL LAW1",
                "2 × WARNING 343: WARNING: INITIAL PENETRATIONS IN INTERFACE"
            ]
        );
        assert!(l.first_error().is_none());
    }

    #[test]
    fn engine_termination_and_early_stop() {
        let text = "   CYCLE    TIME  ERROR\n ** RUN STOPPED: ENERGY ERROR LIMIT REACHED\n\n     NORMAL TERMINATION\n     USER BREAK\n";
        let l = parse(text);
        assert_eq!(l.normal_termination, Some(4));
        assert_eq!(l.stopped, Some((2, "RUN STOPPED: ENERGY ERROR LIMIT REACHED".into())));
        assert!(l.messages.is_empty());
        let e = parse("ERROR ID :     12\n** ERROR IN INPUT\n\n      1 ERROR(S)\n");
        assert_eq!(e.error_count, Some(1));
        assert_eq!(
            e.first_error().map(|m| (m.line, m.title.as_str())),
            Some((1, "ERROR IN INPUT"))
        );
    }
}
