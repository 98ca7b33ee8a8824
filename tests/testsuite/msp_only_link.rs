//! The MSP-only link in CI: the real `faithd run` against faithd's model of iNav on a
//! board without MAVLink (two MSP ports of one modelled iNav on pseudo-terminals,
//! `MockAutopilot::start_msp_only`). The model answers MSP_RAW_IMU, MSP_ATTITUDE,
//! MSP_RC, MSP2_INAV_STATUS and the global variables as iNav's fc/fc_msp.c does; every
//! assertion is on what the model's iNav did or served. `inav_sitl::msp_only` holds
//! the same link to iNav's own firmware.

use crate::common;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use common::autopilot::{Controls, MockAutopilot};
use common::daemon::Daemon;
use common::msp::{MspMock, Traffic};
use faithd_inav::msp::Setup;

fn start(controls: Controls, extra: &str) -> (MockAutopilot, Daemon) {
    let mock = MockAutopilot::start_msp_only(Arc::new(controls), Setup::default());
    let daemon = Daemon::start_config(
        &format!(
            "{}[mavlink]\nreconnect_min_us = 50000\nreconnect_max_us = 200000\n\
             [source]\nkind = \"sim\"\nfirst_approach_us = 1000000\nrepeat_us = 4000000\n{extra}",
            mock.msp_only_toml()
        ),
        &[],
    );
    (mock, daemon)
}

fn telemetry(mock: &MockAutopilot) -> &MspMock {
    mock.telemetry.as_ref().expect("the telemetry port")
}

/// The most requests that reached a port in any second, and the most waiting there.
fn busiest(traffic: &Traffic) -> (usize, usize) {
    let arrived: Vec<Instant> = traffic.arrived.iter().map(|(t, _)| *t).collect();
    let served: Vec<Instant> = traffic.served.iter().map(|(t, _)| *t).collect();
    let per_second = arrived
        .iter()
        .map(|t0| {
            arrived
                .iter()
                .filter(|t| **t >= *t0 && **t < *t0 + Duration::from_secs(1))
                .count()
        })
        .max()
        .unwrap_or(0);
    let waiting = arrived
        .iter()
        .map(|t| {
            arrived.iter().filter(|a| *a <= t).count() - served.iter().filter(|s| *s <= t).count()
        })
        .max()
        .unwrap_or(0);
    (per_second, waiting)
}

/// No MAVLink anywhere: the gate opens on what faithd read over MSP, a roll lands on
/// the modelled iNav and is given back, and each port carries at most half of what
/// the board serves, one request at a time.
#[test]
fn a_roll_lands_over_msp_alone_within_each_ports_budget() {
    let (mock, mut daemon) = start(Controls::default(), "[command]\nmsp_timeout_us = 5000000\n");
    assert!(
        mock.msp
            .wait_for(Duration::from_secs(10), |m| m.first_roll().is_some()),
        "iNav never used a roll; journal:\n{}",
        daemon.log()
    );
    let first = mock.first_roll().unwrap();
    std::thread::sleep(Duration::from_millis(2500));
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    assert!(log.contains("autopilot telemetry over MSP up"), "{log}");
    assert!(!log.contains("MAVLink frames"), "{log}");
    let (back, value) = mock.msp.unrolled_after(first).expect("the roll ended");
    eprintln!(
        "measured (model, MSP-only): roll in use for {:?}, then {value} us",
        back - first
    );
    assert!(back - first >= Duration::from_millis(1400), "{log}");
    for (port, m) in [("telemetry", telemetry(&mock)), ("command", &mock.msp)] {
        let traffic = m.traffic.lock().unwrap().clone();
        let (per_second, waiting) = busiest(&traffic);
        let span = traffic.arrived.last().unwrap().0 - traffic.arrived[0].0;
        eprintln!(
            "measured (model, {port} port): {} requests in {span:?}, at most {per_second} in any second, at most {waiting} waiting",
            traffic.arrived.len()
        );
        assert_eq!(traffic.bytes_lost, 0, "{port}: the receive ring overflowed");
        assert!(per_second <= 51, "{port}: {per_second} in one second");
        assert!(waiting <= 1, "{port}: {waiting} requests waiting");
    }
    let asked = |command: u16| {
        telemetry(&mock)
            .traffic
            .lock()
            .unwrap()
            .served
            .iter()
            .filter(|(_, c)| *c == command)
            .count()
    };
    // The schedule asks the gyro twice as often as the channels (25 and 12.5 a
    // second); a session cut short by a late reply can end between the two.
    let (gyro, channels) = (asked(102), asked(105));
    assert!(
        gyro + 2 >= 2 * channels && gyro > channels,
        "the gyro asked most: {gyro} MSP_RAW_IMU, {channels} MSP_RC"
    );
}

/// The pilot's switch read over MSP: MANUAL closes the gate and iNav never uses a
/// roll; iNav's failsafe closes it too.
#[test]
fn manual_and_inavs_failsafe_close_the_gate_over_msp() {
    let controls = Controls::default();
    controls.switch_us.store(1000, Ordering::Relaxed);
    let (mock, mut daemon) = start(controls, "");
    assert!(
        daemon.wait_for_log("pilot switch not in AUTO (1000 us)", Duration::from_secs(5)),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_secs(2));
    assert_eq!(mock.first_roll(), None, "a roll in MANUAL");
    mock.controls.switch_us.store(1900, Ordering::Relaxed);
    mock.controls.system_status.store(5, Ordering::Relaxed);
    assert!(
        daemon.wait_for_log(
            "the autopilot reports the pilot's radio lost",
            Duration::from_secs(5)
        ),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_secs(2));
    assert!(daemon.stop().success());
    assert_eq!(mock.first_roll(), None, "a roll in failsafe");
}

