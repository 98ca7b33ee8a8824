//! Interop: pymavlink, an independent MAVLink implementation, plays iNav's telemetry
//! over UDP (tests/py/pymavlink_autopilot.py); the roll goes to the MSP model of
//! iNav on a pseudo-terminal. faithd must announce itself, roll on pymavlink's
//! telemetry, and believe only the autopilot's own component.
//!
//! Needs python3 with pymavlink (`bash tests/peers/prepare`); skips with one line
//! without it, and fails in CI.

use crate::common;
use crate::common::peers::python_module;

use std::process::Command;
use std::sync::Arc;
use std::time::Duration;

use common::autopilot::Controls;
use common::daemon::Daemon;
use common::msp::MspMock;

#[derive(serde::Deserialize)]
struct Seen {
    companion_heartbeats: u32,
}

/// pymavlink on a free UDP port for `seconds`, with `args`; faithd started against
/// it and the MSP model; returns what pymavlink saw and faithd's journal.
fn fly(seconds: &str, args: &[&str], msp: &MspMock) -> (Seen, String) {
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
        .arg(script)
        .arg(port.to_string())
        .arg(seconds)
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python3 is needed for the pymavlink interop test");
    std::thread::sleep(Duration::from_millis(300));
    let mut daemon = Daemon::start(&format!("udpout:127.0.0.1:{port}"), &msp.command_toml());
    let out = peer.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "pymavlink peer failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    (serde_json::from_slice(&out.stdout).unwrap(), log)
}

#[test]
fn pymavlink_telemetry_drives_a_roll_and_sees_faithds_heartbeat() {
    if !python_module(
        "pymavlink",
        "pymavlink_telemetry_drives_a_roll_and_sees_faithds_heartbeat",
    ) {
        return;
    }
    let msp = MspMock::start(Arc::new(Controls::default()));
    let (seen, log) = fly("4.5", &[], &msp);
    assert!(
        seen.companion_heartbeats >= 2,
        "faithd's HEARTBEAT not seen"
    );
    assert!(
        msp.first_roll().is_some(),
        "iNav (model) never used a roll; journal:\n{log}"
    );
}

#[test]
fn another_component_of_the_autopilots_system_cannot_open_the_gate() {
    if !python_module(
        "pymavlink",
        "another_component_of_the_autopilots_system_cannot_open_the_gate",
    ) {
        return;
    }
    // The autopilot's RC_CHANNELS say MANUAL; a gimbal (component 154 of the same
    // system) sends RC_CHANNELS with AUTO and an armed HEARTBEAT on the same link.
    // iNav's own switch (the MSP model's) is in AUTO with its override on, so only
    // the component filter stands between the gimbal and a roll iNav would use.
    let msp = MspMock::start(Arc::new(Controls::default()));
    let (seen, log) = fly("4.5", &["1000", "--impostor"], &msp);
    assert!(seen.companion_heartbeats >= 2, "{log}");
    assert!(
        log.contains("decision: roll"),
        "the pipeline wanted to roll: {log}"
    );
    assert!(!log.contains("safety gate open"), "{log}");
    assert!(!log.contains("manoeuvre started"), "{log}");
    assert!(
        log.contains("MAVLink frames from a sender other than the autopilot ignored"),
        "{log}"
    );
    assert!(log.contains("component_id=154"), "{log}");
    assert!(
        log.contains("pilot switch not in AUTO"),
        "the gate held on the autopilot's own switch: {log}"
    );
    assert_eq!(msp.first_roll(), None, "iNav used a roll");
}
