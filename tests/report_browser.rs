//! The HTML report in a real browser: `lab run` then `lab report` (rebuilt from what is recorded)
//! on the closed-form cantilever, the diagnosis cantilever (every diagnosis plot), the solver
//! cantilever and the honeycomb study (replayed: force–displacement curves, every train/validate
//! split); each page opened in headless Chromium, a screenshot saved under
//! `target/tmp/report-screenshots/`, the DOM checked for every section and plot, the page's
//! errors (a hook injected into a copy of the page, and Chromium's console log) required empty.
//!
//! Without Chromium the browser part is skipped with a message, except under CI=true, where a
//! missing Chromium fails (`.ci/run` installs Debian's `chromium`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `lab` with the test's PATH, or with `path` (a PATH without crushsim makes the honeycomb study
/// replay its recordings).
fn lab(args: &[&str], path: Option<&str>) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_lab"));
    command.args(args).current_dir(repo());
    if let Some(path) = path {
        command.env("PATH", path);
    }
    command.output().expect("lab runs")
}

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("LAB_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

/// Records uncaught errors, failed resource loads and console.error calls, and the load time, into
/// a `<pre id=lab-test-hook>` appended at the load event.
const HOOK: &str = r#"<script>
window.__labErrors = [];
window.addEventListener('error', function (e) {
  window.__labErrors.push(e.message ? String(e.message) : 'failed to load ' + (e.target && (e.target.src || e.target.href)));
}, true);
(function () { var ce = console.error; console.error = function () {
  window.__labErrors.push(Array.prototype.join.call(arguments, ' ')); return ce.apply(console, arguments); }; })();
window.addEventListener('load', function () {
  var d = document.createElement('pre'); d.id = 'lab-test-hook';
  var a = document.getElementById('answer-verdict');
  var answer = a ? { top: a.getBoundingClientRect().top, bottom: a.getBoundingClientRect().bottom, text: a.innerText } : null;
  d.textContent = JSON.stringify({ errors: window.__labErrors, load_ms: performance.now(), answer: answer });
  document.body.appendChild(d);
});
</script>"#;

struct Case {
    study: &'static str,
    /// Figure ids expected on the page (each holds one <svg>).
    figures: &'static [&'static str],
    /// Text the page must show: units on axes and in tables, legends, split headings.
    texts: &'static [&'static str],
    /// PATH for `lab run`, when it must not be the test's.
    path: Option<&'static str>,
    /// Screenshot height in pixels: the whole page.
    height: u32,
}

const CASES: [Case; 5] = [
    Case {
        study: "cantilever",
        figures: &["posterior-E", "predictions", "splits", "residuals-h"],
        texts: &[
            "deflection (mm)",
            "no force–displacement curves were recorded",
            "posterior density (per MPa)",
        ],
        path: None,
        height: 4000,
    },
    Case {
        study: "cantilever-diagnosis",
        figures: &["predictions", "splits", "residuals-h", "candidates", "before-after"],
        texts: &["measured − predicted deflection (mm)"],
        path: None,
        height: 4000,
    },
    Case {
        study: "cantilever-command",
        figures: &[
            "surrogate-h8",
            "surrogate-h10",
            "surrogate-h13",
            "posterior-E",
            "predictions",
            "splits",
            "residuals-h",
        ],
        texts: &["deflection (mm)"],
        path: None,
        height: 4000,
    },
    Case {
        study: "honeycomb",
        figures: &[
            "fd-C6T5",
            "fd-C3T8",
            "fd-C3T7",
            "surrogate-C6T5",
            "surrogate-C3T8",
            "surrogate-C3T7",
            "posterior-sigma-y",
            "predictions",
            "splits",
            "residuals-c",
            "residuals-t",
            // Where along the stroke the model errs: the specimens' band with the curves before and
            // after, and the residual curves, per design.
            "stroke-C6T5",
            "stroke-C3T8",
            "stroke-C3T7",
            "stroke-residual-C6T5",
            "stroke-residual-C3T8",
            "stroke-residual-C3T7",
        ],
        texts: &[
            "force (kN)",
            "displacement (mm)",
            "stroke window 5–60 mm",
            "Where along the stroke the model errs",
            "tests: mean ± 2 s.d. (3 specimens)",
            "with 'strain hardening in the fold hinges'",
            "Decided by the plateau level",
            "in blue the recommended model (with 'strain hardening in the fold hinges'): the solver's run",
            "test C3T7-3",
            "uncorrected, run nearest the estimate: sigma_y = ",
            "1. train C6T5, C3T8 → validate C3T7",
            "2. train C6T5, C3T7 → validate C3T8",
            "3. train C3T7, C3T8 → validate C6T5",
            "<table id=split-table>",
        ],
        // No crushsim: the study replays fixtures/honeycomb.
        path: Some("/usr/bin:/bin"),
        height: 7200,
    },
    Case {
        study: "honeycomb-diagnosis",
        // The solver in the loop: its response over etan and the residuals before and after.
        figures: &[
            "predictions",
            "residuals-c",
            "residuals-t",
            "candidates",
            "loop-surface-strain-hardening",
            "loop-residuals-strain-hardening",
        ],
        texts: &[
            "<div id=verdict",
            "<ul id=evidence>",
            "<table id=rivals>",
            "<p id=next-test>",
            "<h3>Simulation in the loop</h3><table id=loop-table>",
        ],
        path: Some("/usr/bin:/bin"),
        height: 11000,
    },
];

