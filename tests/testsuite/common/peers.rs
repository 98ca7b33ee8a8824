//! The test peers, independent implementations the tests meet: pymavlink and
//! dv-processing for python3, iniVation's libcaer. `bash tests/peers/prepare` (what
//! `.ci/run` runs) prepares them all; a test whose peer is missing says so in one line
//! naming that command and skips, or fails in CI, where nothing may be skipped quietly.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// The one command that prepares every peer.
pub const PREPARE: &str = "bash tests/peers/prepare";

/// Whether python3 imports `module`. When it does not, `test` is skipped with one
/// line outside CI and fails in CI.
pub fn python_module(module: &str, test: &str) -> bool {
    let present = Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if present {
        return true;
    }
    let why = format!("python3 has no {module}: run `{PREPARE}`");
    assert!(std::env::var_os("CI").is_none(), "{test}: {why}");
    let _ = writeln!(std::io::stderr(), "skipped {test}: {why}");
    false
}

/// iniVation's libcaer: `LIBCAER_PATH`, or else the wheel's that [`PREPARE`] unzipped
/// into target/peers/ (x86-64 only).
pub fn libcaer_path() -> Option<String> {
    if let Some(path) = std::env::var_os("LIBCAER_PATH").filter(|p| !p.is_empty()) {
        return Some(path.to_string_lossy().into_owned());
    }
    let libs = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/peers/libcaer-3.3.15/unpacked/event_camera_drivers.libs");
    std::fs::read_dir(libs)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("libcaer-"))
        })
        .map(|p| p.to_string_lossy().into_owned())
}