/// The gyro the model reports over MSP_RAW_IMU is what derotation gets: recorded as
/// ATTITUDE in iNav's degrees per second, the whole degrees iNav rounds it to, and
/// the flight replays to the decisions made in it, as a MAVLink flight does.
#[test]
fn a_flight_over_msp_records_inavs_rounded_gyro_and_replays_exactly() {
    use faithd_formats::tlog::TlogReader;
    use mavlink::dialects::common::MavMessage;
    let controls = Controls::default();
    // iNav rounds with lrintf (ties to even: 30.5 would give 30).
    controls.motion.lock().unwrap().gyro_dps = [12.6, -3.4, 30.6];
    let (mock, mut daemon) = start(controls, "");
    // Through the first approach (the simulated camera's events know nothing of the
    // rotation: derotation of them is what is replayed, not a roll).
    assert!(
        daemon.wait_for_log("safety gate", Duration::from_secs(5)),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(2500));
    assert!(daemon.stop().success());
    drop(mock);
    let flight = crate::common::recording::flight(&daemon.flights_dir());
    let (aedat, tlog, windows) = (flight.events, flight.tlog, flight.windows);
    let mut r = TlogReader::new(std::fs::File::open(&tlog).unwrap());
    let mut rates = Vec::new();
    while let Some(rec) = r.next_record().unwrap() {
        if let Some(MavMessage::ATTITUDE(a)) = rec.message {
            rates.push((a.rollspeed, a.pitchspeed, a.yawspeed));
        }
    }
    // 25 a second over the second or two the daemon ran.
    assert!(rates.len() > 25, "{} ATTITUDE", rates.len());
    assert!(rates.iter().all(|r| *r == (13.0, -3.0, 31.0)), "{rates:?}");
    let logged = std::fs::read_to_string(&windows).unwrap().lines().count() - 1;
    let out = crate::common::faithd()
        .args(["replay", "--json", "--events"])
        .arg(&aedat)
        .arg("--mavlink")
        .arg(&tlog)
        .arg("--windows")
        .arg(&windows)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "replayed {logged} windows: every one as decided in flight"
        )),
        "{stderr}"
    );
}

/// The goggles' variables on the modelled iNav: MANUAL (2), open (1), the roll's
/// side while it lasts, and 0 once faithd stops.
#[test]
fn the_goggles_variables_follow_the_gate_and_the_roll() {
    let controls = Controls::default();
    controls.switch_us.store(1000, Ordering::Relaxed);
    let (mock, mut daemon) = start(controls, "[osd]\nenabled = true\n");
    let gvars = |pred: &dyn Fn(&[i32]) -> bool| {
        mock.msp
            .wait_for(Duration::from_secs(8), |m| pred(&m.gvars()))
    };
    assert!(
        gvars(&|g| g[5] == 2 && g[6] == 0),
        "MANUAL: {:?}",
        mock.msp.gvars()
    );
    mock.controls.switch_us.store(1900, Ordering::Relaxed);
    assert!(
        gvars(&|g| g[5] == 1),
        "open: {:?}\n{}",
        mock.msp.gvars(),
        daemon.log()
    );
    assert!(
        gvars(&|g| g[6] != 0 && g[7] > 0),
        "rolling, with the time to contact: {:?}\n{}",
        mock.msp.gvars(),
        daemon.log()
    );
    assert!(daemon.stop().success());
    assert_eq!(mock.msp.gvars()[5], 0, "cleared on SIGTERM");
    let writes = mock.msp.gvar_log.lock().unwrap().clone();
    // Two slots in every ten at most (every 400 ms two, 160 ms apart: six fit in one
    // second), and the clearing write at the end.
    let most = writes
        .iter()
        .map(|(t0, _, _)| {
            writes
                .iter()
                .filter(|(t, _, _)| *t >= *t0 && *t < *t0 + Duration::from_secs(1))
                .count()
        })
        .max()
        .unwrap();
    eprintln!(
        "measured (model): {} variable writes, at most {most} in any second",
        writes.len()
    );
    assert!(most <= 7, "{most} writes in one second");
}

/// `faithd check-fc` over MSP alone, on a board whose iNav has no MAVLink at all: the
/// set-up passes with `[telemetry] kind = "msp"`, and the MAVLink link is refused
/// with the faithd.toml line that switches.
#[test]
fn check_fc_judges_a_board_without_mavlink() {
    let setup = Setup {
        has_mavlink: false,
        ..Setup::default()
    };
    let mock = MockAutopilot::start_msp_only(Arc::new(Controls::default()), setup);
    let run = |toml: &str| {
        let dir = common::TempDir::new("check-fc-msp");
        let config = dir.0.join("faithd.toml");
        std::fs::write(&config, toml).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_faithd"))
            .args(["check-fc", "--no-cli", "--config"])
            .arg(&config)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
        )
    };
    let (code, out) = run(&mock.msp_only_toml());
    assert_eq!(code, Some(0), "{out}");
    assert!(
        out.contains("ok    telemetry port: iNav answers MSP"),
        "{out}"
    );
    let (code, out) = run(&mock.msp.command_toml());
    assert_eq!(code, Some(2), "{out}");
    assert!(out.contains("this build has no MAVLink"), "{out}");
    assert!(
        out.contains("fix in faithd.toml: [telemetry] kind = \"msp\""),
        "{out}"
    );
}