const SECTIONS: [&str; 8] = [
    "answer",
    "study",
    "force-displacement",
    "surrogates",
    "calibration",
    "identifiability",
    "diagnosis",
    "runs",
];

/// Runs the study, then rebuilds the report from the recorded files; returns the out dir.
fn render(case: &Case, root: &Path) -> PathBuf {
    let out = root.join(case.study);
    let study = format!("studies/{}.yaml", case.study);
    let o = lab(&["run", &study, "--out", out.to_str().unwrap()], case.path);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}: {}",
        case.study,
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        out.join("report-data.json").is_file(),
        "lab run records report-data.json"
    );
    let written = std::fs::read(out.join("report.html")).unwrap();
    let started = Instant::now();
    let o = lab(&["report", &study, "--out", out.to_str().unwrap()], case.path);
    let took = started.elapsed();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let rebuilt = std::fs::read(out.join("report.html")).unwrap();
    assert!(
        written == rebuilt,
        "{}: `lab report` rebuilds the same page from the recorded data",
        case.study
    );
    let size = rebuilt.len();
    eprintln!(
        "{}: report.html {} kB, `lab report` {:.0} ms",
        case.study,
        size / 1024,
        took.as_secs_f64() * 1e3
    );
    assert!(
        size < 2 * 1024 * 1024,
        "{}: report is {size} bytes (limit 2 MB)",
        case.study
    );
    out
}

/// Static checks on the page as written: sections, figures, no external asset, no script.
fn check_html(case: &Case, html: &str, out: &Path) {
    for id in SECTIONS {
        assert!(
            html.contains(&format!("<section id={id}>")),
            "{}: section `{id}` missing",
            case.study
        );
    }
    for id in case.figures {
        let at = html
            .find(&format!("<figure class=plot id={id}>"))
            .unwrap_or_else(|| panic!("{}: figure `{id}` missing", case.study));
        assert!(
            html[at..].starts_with(&format!("<figure class=plot id={id}><svg")),
            "{}: figure `{id}` holds no <svg>",
            case.study
        );
    }
    for text in case.texts {
        assert!(html.contains(text), "{}: `{text}` not on the page", case.study);
    }
    // The loop table's runs are results.json's (succeeded / planned of each extension).
    let results: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    for x in results["diagnosis"]["extensions"].as_array().into_iter().flatten() {
        let cell = format!("<td>{} / {}</td>", x["runs"]["succeeded"], x["runs"]["planned"]);
        assert!(html.contains(&cell), "{}: `{cell}` not in the loop table", case.study);
    }
    for needle in ["<script", "src=", "http://", "https://", "<link", "@import", "url("] {
        assert!(
            !html.contains(needle),
            "{}: the page must be self-contained (found `{needle}`)",
            case.study
        );
    }
}

