//! The Python peers of the interop tests (pymavlink, dv-processing), which
//! `bash tests/peers/prepare` at the repository's root installs (`.ci/run` runs it).

use std::io::Write;
use std::process::{Command, Stdio};

/// Whether `python` imports `module`. When it does not, `test` is skipped with one
/// line naming the command that prepares the peers; in CI (CI set) it fails instead.
pub fn python_module(python: &str, module: &str, test: &str) -> bool {
    let present = Command::new(python)
        .args(["-c", &format!("import {module}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if present {
        return true;
    }
    let why = format!("{python} has no {module}: run `bash tests/peers/prepare`");
    assert!(std::env::var_os("CI").is_none(), "{test}: {why}");
    let _ = writeln!(std::io::stderr(), "skipped {test}: {why}");
    false
}
