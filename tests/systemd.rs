//! The systemd side: the unit file is valid, and the daemon speaks the notify
//! protocol (READY once the link and pipeline are up, WATCHDOG while it runs).

mod common;

use std::os::unix::net::UnixDatagram;
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{Controls, Daemon, MockAutopilot, TempDir};

#[test]
fn unit_file_passes_systemd_analyze_verify() {
    let dir = TempDir::new("unit");
    let unit = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/systemd/faithd.service"
    ))
    .unwrap();
    for key in [
        "Type=notify",
        "WatchdogSec=",
        "Restart=on-failure",
        "User=faithd",
        "ProtectSystem=strict",
    ] {
        assert!(unit.contains(key), "unit lacks {key}");
    }
    // verify checks that ExecStart's binary exists: point it at the one just built.
    let unit = unit.replace("/usr/bin/faithd", env!("CARGO_BIN_EXE_faithd"));
    let path = dir.0.join("faithd.service");
    std::fs::write(&path, unit).unwrap();
    let out = std::process::Command::new("systemd-analyze")
        .arg("verify")
        .arg(&path)
        .output()
        .expect("systemd-analyze is needed (apt-get install systemd)");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.contains("faithd.service:"),
        "systemd-analyze verify: {stderr}"
    );
}

#[test]
fn ready_after_link_up_then_watchdog_while_the_pipeline_runs() {
    let dir = TempDir::new("notify");
    let socket_path = dir.0.join("notify.sock");
    let socket = UnixDatagram::bind(&socket_path).unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let daemon = Daemon::start_with_env(
        &format!("serial:{}", mock.slave_path.display()),
        "",
        &[
            ("NOTIFY_SOCKET", socket_path.to_str().unwrap()),
            ("WATCHDOG_USEC", "200000"),
        ],
    );
    let mut messages = Vec::new();
    let until = Instant::now() + Duration::from_millis(2500);
    let mut buf = [0u8; 512];
    while Instant::now() < until {
        if let Ok(n) = socket.recv(&mut buf) {
            messages.push((
                Instant::now(),
                String::from_utf8_lossy(&buf[..n]).into_owned(),
            ));
        }
    }
    let ready = messages
        .iter()
        .position(|(_, m)| m.contains("READY=1"))
        .unwrap_or_else(|| panic!("no READY: {messages:?}\n{}", daemon.log()));
    assert!(mock.heartbeats() > 0);
    let watchdogs: Vec<_> = messages[ready..]
        .iter()
        .filter(|(_, m)| m.contains("WATCHDOG=1"))
        .map(|(t, _)| *t)
        .collect();
    assert!(watchdogs.len() >= 10, "{} watchdog pings", watchdogs.len());
    let worst = watchdogs.windows(2).map(|w| w[1] - w[0]).max().unwrap();
    assert!(worst < Duration::from_millis(200), "watchdog gap {worst:?}");
}
