//! A long flight: the daemon against the mock iNav (MAVLink and MSP on pseudo-
//! terminals) with the C mock of libcaer streaming 180,000 events a second, every
//! flight recorded into a small budget so parts rotate and old ones are deleted all
//! along. Resident memory and open descriptors are sampled and must stay flat.
//!
//! `soak_briefly` runs in every test run (30 s); the hour is
//! `FAITHD_SOAK_SECS=3600 cargo test --release --test testsuite soak:: -- --ignored --nocapture`.

use crate::common;

use std::sync::Arc;
use std::time::{Duration, Instant};

use common::TempDir;
use common::autopilot::{Controls, MockAutopilot};

/// (seconds since start, anonymous resident KiB, open descriptors)
///
/// Anonymous memory (the heap, the stacks) is what a leak grows. The rest of VmRSS is
/// the binary's and the libraries' pages, read in as code paths are first taken and
/// given back under memory pressure; it is printed, not judged.
type Sample = (u64, u64, usize);

fn status_kib(status: &str, key: &str) -> Option<u64> {
    status
        .lines()
        .find_map(|l| l.strip_prefix(key))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// (VmRSS, RssAnon, VmHWM) in KiB and the open descriptors of `pid`.
fn sample(pid: u32) -> Option<(u64, u64, u64, usize)> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let fds = std::fs::read_dir(format!("/proc/{pid}/fd")).ok()?.count();
    Some((
        status_kib(&status, "VmRSS:")?,
        status_kib(&status, "RssAnon:")?,
        status_kib(&status, "VmHWM:")?,
        fds,
    ))
}

fn soak(duration: Duration, every: Duration) -> Vec<Sample> {
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let dir = TempDir::new("soak");
    let flights = dir.0.join("flights");
    let config = dir.0.join("faithd.toml");
    std::fs::write(
        &config,
        mock.service_toml(
            &crate::common::caer_mock_library(),
            &format!(
                "dir = \"{}\"\nmax_file_bytes = 1048576\nmax_total_bytes = 8388608\n",
                flights.display()
            ),
        ),
    )
    .unwrap();
    let log_path = dir.0.join("faithd.log");
    let mut child = crate::common::faithd()
        .args(["run", "--config"])
        .arg(&config)
        .env("RUST_LOG", "info")
        .stderr(std::fs::File::create(&log_path).unwrap())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let mut samples = Vec::new();
    while started.elapsed() < duration {
        std::thread::sleep(every);
        assert!(
            child.try_wait().unwrap().is_none(),
            "faithd ended:\n{}",
            std::fs::read_to_string(&log_path).unwrap_or_default()
        );
        let (rss_kib, anon_kib, peak_kib, fds) = sample(child.id()).expect("/proc of the daemon");
        let t = started.elapsed().as_secs();
        println!(
            "soak t={t:>5} s  rss={rss_kib:>7} KiB  anon={anon_kib:>7} KiB  peak={peak_kib:>7} KiB  fds={fds}"
        );
        samples.push((t, anon_kib, fds));
    }
    let _ = nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    );
    let status = child.wait().unwrap();
    let log = std::fs::read_to_string(&log_path).unwrap_or_default();
    assert!(status.success(), "{log}");
    let on_disk: u64 = std::fs::read_dir(&flights)
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    println!("soak: recordings hold {on_disk} bytes (budget 8388608)");
    assert!(on_disk <= 8 * 1024 * 1024, "{on_disk} bytes on disk");
    let closed = log
        .lines()
        .find(|l| l.contains("recording closed"))
        .unwrap_or_default();
    println!("soak: {closed}");
    samples
}

/// After a warm-up fifth, anonymous memory may not grow by more than `slack_kib` and
/// the descriptors not at all (beyond one transient).
fn assert_flat(samples: &[Sample], slack_kib: u64) {
    let warm = &samples[samples.len() / 5..];
    let (first_rss, last_rss) = (warm[0].1, warm[warm.len() - 1].1);
    let max_rss = warm.iter().map(|s| s.1).max().unwrap();
    assert!(
        max_rss <= first_rss + slack_kib,
        "anonymous memory grew from {first_rss} to {max_rss} KiB (last {last_rss}): {samples:?}"
    );
    let fds: Vec<usize> = warm.iter().map(|s| s.2).collect();
    let (min_fds, max_fds) = (*fds.iter().min().unwrap(), *fds.iter().max().unwrap());
    assert!(
        max_fds <= min_fds + 1,
        "open descriptors vary from {min_fds} to {max_fds}: {samples:?}"
    );
}

#[test]
fn soak_briefly() {
    let samples = soak(Duration::from_secs(30), Duration::from_secs(2));
    assert_flat(&samples, 4 * 1024);
}

#[test]
#[ignore = "an hour: FAITHD_SOAK_SECS=3600 cargo test --release --test testsuite soak:: -- --ignored --nocapture"]
fn soak_for_an_hour() {
    let secs = std::env::var("FAITHD_SOAK_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3600);
    let samples = soak(
        Duration::from_secs(secs),
        Duration::from_secs(60.min(secs / 10).max(1)),
    );
    assert_flat(&samples, 4 * 1024);
}
