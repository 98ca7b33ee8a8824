//! The crate boundaries hold (docs/design.md, "Crates"): the core links nothing that
//! does I/O; the flight daemon links no lab, no model of iNav and no simulator; the
//! flight build (no `sim` feature) links neither the lab nor the simulator nor
//! plotters nor the video encoders; the lab flies the daemon itself. Read from
//! `cargo tree`, i.e. from what cargo would actually build. And inside the crates: no
//! module imports a sibling that imports it, and no function of the core or the
//! daemon outgrows 120 lines (the scripts in `tests/tools/`).

use std::process::Command;

/// The normal (non-dev) dependencies of `package` with `args`, one crate name a line.
fn dependencies(package: &str, args: &[&str]) -> Vec<String> {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "--offline",
            "-e",
            "normal",
            "--prefix",
            "none",
            "-p",
            package,
        ])
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cargo tree");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .collect()
}

#[test]
fn the_core_links_no_runtime_protocol_format_or_plotting_crate() {
    let deps = dependencies("faithd-core", &[]);
    assert!(deps.iter().any(|d| d == "nalgebra"), "{deps:?}");
    for banned in [
        "tokio",
        "tokio-serial",
        "mavlink",
        "plotters",
        "zstd",
        "lz4_flex",
        "tracing-subscriber",
        "tracing",
        "serde_json",
        "faithd-formats",
    ] {
        assert!(
            !deps.iter().any(|d| d == banned),
            "faithd-core links {banned}"
        );
    }
}

/// What only the lab may link: the lab, faithd's model of iNav, the simulator,
/// plotters and the video encoders.
const LAB_ONLY: [&str; 6] = [
    "faithd-lab",
    "faithd-inav",
    "faithd-sim",
    "plotters",
    "gif",
    "png",
];

fn assert_links_no_lab(deps: &[String], who: &str) {
    for banned in LAB_ONLY {
        assert!(!deps.iter().any(|d| d == banned), "{who} links {banned}");
    }
}

#[test]
fn the_flight_daemon_links_no_lab_no_model_and_no_simulator() {
    let daemon = dependencies("faithd-daemon", &[]);
    assert!(daemon.iter().any(|d| d == "faithd-core"), "{daemon:?}");
    assert_links_no_lab(&daemon, "faithd-daemon");
    // The lab's flights run the daemon's own code, not a copy of it.
    let lab = dependencies("faithd-lab", &[]);
    assert!(lab.iter().any(|d| d == "faithd-daemon"), "{lab:?}");
}

#[test]
fn the_flight_build_links_no_lab_and_no_simulator() {
    let flight = dependencies("faithd", &["--no-default-features"]);
    assert!(flight.iter().any(|d| d == "faithd-daemon"), "{flight:?}");
    assert_links_no_lab(&flight, "the flight build");
    let workstation = dependencies("faithd", &[]);
    assert!(
        workstation.iter().any(|d| d == "faithd-lab"),
        "{workstation:?}"
    );
}

/// No module imports a sibling that imports it, in any crate of the workspace: shared
/// items live down the tree, where both sides import them (`tests/tools/modcycles.py`
/// reads every `use` and path and follows re-exports to where an item is defined).
#[test]
fn no_module_imports_a_sibling_that_imports_it() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut sources: Vec<_> = std::fs::read_dir(root.join("crates"))
        .unwrap()
        .map(|entry| entry.unwrap().path().join("src"))
        .collect();
    sources.sort();
    sources.extend([root.join("src"), root.join("libcaer-sys/src")]);
    let out = std::process::Command::new("python3")
        .arg(root.join("tests/tools/modcycles.py"))
        .arg("--siblings")
        .args(&sources)
        .output()
        .expect("python3 runs tests/tools/modcycles.py");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{report}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        report.matches("0 cycle(s)").count(),
        sources.len() + 1,
        "{report}"
    );
}

/// Every function of the core and of the flight daemon, tests aside, fits in 120
/// lines: a reader holds it in mind (`tests/tools/fnlen.py`).
#[test]
fn no_function_of_the_core_or_the_daemon_is_longer_than_120_lines() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::process::Command::new("python3")
        .arg(root.join("tests/tools/fnlen.py"))
        .arg("120")
        .arg(root.join("crates/faithd-core/src"))
        .arg(root.join("crates/faithd-daemon/src"))
        .output()
        .expect("python3 runs tests/tools/fnlen.py");
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