fn browser(chromium: &Path, user_data: &Path, extra: &[String], page: &Path) -> Output {
    let mut args: Vec<String> = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--disable-quic",
        "--disable-dev-shm-usage",
        "--enable-logging=stderr",
        "--v=0",
    ]
    .map(String::from)
    .to_vec();
    args.push(format!("--user-data-dir={}", user_data.display()));
    args.extend(extra.iter().cloned());
    args.push(format!("file://{}", page.display()));
    let o = Command::new(chromium).args(&args).output().expect("chromium starts");
    assert!(
        o.status.success(),
        "chromium {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Console errors in Chromium's log (`CONSOLE` lines at error level, or uncaught exceptions).
fn console_errors(stderr: &str) -> Vec<String> {
    stderr
        .lines()
        .filter(|l| {
            (l.contains("CONSOLE") && (l.contains(":ERROR:") || l.contains("Uncaught"))) || l.contains("Uncaught ")
        })
        .map(str::to_string)
        .collect()
}

#[test]
fn reports_render_in_chromium_with_every_section_and_plot() {
    let tmp = tempfile::tempdir().unwrap();
    let outs: Vec<PathBuf> = CASES.iter().map(|c| render(c, tmp.path())).collect();
    for (case, out) in CASES.iter().zip(&outs) {
        check_html(case, &std::fs::read_to_string(out.join("report.html")).unwrap(), out);
    }
    let Some(chromium) = chromium() else {
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!("CI=true but chromium is not installed: .ci/run must install Debian's `chromium`");
        }
        eprintln!("SKIPPED the browser part of the report test: no `chromium` on PATH (apt-get install chromium)");
        return;
    };
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("report-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    for (case, out) in CASES.iter().zip(&outs) {
        let html = std::fs::read_to_string(out.join("report.html")).unwrap();
        // A copy with the error hook at the top of <head>; the report itself carries no script.
        let hooked = out.join("report-hooked.html");
        std::fs::write(&hooked, html.replacen("<head>", &format!("<head>{HOOK}"), 1)).unwrap();

        let shot = shots.join(format!("{}.png", case.study));
        let _ = std::fs::remove_file(&shot);
        let o = browser(
            &chromium,
            &tmp.path().join(format!("profile-shot-{}", case.study)),
            &[
                format!("--screenshot={}", shot.display()),
                format!("--window-size=1280,{}", case.height),
                "--hide-scrollbars".into(),
            ],
            &out.join("report.html"),
        );
        assert!(
            shot.is_file(),
            "{}: no screenshot: {}",
            case.study,
            String::from_utf8_lossy(&o.stderr)
        );
        let errors = console_errors(&String::from_utf8_lossy(&o.stderr));
        assert!(errors.is_empty(), "{}: console errors: {errors:#?}", case.study);

        let o = browser(
            &chromium,
            &tmp.path().join(format!("profile-dom-{}", case.study)),
            &["--dump-dom".into(), format!("--window-size=1280,{FIRST_SCREEN}")],
            &hooked,
        );
        let dom = String::from_utf8_lossy(&o.stdout).into_owned();
        let errors = console_errors(&String::from_utf8_lossy(&o.stderr));
        assert!(errors.is_empty(), "{}: console errors: {errors:#?}", case.study);
        for id in SECTIONS {
            assert!(
                dom.contains(&format!("<section id=\"{id}\">")),
                "{}: section `{id}` not in the DOM",
                case.study
            );
        }
        for id in case.figures {
            let at = dom
                .find(&format!("id=\"{id}\""))
                .unwrap_or_else(|| panic!("{}: figure `{id}` not in the DOM", case.study));
            let end = dom[at..].find("</figure>").map_or(dom.len(), |e| at + e);
            assert!(
                dom[at..end].contains("<svg"),
                "{}: figure `{id}` has no <svg> in the DOM",
                case.study
            );
        }
        verdict_block_matches_results(case, &dom, out);
        let svgs = dom.matches("<svg").count();
        assert_eq!(
            svgs,
            html.matches("<svg").count(),
            "{}: every <svg> of the page is in the DOM",
            case.study
        );
        assert!(svgs >= case.figures.len(), "{}: {svgs} <svg>", case.study);
        let hook = dom
            .split("<pre id=\"lab-test-hook\">")
            .nth(1)
            .and_then(|s| s.split("</pre>").next())
            .unwrap_or_else(|| panic!("{}: the load hook did not run", case.study))
            .replace("&quot;", "\"")
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&amp;", "&");
        let hook: serde_json::Value = serde_json::from_str(&hook).expect("hook JSON");
        assert_eq!(hook["errors"], serde_json::json!([]), "{}: page errors", case.study);
        answer_on_first_screen(case, &hook["answer"], out);
        let load_ms = hook["load_ms"].as_f64().unwrap();
        eprintln!(
            "{}: {svgs} plots, loaded in {load_ms:.0} ms, screenshot {}",
            case.study,
            shot.display()
        );
        assert!(
            load_ms < 1000.0,
            "{}: the page took {load_ms} ms to load (limit 1 s)",
            case.study
        );
    }
}

