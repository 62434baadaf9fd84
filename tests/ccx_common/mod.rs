//! Shared by the live CalculiX tests (tests/calculix_live.rs, tests/calculix_honeycomb.rs).

use std::path::PathBuf;
use std::process::Command;

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Whether `ccx` can be run; in CI its absence fails the test.
pub fn have_ccx() -> bool {
    let ok = Command::new("ccx").arg("-v").output().is_ok();
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "ccx (Debian package calculix-ccx) is missing in CI: .ci/run must install it"
        );
        eprintln!("SKIPPED: ccx is not installed (apt-get install calculix-ccx); set CI=true to make this fail");
    }
    ok
}
