//! Where the tests find the `crushsim` program. It is its own crate (lab does not link it), a
//! default member of the workspace, so `cargo test --release` at the repository root builds it
//! into the same directory as `lab`.

use std::path::PathBuf;

/// `target/<profile>/crushsim`, beside the `lab` under test.
pub fn crushsim() -> PathBuf {
    let path = PathBuf::from(env!("CARGO_BIN_EXE_lab")).with_file_name("crushsim");
    assert!(
        path.is_file(),
        "{} is not built: run the tests from the repository root (`cargo test --release`) or \
         build it first (`cargo build --release -p crushsim`)",
        path.display()
    );
    path
}
