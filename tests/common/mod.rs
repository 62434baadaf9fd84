//! Helpers shared by the bad-input test files.

use std::path::Path;

use lab::error::InputError;

/// Column (from 1) of the first `needle` on line `line` (from 1) of `text`.
pub fn column_of(text: &str, line: usize, needle: &str) -> usize {
    let l = text.lines().nth(line - 1).unwrap();
    l[..l
        .find(needle)
        .unwrap_or_else(|| panic!("`{needle}` not on line {line}: {l}"))]
        .chars()
        .count()
        + 1
}

/// Asserts the error names `file`, `line`, `column` (if given), contains `phrase`, and shows the
/// offending line with a caret.
#[track_caller]
pub fn assert_located(err: &InputError, file: &Path, line: usize, column: Option<usize>, phrase: &str) {
    let shown = err.to_string();
    assert_eq!(err.file, file, "wrong file in:\n{shown}");
    let span = err.span.as_ref().unwrap_or_else(|| panic!("no line in:\n{shown}"));
    assert_eq!(span.line, line, "wrong line in:\n{shown}");
    if let Some(column) = column {
        assert_eq!(span.column, column, "wrong column in:\n{shown}");
    }
    assert!(shown.contains(phrase), "`{phrase}` not in:\n{shown}");
    assert!(
        err.excerpt.as_deref().is_some_and(|e| e.contains('^')),
        "no caret in:\n{shown}"
    );
}
