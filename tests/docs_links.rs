//! The documentation says only what is there: README.md and every page of docs/ are read as
//! GitHub renders them, and
//!
//! - every relative link and image (`[text](path)`, `[text](path#anchor)`, `[text](#anchor)`)
//!   resolves to a file inside the repository, and every anchor to a heading of the page it names,
//!   spelled as GitHub spells heading anchors (the heading's text, lower case, without punctuation
//!   other than `-` and `_`, spaces as `-`, a repeated heading suffixed `-1`, `-2`, …);
//! - every path of the repository named in a code span (`` `tests/foo.rs` ``, `` `src/diagnose/mod.rs` ``:
//!   a span that starts with one of the repository's top-level directories) exists;
//! - every study file shown in a fenced ```` ```yaml ```` block is one `lab check` accepts;
//! - every `lab` command in a fenced ```` ```sh ```` block (`lab SUB ...`, `target/release/lab SUB ...`
//!   or `cargo run --release -- SUB ...`) names a subcommand that `lab --help` lists, with only
//!   options that `lab SUB --help` lists, and the `studies/`, `fixtures/` and `scripts/` paths it
//!   names exist.
//!
//! **Which yaml blocks are studies.** A block with both `name:` and `simulation:` at the start of a
//! line (top-level keys) is a whole study; any other yaml block is a fragment of one and is not
//! checked. A study is checked as if it were a file in `studies/`: paths inside it are relative to
//! `studies/`, as in the repository's own studies (`../fixtures/...`, `cantilever-tests.csv`). It
//! is written into a scratch copy of the repository (a temporary directory whose entries are
//! symbolic links to the repository's, with a real `studies/` of links beside the new file), so
//! nothing is written into the repository. A block whose first line is a comment starting with
//! `# error example` shows bad input on purpose: `lab check` must reject it with exit code 2 and
//! an error naming the file.
//!
//! Every check is first shown to fail on a small synthetic page with the fault it looks for, passed
//! to the same function. Deterministic and fast: no network, `lab check` spawned once per study
//! shown (well under a second each).

