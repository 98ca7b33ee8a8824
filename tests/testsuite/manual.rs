//! The manual pages and shell completions as their readers use them: Debian's
//! groff and man render every page without a warning, and bash completes the
//! subcommands and options from the generated script. `--version` names the build's
//! features.

use std::path::Path;
use std::process::{Command, Output};

fn faithd(args: &[&str]) -> Output {
    crate::common::faithd()
        .args(args)
        .output()
        .expect("run faithd")
}

fn stdout(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The subcommands `--help` lists (clap's own `help` aside).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

fn tool(name: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {name}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// What `man` shows for a page file, as plain text.
fn man_text(page: &Path) -> String {
    let out = Command::new("man")
        .args(["-l", "-P", "cat"])
        .arg(page)
        .env("MANWIDTH", "100")
        .env("LANG", "C.UTF-8")
        .output()
        .expect("run man");
    assert!(out.status.success(), "man -l {}", page.display());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn every_subcommand_has_a_manual_page_that_man_renders() {
    assert!(
        tool("man") && tool("groff"),
        "man and groff are needed (apt-get install man-db groff-base; .ci/run does)"
    );
    let dir = tempfile::tempdir().unwrap();
    stdout(&faithd(&["man-pages", dir.path().to_str().unwrap()]));

    let mut expected = vec!["faithd".to_string()];
    for sub in subcommands(&stdout(&faithd(&["--help"]))) {
        let nested = subcommands(&stdout(&faithd(&[&sub, "--help"])));
        expected.push(format!("faithd-{sub}"));
        expected.extend(nested.iter().map(|n| format!("faithd-{sub}-{n}")));
    }
    assert!(expected.contains(&"faithd-run".to_string()), "{expected:?}");
    // The lab's commands exactly when the build has the lab.
    assert_eq!(
        expected.contains(&"faithd-bench-pipeline".to_string()),
        crate::common::sim_built(),
        "{expected:?}"
    );
    let mut written: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    let mut wanted: Vec<String> = expected.iter().map(|p| format!("{p}.1")).collect();
    wanted.sort();
    assert_eq!(written, wanted);

    for page in &expected {
        let path = dir.path().join(format!("{page}.1"));
        // groff's warnings (-ww) name any roff the page gets wrong.
        let groff = Command::new("groff")
            .args(["-man", "-Tutf8", "-ww", "-z"])
            .arg(&path)
            .output()
            .expect("run groff");
        assert!(
            groff.status.success() && groff.stderr.is_empty(),
            "{page}: {}",
            String::from_utf8_lossy(&groff.stderr)
        );
        let text = man_text(&path);
        assert!(text.contains("NAME"), "{page}: {text}");
        assert!(text.contains(page.as_str()), "{page}: {text}");
    }
    // A page documents its command's options, with their help.
    let run = man_text(&dir.path().join("faithd-run.1"));
    assert!(run.contains("--config"), "{run}");
    assert!(run.contains("--simulated-camera"), "{run}");
    if crate::common::sim_built() {
        let sim = man_text(&dir.path().join("faithd-sim.1"));
        assert!(sim.contains("--cpu-scale"), "{sim}");
    }
}

/// What bash offers after `words` (the last one being completed).
fn bash_completes(script: &Path, words: &[&str]) -> Vec<String> {
    let quoted: Vec<String> = words.iter().map(|w| format!("'{w}'")).collect();
    let program = format!(
        "source '{}'; COMP_WORDS=({}); COMP_CWORD={}; _faithd faithd '{}' '{}'; printf '%s\\n' \"${{COMPREPLY[@]}}\"",
        script.display(),
        quoted.join(" "),
        words.len() - 1,
        words[words.len() - 1],
        words[words.len() - 2],
    );
    let out = Command::new("bash")
        .args(["--norc", "-c", &program])
        .output()
        .expect("run bash");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn bash_completes_subcommands_and_options_from_the_generated_script() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("faithd.bash");
    std::fs::write(&script, stdout(&faithd(&["completions", "bash"]))).unwrap();

    assert_eq!(bash_completes(&script, &["faithd", "rep"]), ["replay"]);
    assert_eq!(
        bash_completes(&script, &["faithd", "run", "--simulated"]),
        ["--simulated-camera"]
    );
    // The lab's commands are offered exactly when the build has them.
    let bench = bash_completes(&script, &["faithd", "bench", ""]);
    if crate::common::sim_built() {
        assert_eq!(
            bash_completes(&script, &["faithd", "sim", "--cpu"]),
            ["--cpu-scale"]
        );
        for sub in ["foe", "pipeline", "compute"] {
            assert!(bench.iter().any(|w| w == sub), "{bench:?}");
        }
    } else {
        assert!(!bench.iter().any(|w| w == "pipeline"), "{bench:?}");
    }

    for shell in ["zsh", "fish"] {
        let script = stdout(&faithd(&["completions", shell]));
        assert!(script.contains("simulated-camera"), "{shell}: {script}");
    }
    let refused = faithd(&["completions", "tcsh"]);
    assert_eq!(refused.status.code(), Some(2));
}

#[test]
fn the_version_names_the_builds_features() {
    let version = stdout(&faithd(&["--version"]));
    assert!(version.starts_with("faithd 0."), "{version}");
    assert!(version.contains("camera"), "{version}");
    if crate::common::sim_built() {
        assert!(version.contains("sim (demo, sim, bench)"), "{version}");
    } else {
        assert!(version.contains("flight build"), "{version}");
        assert!(version.contains("without: sim"), "{version}");
    }
}
