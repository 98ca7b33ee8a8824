//! A flight recorded through a full card, a pulled camera and a killed daemon keeps
//! everything it wrote before each fault, readable by faithd and by the independent
//! peers (dv-processing for AEDAT 4, pymavlink for .tlog).
//!
//! The card is a 1 MiB tmpfs, so this test needs root (CI runs as root); the camera
//! is the C mock of libcaer, scripted through its environment to vanish and return.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Duration;

use common::autopilot::{Controls, MockAutopilot};
use common::{TempDir, poll_until};
use faithd_formats::events::EventReader;
use faithd_formats::events::aedat4::Aedat4Reader;
use faithd_formats::tlog::TlogReader;

/// A small tmpfs: a card that fills up. Unmounted when dropped.
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(dir: &Path, size: &str) -> Self {
        assert!(
            nix::unistd::geteuid().is_root(),
            "this test mounts a tmpfs as a full SD card: run it as root (CI does)"
        );
        std::fs::create_dir_all(dir).unwrap();
        let status = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size},mode=0700")])
            .arg("faithd-test-card")
            .arg(dir)
            .status()
            .expect("mount");
        assert!(status.success(), "mount -t tmpfs failed");
        Tmpfs(dir.to_path_buf())
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.0).status();
    }
}

fn python_script(script: &str, args: &[&str]) -> String {
    // dv-processing's readers live beside the formats crate that tests against them.
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("crates/faithd-formats/tests/py")
        .join(script);
    let out = Command::new("python3")
        .arg(&path)
        .args(args)
        .current_dir(path.parent().unwrap())
        .output()
        .expect("python3");
    assert!(
        out.status.success(),
        "{script} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Events of an AEDAT 4 file as faithd reads them: every whole packet.
fn faithd_events(path: &Path) -> usize {
    let mut reader = Aedat4Reader::new(std::fs::File::open(path).unwrap())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (mut batch, mut count, mut last_t) = (Vec::new(), 0, i64::MIN);
    loop {
        match reader.next_batch(&mut batch) {
            Ok(true) => {
                for e in &batch {
                    assert!(e.t_us >= last_t, "{}: time goes back", path.display());
                    last_t = e.t_us;
                }
                count += batch.len();
            }
            Ok(false) => return count,
            Err(e) => panic!("{}: {e} after {count} events", path.display()),
        }
    }
}

fn tlog_records(path: &Path) -> usize {
    let mut reader = TlogReader::new(std::fs::File::open(path).unwrap());
    let mut count = 0;
    while let Some(_record) = reader
        .next_record()
        .unwrap_or_else(|e| panic!("{}: {e} after {count} records", path.display()))
    {
        count += 1;
    }
    count
}

#[test]
fn a_full_card_a_pulled_camera_and_a_kill_lose_nothing_written_before() {
    const TEST: &str = "a_full_card_a_pulled_camera_and_a_kill_lose_nothing_written_before";
    let peers = crate::common::peers::python_module;
    if !peers("dv_processing", TEST) || !peers("pymavlink", TEST) {
        return;
    }
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let dir = TempDir::new("full-card");
    let card = dir.0.join("card");
    let tmpfs = Tmpfs::mount(&card, "1m");
    let config = dir.0.join("faithd.toml");
    std::fs::write(
        &config,
        mock.service_toml(
            &crate::common::caer_mock_library(),
            &format!(
                "dir = \"{}\"\nmax_file_bytes = 1048576\nmax_total_bytes = 67108864\nsync_interval_ms = 100\n",
                card.display()
            ),
        ),
    )
    .unwrap();
    let log_path = dir.0.join("faithd.log");
    let mut child = crate::common::faithd()
        .args(["run", "--config"])
        .arg(&config)
        .env("RUST_LOG", "info")
        // The camera is pulled after 1.5 s of events, refuses two opens, returns.
        .env("CAER_MOCK_DISCONNECT_AFTER", "1500")
        .env("CAER_MOCK_FAILED_OPENS", "2")
        .stderr(std::fs::File::create(&log_path).unwrap())
        .spawn()
        .unwrap();
    let log = || std::fs::read_to_string(&log_path).unwrap_or_default();
    let all_faults = poll_until(Duration::from_secs(30), || {
        let text = log();
        text.contains("camera lost")
            && text.matches("camera open: streaming").count() >= 2
            && text.contains("No space left on device")
    });
    assert!(all_faults, "not every fault happened:\n{}", log());
    std::thread::sleep(Duration::from_millis(1500));
    assert!(
        child.try_wait().unwrap().is_none(),
        "faithd ended:\n{}",
        log()
    );
    // SIGSTOP, then SIGKILL: the kill lands between two system calls. With the card
    // full, every record is refused by its reservation before a byte of it is
    // written, so no moment leaves a torn record (before reservations, one run in
    // CI was killed between a short write and its cut back: a partial last line).
    let pid = nix::unistd::Pid::from_raw(child.id() as i32);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGSTOP).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGKILL).unwrap();
    child.wait().unwrap();
    let text = log();
    assert!(text.contains("(item dropped; recording goes on)"), "{text}");

    let mut names: Vec<String> = std::fs::read_dir(&card)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let of = |ext: &str| -> Vec<PathBuf> {
        names
            .iter()
            .filter(|n| n.ends_with(ext))
            .map(|n| card.join(n))
            .collect()
    };
    let (events, tlogs, windows) = (of(".aedat4"), of(".tlog"), of(".windows.jsonl"));
    assert!(
        !events.is_empty() && !tlogs.is_empty() && !windows.is_empty(),
        "{names:?}"
    );
    let used: u64 = names
        .iter()
        .map(|n| std::fs::metadata(card.join(n)).unwrap().len())
        .sum();
    assert!(used > 900 * 1024, "the card was not full: {used} bytes");
    for path in &events {
        let ours = faithd_events(path);
        assert!(ours > 100_000, "{}: {ours} events", path.display());
        let theirs = python_script("dv_read_events.py", &[path.to_str().unwrap()]);
        let theirs: serde_json::Value = serde_json::from_str(theirs.trim()).unwrap();
        assert_eq!(theirs["count"], ours, "{}: dv-processing", path.display());
    }
    for path in &tlogs {
        let ours = tlog_records(path);
        assert!(ours > 50, "{}: {ours} records", path.display());
        let theirs = python_script("tlog_peer.py", &["read", path.to_str().unwrap()]);
        assert!(!theirs.contains("BAD_DATA"), "{}", path.display());
        assert_eq!(
            theirs.lines().count(),
            ours,
            "{}: pymavlink",
            path.display()
        );
    }
    for path in &windows {
        let text = std::fs::read_to_string(path).unwrap();
        assert!(
            text.ends_with('\n'),
            "{}: a partial line at the end of {} bytes: {:?}",
            path.display(),
            text.len(),
            &text[text.len().saturating_sub(120)..]
        );
        for line in text.lines() {
            serde_json::from_str::<serde_json::Value>(line)
                .unwrap_or_else(|e| panic!("{}: {e}: {line}", path.display()));
        }
    }
    drop(tmpfs);
}
