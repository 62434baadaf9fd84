//! The independent programs the tests check `lab` against, found where `.ci/run` installs them:
//! PyDyna (`ansys-dyna-core`, an LS-DYNA keyword reader, in `target/pydyna-venv` by
//! scripts/pydyna-venv.sh, or `LAB_PYDYNA_PYTHON`) and OpenRadioss (its starter on PATH). Without
//! one a test skips with a message; under CI=true its absence fails.

use std::path::PathBuf;
use std::process::Command;

/// Fails under CI=true, else says what is skipped.
fn missing(what: &str, how: &str) {
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI=true but {what} is missing: {how}"
    );
    eprintln!("SKIPPED: {what} is missing ({how})");
}

/// PyDyna's python, or `None` (skip).
#[allow(dead_code)]
pub fn pydyna_python() -> Option<PathBuf> {
    let python = std::env::var_os("LAB_PYDYNA_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/pydyna-venv/bin/python"));
    let ok = Command::new(&python)
        .args(["-c", "import ansys.dyna.core"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        missing(
            "PyDyna (ansys-dyna-core)",
            &format!(
                "{} cannot import it; scripts/pydyna-venv.sh makes the venv",
                python.display()
            ),
        );
    }
    ok.then_some(python)
}

/// Whether OpenRadioss's starter is on PATH (else skip).
#[allow(dead_code)]
pub fn openradioss() -> bool {
    let found = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("starter_linux64_gf").is_file()));
    if !found {
        missing(
            "OpenRadioss (starter_linux64_gf on PATH)",
            "eval \"$(../shared/tools/openradioss/install.sh)\"",
        );
    }
    found
}