use std::collections::{BTreeSet, HashSet};
use std::path::{Component, Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

use regex::Regex;

/// The README's first commands, exactly: the front page's promise to a new user.
const FIRST_COMMANDS: &str = "cargo run --release -- run studies/honeycomb.yaml    # the main job: the paper's honeycomb crush (Sec. 4)\n\
cargo test --release                                 # the tests\n";

/// The marker of a yaml block that shows bad input on purpose.
const ERROR_EXAMPLE: &str = "# error example";

/// Top-level directories whose paths, named in a code span, must exist.
const REPOSITORY_DIRS: [&str; 14] = [
    "src/",
    "tests/",
    "scripts/",
    "studies/",
    "fixtures/",
    "templates/",
    "benches/",
    "examples/",
    "docs/",
    "crushsim/",
    "lsda/",
    "radioss-th/",
    ".ci/",
    "README.md",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and docs/*.md, relative to the repository root, in order.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![PathBuf::from("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .expect("docs/ exists")
        .map(|e| e.expect("a docs/ entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .map(|p| Path::new("docs").join(p.file_name().expect("a file name")))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

fn read(rel: &Path) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{}: {e}", rel.display()))
}

// ---- reading a page ----

/// A fenced code block: its info string (`sh`, `yaml`, …), the line of its first content line, and
/// its text.
#[derive(Debug)]
struct Block {
    lang: String,
    line: usize,
    text: String,
}

/// A page as the checks see it: prose paragraphs (lines joined, with the line each starts on),
/// headings, and fenced blocks.
#[derive(Debug, Default)]
struct Doc {
    paragraphs: Vec<(usize, String)>,
    headings: Vec<String>,
    blocks: Vec<Block>,
}

fn fence(line: &str) -> Option<&str> {
    let t = line.trim_start();
    let indent = line.len() - t.len();
    (indent <= 3 && (t.starts_with("```") || t.starts_with("~~~"))).then(|| t.trim_start_matches(['`', '~']).trim())
}

fn parse(text: &str) -> Doc {
    let mut doc = Doc::default();
    let mut open: Option<Block> = None;
    let mut para: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        if let Some(b) = open.as_mut() {
            if fence(line).is_some() {
                doc.blocks.extend(open.take());
            } else {
                b.text.push_str(line);
                b.text.push('\n');
            }
            continue;
        }
        if let Some(lang) = fence(line) {
            doc.paragraphs.extend(para.take());
            open = Some(Block {
                lang: lang.split_whitespace().next().unwrap_or("").to_string(),
                line: n + 1,
                text: String::new(),
            });
            continue;
        }
        if let Some(h) = heading(line) {
            doc.paragraphs.extend(para.take());
            doc.headings.push(h.to_string());
            doc.paragraphs.push((n, h.to_string()));
            continue;
        }
        if line.trim().is_empty() {
            doc.paragraphs.extend(para.take());
            continue;
        }
        match para.as_mut() {
            Some((_, p)) => {
                p.push(' ');
                p.push_str(line.trim());
            }
            None => para = Some((n, line.trim().to_string())),
        }
    }
    doc.paragraphs.extend(para);
    assert!(open.is_none(), "a fenced block is never closed");
    doc
}

/// An ATX heading's text (`## Text` → `Text`).
fn heading(line: &str) -> Option<&str> {
    let hashes = line.len() - line.trim_start_matches('#').len();
    let rest = &line[hashes..];
    ((1..=6).contains(&hashes) && rest.starts_with(' ')).then(|| rest.trim().trim_end_matches('#').trim())
}

/// The code spans of a paragraph (their content), and the paragraph with each replaced by `code`.
fn code_spans(p: &str) -> (Vec<String>, String) {
    let mut spans = Vec::new();
    let mut out = String::new();
    let mut rest = p;
    while let Some(start) = rest.find('`') {
        let ticks = rest[start..].len() - rest[start..].trim_start_matches('`').len();
        let fence = &rest[start..start + ticks];
        let after = &rest[start + ticks..];
        let Some(end) = find_run(after, ticks) else {
            break;
        };
        out.push_str(&rest[..start]);
        out.push_str("code");
        spans.push(after[..end].trim().to_string());
        rest = &after[end + fence.len()..];
    }
    out.push_str(rest);
    (spans, out)
}

/// The first run of exactly `n` backticks in `s`.
fn find_run(s: &str, n: usize) -> Option<usize> {
    let b = s.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'`' {
            let mut j = i;
            while j < b.len() && b[j] == b'`' {
                j += 1;
            }
            if j - i == n {
                return Some(i);
            }
            i = j;
        } else {
            i += 1;
        }
    }
    None
}

// ---- anchors and links ----

/// The anchor GitHub gives a heading: its rendered text (code spans' content, links' text, no
/// emphasis marks), lower case, every character that is not a letter, mark, number, connector
/// (`_`), `-` or space removed, spaces turned into `-`.
fn slug(heading: &str) -> String {
    let links = Regex::new(r"!?\[([^\]]*)\]\([^)]*\)").expect("a regex");
    let text = links.replace_all(heading, "$1");
    let text = text.replace('`', "");
    let keep = Regex::new(r"[^\p{L}\p{M}\p{N}\p{Pc} -]").expect("a regex");
    keep.replace_all(&text.to_lowercase(), "").replace(' ', "-")
}

/// Every anchor of a page: its headings' slugs, a repeated one suffixed `-1`, `-2`, ….
fn anchors(doc: &Doc) -> HashSet<String> {
    let mut seen = HashSet::new();
    for h in &doc.headings {
        let base = slug(h);
        let mut a = base.clone();
        let mut k = 0;
        while seen.contains(&a) {
            k += 1;
            a = format!("{base}-{k}");
        }
        seen.insert(a);
    }
    seen
}

/// The relative link targets of a page (images included), with the line each paragraph starts on.
fn links(doc: &Doc) -> Vec<(usize, String)> {
    let re = Regex::new(r#"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)"#).expect("a regex");
    let mut out = Vec::new();
    for (line, p) in &doc.paragraphs {
        let (_, prose) = code_spans(p);
        for c in re.captures_iter(&prose) {
            let target = c[1].to_string();
            let external = target.contains("://") || target.starts_with("mailto:");
            if !external {
                out.push((*line, target));
            }
        }
    }
    out
}

/// `base/rel` with `.` and `..` resolved, or `None` when it leaves the repository.
fn resolve(base: &Path, rel: &str) -> Option<PathBuf> {
    let mut parts: Vec<String> = base
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    for c in Path::new(rel).components() {
        match c {
            Component::Normal(s) => parts.push(s.to_string_lossy().into_owned()),
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::CurDir => {}
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    Some(parts.iter().collect())
}

/// What is wrong with the links of page `rel` (its text `text`): targets that are missing or
/// outside the repository, anchors that no heading of their page gives.
fn link_problems(rel: &Path, text: &str) -> Vec<String> {
    let doc = parse(text);
    let dir = rel.parent().unwrap_or(Path::new(""));
    let mut problems = Vec::new();
    for (line, target) in links(&doc) {
        let at = format!("{}:{line}: link `{target}`", rel.display());
        let (file, anchor) = match target.split_once('#') {
            Some((f, a)) => (f, Some(a)),
            None => (target.as_str(), None),
        };
        let page = if file.is_empty() {
            rel.to_path_buf()
        } else {
            match resolve(dir, file) {
                Some(p) if root().join(&p).exists() => p,
                Some(p) => {
                    problems.push(format!("{at}: {} does not exist", p.display()));
                    continue;
                }
                None => {
                    problems.push(format!("{at}: leaves the repository"));
                    continue;
                }
            }
        };
        let Some(anchor) = anchor else { continue };
        if page.extension().is_none_or(|e| e != "md") {
            problems.push(format!(
                "{at}: an anchor into {}, which is not a Markdown page",
                page.display()
            ));
            continue;
        }
        let target_doc = if page == rel { parse(text) } else { parse(&read(&page)) };
        if !anchors(&target_doc).contains(anchor) {
            problems.push(format!(
                "{at}: no heading of {} has the anchor `#{anchor}`",
                page.display()
            ));
        }
    }
    problems
}

/// Code spans naming a path of the repository (see [`REPOSITORY_DIRS`]) that does not exist.
/// Spans with placeholders (`<key>`, `{design}`, `*`) or spaces are not paths and are skipped;
/// `path::item` and `path:line` name the path before the `:`.
fn path_problems(rel: &Path, text: &str) -> Vec<String> {
    let doc = parse(text);
    let mut problems = Vec::new();
    for (line, p) in &doc.paragraphs {
        let (spans, _) = code_spans(p);
        for span in spans {
            if !REPOSITORY_DIRS.iter().any(|d| span.starts_with(d)) || span.contains([' ', '<', '{', '*', '|']) {
                continue;
            }
            // What `lab run` writes beside a study (`lab-out/`) is output, not part of the repository.
            if span.contains("lab-out/") {
                continue;
            }
            let path = span.split(':').next().unwrap_or(&span);
            if !root().join(path).exists() {
                problems.push(format!("{}:{line}: `{span}`: {path} does not exist", rel.display()));
            }
        }
    }
    problems
}

// ---- studies ----

/// A scratch copy of the repository in which studies shown in the docs are written and checked.
struct Sandbox {
    dir: PathBuf,
}

impl Sandbox {
    fn new() -> Sandbox {
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "lab-docs-links-{}-{}",
            std::process::id(),
            COUNT.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("studies")).expect("a scratch directory");
        for entry in std::fs::read_dir(root()).expect("the repository") {
            let entry = entry.expect("an entry");
            let name = entry.file_name();
            if name == "studies" || name == "target" || name == ".git" {
                continue;
            }
            std::os::unix::fs::symlink(entry.path(), dir.join(&name)).expect("a link");
        }
        for entry in std::fs::read_dir(root().join("studies")).expect("studies/") {
            let entry = entry.expect("an entry");
            let name = entry.file_name();
            if name == "lab-out" {
                continue;
            }
            std::os::unix::fs::symlink(entry.path(), dir.join("studies").join(&name)).expect("a link");
        }
        Sandbox { dir }
    }
}

impl Drop for Sandbox {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Whether a yaml block is a whole study (top-level `name:` and `simulation:`).
fn is_study(block: &Block) -> bool {
    let top = |key: &str| block.text.lines().any(|l| l.starts_with(key));
    block.lang == "yaml" && top("name:") && top("simulation:")
}

/// What is wrong with the studies page `rel` shows: a study `lab check` rejects, or an error
/// example it accepts (or rejects without naming the file, or not with exit code 2).
fn study_problems(rel: &Path, text: &str, sandbox: &Sandbox) -> Vec<String> {
    let doc = parse(text);
    let mut problems = Vec::new();
    let stem = rel
        .file_stem()
        .map_or("page".into(), |s| s.to_string_lossy().into_owned());
    for block in doc.blocks.iter().filter(|b| is_study(b)) {
        let file = sandbox
            .dir
            .join("studies")
            .join(format!("docs-{stem}-{}.yaml", block.line));
        std::fs::write(&file, &block.text).expect("the study written");
        let out = Command::new(env!("CARGO_BIN_EXE_lab"))
            .arg("check")
            .arg(&file)
            .current_dir(&sandbox.dir)
            .output()
            .expect("lab runs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        let at = format!("{}:{}: the study shown", rel.display(), block.line);
        let error_example = block.text.trim_start().starts_with(ERROR_EXAMPLE);
        let named = stderr.contains(&file.file_name().expect("a name").to_string_lossy().into_owned());
        match (error_example, out.status.code()) {
            (false, Some(0)) => {}
            (false, code) => problems.push(format!("{at}: `lab check` rejects it (exit {code:?}):\n{stderr}")),
            (true, Some(2)) if named && stderr.starts_with("error: ") => {}
            (true, Some(0)) => problems.push(format!("{at}: marked `{ERROR_EXAMPLE}`, but `lab check` accepts it")),
            (true, code) => problems.push(format!(
                "{at}: an error example must give exit 2 and an error naming the file; got {code:?}:\n{stderr}"
            )),
        }
        let _ = std::fs::remove_file(&file);
    }
    problems
}

// ---- commands ----

/// `lab --help`'s subcommands, and the long options of each one's `--help`.
struct Help {
    subcommands: Vec<(String, BTreeSet<String>)>,
}

fn help_text(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_lab"))
        .args(args)
        .output()
        .expect("lab runs");
    assert!(out.status.success(), "lab {args:?} fails");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

impl Help {
    fn of_lab() -> Help {
        let top = help_text(&["--help"]);
        let names: Vec<String> = top
            .lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            .skip(1)
            .take_while(|l| !l.trim().is_empty())
            .filter_map(|l| l.split_whitespace().next().map(str::to_string))
            .filter(|n| n != "help")
            .collect();
        assert!(names.iter().any(|n| n == "run"), "`lab --help` lists no `run`:\n{top}");
        let option = Regex::new(r"--[a-z][a-z-]*").expect("a regex");
        let subcommands = names
            .into_iter()
            .map(|n| {
                let text = help_text(&[&n, "--help"]);
                let options = option.find_iter(&text).map(|m| m.as_str().to_string()).collect();
                (n, options)
            })
            .collect();
        Help { subcommands }
    }

    fn options(&self, sub: &str) -> Option<&BTreeSet<String>> {
        self.subcommands.iter().find(|(n, _)| n == sub).map(|(_, o)| o)
    }
}

/// The `lab` invocations of a shell line: each command's words after `lab` (or after `--` of
/// `cargo run`), leading `VAR=value` words, `nice -n N` and `time` skipped.
fn lab_invocations(line: &str) -> Vec<Vec<String>> {
    let line = match line.find(" #") {
        Some(i) => &line[..i],
        None if line.trim_start().starts_with('#') => "",
        None => line,
    };
    let line = line.trim_start().trim_start_matches("$ ");
    let mut out = Vec::new();
    for command in line.split("&&").flat_map(|c| c.split(';')).flat_map(|c| c.split('|')) {
        let words: Vec<&str> = command.split_whitespace().collect();
        let mut i = 0;
        while i < words.len() {
            match words[i] {
                w if w.contains('=') && !w.starts_with('-') => i += 1,
                "nice" => i += if words.get(i + 1) == Some(&"-n") { 3 } else { 1 },
                "time" | "env" => i += 1,
                _ => break,
            }
        }
        let Some(first) = words.get(i) else { continue };
        let is_lab = *first == "lab" || first.ends_with("/lab");
        let rest: Vec<String> = if is_lab {
            words[i + 1..].iter().map(|w| w.to_string()).collect()
        } else if *first == "cargo" && words.get(i + 1) == Some(&"run") {
            match words.iter().position(|w| *w == "--") {
                Some(d) => words[d + 1..].iter().map(|w| w.to_string()).collect(),
                None => continue,
            }
        } else {
            continue;
        };
        out.push(rest);
    }
    out
}

/// What is wrong with the `lab` commands page `rel` shows in its shell blocks.
fn command_problems(rel: &Path, text: &str, help: &Help) -> Vec<String> {
    let doc = parse(text);
    let mut problems = Vec::new();
    for block in doc
        .blocks
        .iter()
        .filter(|b| matches!(b.lang.as_str(), "sh" | "bash" | "shell" | "console"))
    {
        for (k, line) in block.text.lines().enumerate() {
            let at = format!("{}:{}", rel.display(), block.line + k);
            for words in lab_invocations(line) {
                let Some(sub) = words.first() else {
                    problems.push(format!("{at}: `lab` without a subcommand"));
                    continue;
                };
                let Some(options) = help.options(sub) else {
                    problems.push(format!("{at}: `lab {sub}`: `lab --help` lists no subcommand `{sub}`"));
                    continue;
                };
                for w in &words[1..] {
                    let w = w.trim_matches(['[', ']', '"', '\'']);
                    let flag = w.split('=').next().unwrap_or(w);
                    if flag.starts_with("--") && !options.contains(flag) {
                        problems.push(format!("{at}: `lab {sub}` has no option `{flag}`"));
                    }
                    let named = ["studies/", "fixtures/", "scripts/"].iter().any(|d| w.starts_with(d));
                    if named && !w.contains(['*', '<', '{']) && !root().join(w).exists() {
                        problems.push(format!("{at}: `lab {sub}` names {w}, which does not exist"));
                    }
                }
            }
        }
    }
    problems
}

#[track_caller]
fn assert_none(problems: &[String]) {
    assert!(
        problems.is_empty(),
        "{} problem(s):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

// ---- the tests ----

#[test]
fn anchors_are_spelled_as_github_spells_them() {
    assert_eq!(
        slug("How a diagnosis reaches its verdict"),
        "how-a-diagnosis-reaches-its-verdict"
    );
    assert_eq!(
        slug("Discovering a missing term (`diagnosis.discover`)"),
        "discovering-a-missing-term-diagnosisdiscover"
    );
    assert_eq!(
        slug("LS-DYNA decks (`adapter: lsdyna`)"),
        "ls-dyna-decks-adapter-lsdyna"
    );
    assert_eq!(slug("The noise: σ² = a² + (b·y)²"), "the-noise-σ²--a²--by²");
    assert_eq!(slug("`results.json` `sampling`"), "resultsjson-sampling");
    assert_eq!(slug("Record and replay"), "record-and-replay");
    let doc = parse("# A\n\n## Same\n\n## Same\n\n```sh\n# not a heading\n```\n");
    let a = anchors(&doc);
    for want in ["a", "same", "same-1"] {
        assert!(a.contains(want), "{want} not in {a:?}");
    }
    assert!(!a.contains("not-a-heading"), "a comment in a code block is no heading");
}

#[test]
fn every_relative_link_and_anchor_resolves() {
    // The checker sees each fault it looks for.
    let synthetic = "# Page\n\nSee [the verdict](#no-such-heading), [a page](missing.md), \
        [outside](../../etc/passwd), [binout](binout.md#no-such-anchor), [a file](../src/main.rs#L3) \
        and [this one](#page).\n\n```text\n[not a link](#inside-code)\n```\n\nAlso `[code](#nope)`.\n";
    let found = link_problems(Path::new("docs/synthetic.md"), synthetic);
    let expect = [
        "#no-such-heading",
        "missing.md",
        "leaves the repository",
        "#no-such-anchor",
        "not a Markdown page",
    ];
    assert_eq!(found.len(), expect.len(), "{found:#?}");
    for (f, e) in found.iter().zip(expect) {
        assert!(f.contains(e), "`{e}` not in `{f}`");
    }
    // A link wrapped over two lines is still one link.
    let wrapped = "Read [how a\nverdict is reached](#nowhere).\n";
    assert_eq!(link_problems(Path::new("docs/synthetic.md"), wrapped).len(), 1);

    let mut problems = Vec::new();
    for page in pages() {
        problems.extend(link_problems(&page, &read(&page)));
        problems.extend(path_problems(&page, &read(&page)));
    }
    assert_none(&problems);
}

#[test]
fn repository_paths_in_code_spans_exist() {
    let synthetic = "The rule is in `src/diagnose/no_such.rs`, run by `tests/docs_links.rs`; `OUT/runs/<key>/` \
        and `src/extract/{grid,cfc}.rs` are patterns, `tests/loop_verdict.rs::seeds` an item.\n";
    let found = path_problems(Path::new("docs/synthetic.md"), synthetic);
    assert_eq!(found.len(), 1, "{found:#?}");
    assert!(found[0].contains("src/diagnose/no_such.rs"));
}

#[test]
fn every_study_shown_is_one_lab_check_accepts() {
    let sandbox = Sandbox::new();
    // A study with a typo, a study not marked as an error that is one, and an error example that
    // is none: three faults; the good study and the true error example are none.
    let good = "name: cantilever\nconstants: {F: 600, L: 20, b: 2}\ndesign:\n  h: {unit: mm}\n\
        parameters:\n  E: {min: 50000, max: 80000, unit: MPa}\nsimulation:\n  expression: \"4*F*L^3/(E*b*h^3)\"\n\
        experiments:\n  file: cantilever-tests.csv\n  response: deflection\ntraining: [h8, h10]\n";
    let typo = good.replace("(E*b", "(Ee*b");
    let page = format!(
        "# Studies\n\n```yaml\n{good}```\n\n```yaml\n{typo}```\n\n```yaml\n{ERROR_EXAMPLE}: a typo\n{typo}```\n\n\
         ```yaml\n{ERROR_EXAMPLE}: none\n{good}```\n\n```yaml\nsimulation:\n  expression: \"oops(\"\n```\n"
    );
    let found = study_problems(Path::new("docs/synthetic.md"), &page, &sandbox);
    assert_eq!(found.len(), 2, "{found:#?}");
    assert!(
        found[0].contains("rejects it") && found[0].contains("Ee"),
        "{}",
        found[0]
    );
    assert!(found[1].contains("accepts it"), "{}", found[1]);

    let mut problems = Vec::new();
    let mut studies = 0;
    for p in pages() {
        let text = read(&p);
        studies += parse(&text).blocks.iter().filter(|b| is_study(b)).count();
        problems.extend(study_problems(&p, &text, &sandbox));
    }
    assert_none(&problems);
    assert!(
        studies >= 3,
        "the docs show {studies} whole studies; the study reference shows at least three"
    );
    // Nothing was left in the scratch copy's studies/ but the links to the repository's.
    let left: Vec<_> = std::fs::read_dir(sandbox.dir.join("studies"))
        .expect("the scratch studies/")
        .filter_map(|e| e.ok())
        .filter(|e| !e.file_type().is_ok_and(|t| t.is_symlink()))
        .map(|e| e.file_name())
        .collect();
    assert!(left.is_empty(), "`lab check` wrote {left:?}");
}

#[test]
fn every_lab_command_shown_is_one_lab_has() {
    let help = Help::of_lab();
    let synthetic = "```sh\nlab frobnicate studies/honeycomb.yaml\nlab run studies/honeycomb.yaml --fast\n\
        PATH=x:$PATH cargo run --release -- run studies/no-such.yaml --jobs 2\n\
        lab check studies/honeycomb.yaml   # a comment --not-an-option\n\
        nice -n 10 target/release/lab status studies/honeycomb.yaml --out /tmp/x && lab report studies/honeycomb.yaml\n\
        cargo test --release --test docs_links\n```\n";
    let found = command_problems(Path::new("docs/synthetic.md"), synthetic, &help);
    let expect = [
        "no subcommand `frobnicate`",
        "no option `--fast`",
        "studies/no-such.yaml",
    ];
    assert_eq!(found.len(), expect.len(), "{found:#?}");
    for (f, e) in found.iter().zip(expect) {
        assert!(f.contains(e), "`{e}` not in `{f}`");
    }

    let mut problems = Vec::new();
    let mut commands = 0;
    for p in pages() {
        let text = read(&p);
        for b in parse(&text).blocks.iter().filter(|b| b.lang == "sh") {
            commands += b.text.lines().map(|l| lab_invocations(l).len()).sum::<usize>();
        }
        problems.extend(command_problems(&p, &text, &help));
    }
    assert_none(&problems);
    assert!(commands >= 10, "the docs show only {commands} `lab` commands");
}

#[test]
fn the_readme_starts_with_the_two_first_commands() {
    let readme = parse(&read(Path::new("README.md")));
    let first = readme.blocks.first().expect("the README has a code block");
    assert_eq!(first.lang, "sh");
    assert_eq!(first.text, FIRST_COMMANDS, "the README's first commands changed");
    let lines = read(Path::new("README.md")).lines().count();
    assert!(lines < 150, "the README is a front page: {lines} lines (under 150)");
}