/// The height of the first screen a reader sees, in CSS pixels (a laptop's browser window).
const FIRST_SCREEN: u32 = 800;

/// On the page as the browser lays it out, the answer box lies within the first screen and reads
/// results.json's plain verdict, with each parameter of the recommended model at its value.
fn answer_on_first_screen(case: &Case, answer: &serde_json::Value, out: &Path) {
    let results: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    let expected = &results["answer"];
    let bottom = answer["bottom"]
        .as_f64()
        .unwrap_or_else(|| panic!("{}: no answer box laid out", case.study));
    assert!(
        bottom <= f64::from(FIRST_SCREEN),
        "{}: the answer box ends at {bottom} px, below the first screen ({FIRST_SCREEN} px)",
        case.study
    );
    let text = answer["text"].as_str().unwrap();
    for key in ["verdict", "action", "decided_by"] {
        let words = expected[key].as_str().unwrap();
        assert!(
            text.contains(words),
            "{}: `{words}` not in the answer box: {text}",
            case.study
        );
    }
    let model = &expected["recommended"];
    let quantities = model["parameters"]
        .as_array()
        .into_iter()
        .flatten()
        .chain(model["variables"].as_array().into_iter().flatten());
    for q in quantities {
        let name = format!("{} = ", q["name"].as_str().unwrap());
        let v = q["value"].as_f64().unwrap();
        let shown: f64 = text
            .split(&name)
            .nth(1)
            .and_then(|rest| rest.split([' ', ',', ')']).next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{}: `{name}` not in the answer box: {text}", case.study));
        assert!(
            (shown - v).abs() <= 5e-4 * v.abs(),
            "{}: {name}{shown} in the answer box, {v} in results.json",
            case.study
        );
    }
}

/// The verdict block in the browser's DOM says what results.json says: its verdict key, its
/// headline and its action, first in the Diagnosis section.
fn verdict_block_matches_results(case: &Case, dom: &str, out: &Path) {
    let results: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    let d = &results["diagnosis"];
    let visible = |s: &str| s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
    let at = dom
        .find("id=\"verdict\"")
        .unwrap_or_else(|| panic!("{}: no verdict block in the DOM", case.study));
    let section = dom.find("<section id=\"diagnosis\">").expect("a diagnosis section");
    assert!(
        at > section,
        "{}: the verdict block sits in the Diagnosis section",
        case.study
    );
    let between = &dom[section..at];
    assert!(
        !between.contains("<figure") && !between.contains("<table"),
        "{}: the verdict comes first",
        case.study
    );
    let block = &dom[at..at + dom[at..].find("</div>").unwrap()];
    assert!(
        block.contains(&format!("data-verdict=\"{}\"", d["verdict"].as_str().unwrap())),
        "{}: {block}",
        case.study
    );
    for key in ["headline", "action"] {
        let text = visible(d[key].as_str().unwrap());
        assert!(
            block.contains(&text),
            "{}: {key} {text:?} not in the verdict block {block}",
            case.study
        );
    }
}
