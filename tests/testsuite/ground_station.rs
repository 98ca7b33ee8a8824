//! The ground station link end to end: the real `faithd run` with `[ground]` on a UDP
//! port, pymavlink playing iNav's telemetry on another (tests/py/pymavlink_autopilot.py)
//! and pymavlink as the ground station (tests/py/pymavlink_ground.py), the roll going
//! to the MSP model of iNav on a pseudo-terminal.
//!
//! The ground station must hear faithd's HEARTBEAT as an onboard controller at 1 Hz,
//! a STATUSTEXT for the gate opening, for the roll and for the switch going to MANUAL
//! (in that order), the five NAMED_VALUE_FLOAT values at 4 Hz, and the autopilot's
//! own telemetry from the autopilot's ids at the autopilot's rate. It sends
//! RC_CHANNELS_OVERRIDE and COMMAND_LONG (disarm) to the vehicle five times a second;
//! the autopilot must see nothing but faithd's HEARTBEAT. With
//! `forward_to_autopilot = true` the commands reach it, the stick input still not.
//!
//! Needs python3 with pymavlink (`.ci/run` installs it). Without it the test is
//! skipped with a message, unless `CI` is set: there it fails.
//! `cargo test --test testsuite ground_station:: -- --nocapture` prints what the ground station
//! showed (the capture in docs/daemon.md).

use crate::common;

use std::collections::BTreeMap;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::Duration;

use common::autopilot::Controls;
use common::daemon::Daemon;
use common::msp::MspMock;
use common::poll_until;

#[derive(serde::Deserialize)]
struct AutopilotSaw {
    received: BTreeMap<String, u32>,
}

#[derive(serde::Deserialize)]
struct Seen {
    count: u32,
    rate_hz: f64,
}

#[derive(serde::Deserialize)]
struct Text {
    from: String,
    severity: String,
    text: String,
}

#[derive(serde::Deserialize)]
struct Heartbeat {
    #[serde(rename = "type")]
    mav_type: String,
    autopilot: String,
}

#[derive(serde::Deserialize)]
struct GroundSaw {
    seen: BTreeMap<String, Seen>,
    statustext: Vec<Text>,
    values: BTreeMap<String, Vec<(f64, Option<f64>)>>,
    values_hz: BTreeMap<String, f64>,
    heartbeats: BTreeMap<String, Heartbeat>,
    sent: BTreeMap<String, u32>,
    capture: String,
}

/// The NAMED_VALUE_FLOAT names faithd sends (`link::ground::VALUE_NAMES`).
const VALUE_NAMES: [&str; 5] = ["foe_x_px", "foe_y_px", "ttc_s", "events_hz", "cycle_ms"];

fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn python(script: &str, args: &[String]) -> Child {
    Command::new("python3")
        .arg(format!("{}/tests/py/{script}", env!("CARGO_MANIFEST_DIR")))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 runs the pymavlink peers")
}

