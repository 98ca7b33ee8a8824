//! Interop: pymavlink, an independent MAVLink implementation, plays the autopilot
//! over UDP; the real `faithd run` must announce itself, roll for the configured
//! time with a correctly encoded RC_CHANNELS_OVERRIDE, and release.
//!
//! Needs python3 with pymavlink (`.ci/run` installs it); fails, not skips, without.

mod common;

use std::process::Command;

#[derive(serde::Deserialize)]
struct Seen {
    companion_heartbeats: u32,
    overrides: Vec<Override>,
}

#[derive(serde::Deserialize)]
struct Override {
    t_s: f64,
    chan1_raw: u16,
    chan2_raw: u16,
    target_system: u8,
}

#[test]
fn pymavlink_autopilot_sees_heartbeats_a_timed_roll_and_a_release() {
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/py/pymavlink_autopilot.py"
    );
    let peer = Command::new("python3")
        .args([script, &port.to_string(), "4.5"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python3 is needed for the pymavlink interop test");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let mut daemon = common::Daemon::start(&format!("udpout:127.0.0.1:{port}"), "");
    let out = peer.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "pymavlink peer failed (is pymavlink installed? `python3 -m pip install pymavlink`):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let seen: Seen = serde_json::from_slice(&out.stdout).unwrap();
    assert!(daemon.stop().success());
    assert!(
        seen.companion_heartbeats >= 2,
        "faithd's HEARTBEAT not seen"
    );
    let rolls: Vec<_> = seen
        .overrides
        .iter()
        .filter(|o| o.chan1_raw == 1200 || o.chan1_raw == 1800)
        .collect();
    assert!(
        !rolls.is_empty(),
        "no roll seen by pymavlink; faithd log:\n{}",
        daemon.log()
    );
    let release = seen
        .overrides
        .iter()
        .find(|o| o.chan1_raw == 0 && o.t_s > rolls[0].t_s)
        .expect("release seen by pymavlink");
    let lasted = release.t_s - rolls[0].t_s;
    assert!((1.45..=1.56).contains(&lasted), "roll lasted {lasted} s");
    assert!(
        seen.overrides
            .iter()
            .all(|o| o.chan2_raw == u16::MAX && o.target_system == 1)
    );
}