fn finish<T: serde::de::DeserializeOwned>(child: Child, what: &str) -> T {
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "the pymavlink {what} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "the pymavlink {what} printed no JSON ({e}):\n{}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// Whether the pymavlink peers can run; skips (outside CI) with a line if not.
fn peers_available(test: &str) -> bool {
    crate::common::peers::python_module("pymavlink", test)
}

/// What one flight showed: the ground station's and the autopilot's records, the
/// journal, and whether iNav (the MSP model) used a roll.
struct Flight {
    ground: GroundSaw,
    autopilot: AutopilotSaw,
    log: String,
    rolled: bool,
}

/// faithd with `[ground]` (plus `ground_toml`) between pymavlink as the autopilot
/// (`autopilot_args` after its port) and pymavlink as the ground station, listening
/// for `ground_s` seconds. One approach to the pole, 1.5 s in: the gate is open by
/// then (the MSP stream warms up for 0.8 s), so the roll comes when the pipeline calls
/// for it.
fn fly(autopilot_args: &[&str], ground_s: &str, ground_toml: &str) -> Flight {
    let (autopilot_port, ground_port) = (free_udp_port(), free_udp_port());
    let mut args = vec![autopilot_port.to_string()];
    args.extend(autopilot_args.iter().map(|a| a.to_string()));
    let autopilot = python("pymavlink_autopilot.py", &args);
    let ground = python(
        "pymavlink_ground.py",
        &[ground_port.to_string(), ground_s.into()],
    );
    // Both peers listening (their ports taken) before faithd starts, so the ground
    // station hears faithd's first words.
    assert!(
        poll_until(Duration::from_secs(10), || {
            [autopilot_port, ground_port]
                .iter()
                .all(|p| std::net::UdpSocket::bind(("127.0.0.1", *p)).is_err())
        }),
        "the pymavlink peers did not start listening"
    );
    let msp = MspMock::start(Arc::new(Controls::default()));
    let mut daemon = Daemon::start_config(
        &format!(
            "[mavlink]\nendpoint = \"udpout:127.0.0.1:{autopilot_port}\"\n\
             [source]\nkind = \"sim\"\nfirst_approach_us = 1500000\nrepeat_us = 60000000\n\
             {}[ground]\nenabled = true\nendpoint = \"udpout:127.0.0.1:{ground_port}\"\n{ground_toml}",
            msp.command_toml()
        ),
        &[],
    );
    let ground: GroundSaw = finish(ground, "ground station");
    let autopilot: AutopilotSaw = finish(autopilot, "autopilot");
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    Flight {
        ground,
        autopilot,
        log,
        rolled: msp.first_roll().is_some(),
    }
}

#[test]
fn the_ground_station_sees_faithd_and_the_autopilot_and_reaches_neither() {
    if !peers_available("the_ground_station_sees_faithd_and_the_autopilot_and_reaches_neither") {
        return;
    }
    // The autopilot plays 7 s, the pilot's switch in AUTO until 4.5 s, then MANUAL;
    // the ground station listens for 6 s.
    let Flight {
        ground,
        autopilot,
        log,
        rolled,
    } = fly(&["7", "--manual-after=4.5"], "6", "");
    println!("{}", ground.capture);

    // faithd announces itself as an onboard controller of the vehicle, once a second.
    let hb = &ground.heartbeats.get("1/191").expect("faithd's HEARTBEAT");
    assert_eq!(
        (hb.mav_type.as_str(), hb.autopilot.as_str()),
        ("ONBOARD_CONTROLLER", "INVALID")
    );
    let faithd_hb = &ground.seen["HEARTBEAT 1/191"];
    assert!(
        faithd_hb.count >= 5 && (0.8..=1.25).contains(&faithd_hb.rate_hz),
        "faithd's HEARTBEAT: {} at {:.2} Hz",
        faithd_hb.count,
        faithd_hb.rate_hz
    );

    // STATUSTEXT: the gate opening, the roll, the switch to MANUAL; all from faithd,
    // whole (50 characters at most), at the severities chosen for ground stations.
    for t in &ground.statustext {
        assert_eq!(t.from, "1/191", "{}", t.text);
        assert!(
            t.text.len() <= 50 && t.text.starts_with("faithd: "),
            "{}",
            t.text
        );
    }
    let find = |prefix: &str| {
        ground
            .statustext
            .iter()
            .position(|t| t.text.starts_with(prefix))
            .unwrap_or_else(|| {
                panic!(
                    "no STATUSTEXT `{prefix}...`:\n{}\njournal:\n{log}",
                    ground.capture
                )
            })
    };
    let open = find("faithd: gate open");
    let roll = find("faithd: roll ");
    let manual = find("faithd: gate closed: switch MANUAL");
    assert!(open < roll && roll < manual, "{}", ground.capture);
    assert_eq!(ground.statustext[open].severity, "NOTICE");
    assert_eq!(ground.statustext[roll].severity, "WARNING");
    assert!(
        ground.statustext[roll].text.contains("obstacle TTC"),
        "{}",
        ground.statustext[roll].text
    );
    assert_eq!(ground.statustext[manual].severity, "NOTICE");
    assert!(rolled, "the roll reached iNav (model) too");

    // The values to plot: every name at 4 Hz, the pipeline's figures in them.
    for name in VALUE_NAMES {
        let hz = ground.values_hz.get(name).copied().unwrap_or(0.0);
        assert!(
            (3.5..=4.5).contains(&hz),
            "NAMED_VALUE_FLOAT {name} at {hz:.2} Hz"
        );
    }
    let finite = |name: &str| {
        ground.values[name]
            .iter()
            .filter_map(|(_, v)| *v)
            .filter(|v| v.is_finite())
            .collect::<Vec<_>>()
    };
    assert!(
        finite("events_hz").iter().any(|&r| r > 1000.0),
        "events_hz: {:?}",
        finite("events_hz")
    );
    assert!(
        finite("cycle_ms").iter().all(|&c| c > 0.0 && c < 10.0),
        "cycle_ms: {:?}",
        finite("cycle_ms")
    );
    assert!(!finite("ttc_s").is_empty() && !finite("foe_x_px").is_empty());

    // The autopilot's telemetry, forwarded with the autopilot's own ids, at its rate.
    for kind in ["ATTITUDE 1/1", "RC_CHANNELS 1/1"] {
        let seen = ground.seen.get(kind).unwrap_or_else(|| panic!("no {kind}"));
        assert!(
            seen.rate_hz >= 18.0,
            "{kind} forwarded at {:.1} Hz",
            seen.rate_hz
        );
    }
    assert_eq!(ground.heartbeats["1/1"].mav_type, "QUADROTOR");

    // The ground station tried to fly; the autopilot heard nothing but faithd.
    assert!(
        ground.sent["RC_CHANNELS_OVERRIDE"] >= 20,
        "{:?}",
        ground.sent
    );
    assert!(ground.sent["COMMAND_LONG"] >= 20, "{:?}", ground.sent);
    assert_eq!(
        autopilot.received.keys().collect::<Vec<_>>(),
        ["HEARTBEAT 1/191"],
        "the autopilot received {:?}",
        autopilot.received
    );
    assert!(
        log.contains("frame from the ground station not forwarded to the autopilot")
            && (log.contains("message_name=\"RC_CHANNELS_OVERRIDE\"")
                || log.contains("message_name=\"COMMAND_LONG\"")),
        "the journal names what it kept from the autopilot:\n{log}"
    );
    println!(
        "rates: faithd HEARTBEAT {:.2} Hz, NAMED_VALUE_FLOAT {}, ATTITUDE {:.1} Hz, RC_CHANNELS {:.1} Hz; ground sent {:?}; autopilot received {:?}",
        faithd_hb.rate_hz,
        VALUE_NAMES
            .iter()
            .map(|n| format!("{n} {:.2} Hz", ground.values_hz[*n]))
            .collect::<Vec<_>>()
            .join(", "),
        ground.seen["ATTITUDE 1/1"].rate_hz,
        ground.seen["RC_CHANNELS 1/1"].rate_hz,
        ground.sent,
        autopilot.received
    );
}

#[test]
fn forwarding_to_the_autopilot_lets_commands_through_but_never_stick_input() {
    if !peers_available("forwarding_to_the_autopilot_lets_commands_through_but_never_stick_input") {
        return;
    }
    let Flight {
        ground, autopilot, ..
    } = fly(&["4.5"], "3.5", "forward_to_autopilot = true\n");
    let from_ground = |kind: &str| {
        autopilot
            .received
            .get(&format!("{kind} 255/190"))
            .copied()
            .unwrap_or(0)
    };
    assert!(ground.sent["COMMAND_LONG"] >= 10, "{:?}", ground.sent);
    // UDP on loopback loses nothing here: every command the ground sent arrives, with
    // the ground station's own ids (forwarded as received).
    assert_eq!(
        from_ground("COMMAND_LONG"),
        ground.sent["COMMAND_LONG"],
        "{:?}",
        autopilot.received
    );
    assert_eq!(from_ground("HEARTBEAT"), ground.sent["HEARTBEAT"]);
    assert!(
        !autopilot
            .received
            .keys()
            .any(|k| k.starts_with("RC_CHANNELS_OVERRIDE")),
        "stick input reached the autopilot: {:?}",
        autopilot.received
    );
}
