//! The flight daemon end to end: the real `faithd run` binary, its sim camera flying
//! at a pole, and a mock iNav on a real pseudo-terminal exchanging MAVLink 2 bytes.

mod common;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use common::{Controls, Daemon, MockAutopilot, TempDir, point_symlink};

/// The defaults the daemon runs with (config/faithd.toml).
const SEND_PERIOD: Duration = Duration::from_millis(20);
const ROLL: Duration = Duration::from_millis(1500);
/// Scheduling slack for a loaded 2-core test machine, on top of the spec'd bound.
const SLACK: Duration = Duration::from_millis(15);

fn is_roll(v: u16) -> bool {
    v == 1200 || v == 1800
}

fn start(controls: Controls) -> (MockAutopilot, Daemon) {
    let mock = MockAutopilot::start(Arc::new(controls));
    let endpoint = format!("serial:{}", mock.slave_path.display());
    let daemon = Daemon::start(&endpoint, "");
    (mock, daemon)
}

fn first_roll(mock: &MockAutopilot) -> Option<Instant> {
    mock.overrides()
        .iter()
        .find(|(_, o)| is_roll(o.chan1_raw))
        .map(|(t, _)| *t)
}

#[test]
fn auto_switch_rolls_for_the_configured_time_then_releases() {
    let (mock, mut daemon) = start(Controls::default());
    assert!(
        mock.wait_for(Duration::from_secs(10), |m| m
            .overrides()
            .iter()
            .any(|(_, o)| o.chan1_raw == 0)),
        "no roll and release within 10 s; log:\n{}",
        daemon.log()
    );
    let overrides = mock.overrides();
    let rolls: Vec<_> = overrides
        .iter()
        .filter(|(_, o)| is_roll(o.chan1_raw))
        .collect();
    let release = overrides.iter().find(|(_, o)| o.chan1_raw == 0).unwrap();
    let start = rolls[0].0;
    let lasted = release.0 - start;
    assert!(
        lasted + SEND_PERIOD >= ROLL && lasted <= ROLL + SEND_PERIOD + SLACK,
        "roll lasted {lasted:?}, configured {ROLL:?}"
    );
    let gaps = rolls.windows(2).map(|w| w[1].0 - w[0].0);
    let worst = gaps.max().unwrap();
    eprintln!(
        "measured: roll lasted {lasted:?}, worst re-send gap {worst:?}, {} frames",
        rolls.len()
    );
    assert!(worst <= 2 * SEND_PERIOD + SLACK, "re-send gap {worst:?}");
    // Only the roll channel: every other channel says "ignore".
    for (_, o) in &overrides {
        assert_eq!(
            [
                o.chan2_raw,
                o.chan3_raw,
                o.chan4_raw,
                o.chan6_raw,
                o.chan8_raw
            ],
            [u16::MAX; 5]
        );
        assert_eq!(o.target_system, 1);
    }
    assert!(
        rolls
            .iter()
            .all(|(_, o)| o.chan1_raw == rolls[0].1.chan1_raw)
    );
    assert!(
        daemon.log().contains("manoeuvre started"),
        "{}",
        daemon.log()
    );
    assert!(daemon.stop().success());
}

#[test]
fn manual_switch_means_no_override_is_ever_sent() {
    let controls = Controls::default();
    controls.switch_us.store(1000, Ordering::Relaxed);
    let (mock, mut daemon) = start(controls);
    // Long enough for the sim approach to make the pipeline decide to roll.
    let decided = mock.wait_for(Duration::from_secs(8), |_| {
        daemon.log().contains("decision: roll")
    });
    assert!(
        decided,
        "the pipeline never wanted to roll:\n{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(500));
    assert!(mock.heartbeats() > 0, "the link never came up");
    assert!(
        mock.overrides().is_empty(),
        "override sent with the switch in MANUAL: {:?}",
        mock.overrides()
    );
    assert!(daemon.log().contains("pilot switch not in AUTO"));
    assert!(daemon.stop().success());
}

#[test]
fn switching_to_manual_mid_manoeuvre_releases_within_one_send_period() {
    let (mock, mut daemon) = start(Controls::default());
    assert!(
        mock.wait_for(Duration::from_secs(10), |m| first_roll(m).is_some()),
        "no roll: {}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(300));
    mock.controls.switch_us.store(1000, Ordering::Relaxed);
    let flipped = Instant::now();
    std::thread::sleep(Duration::from_millis(800));
    // The first RC_CHANNELS frame that carried MANUAL.
    let manual_at = mock
        .rc_sent
        .lock()
        .unwrap()
        .iter()
        .find(|r| r.at >= flipped && r.switch_us == 1000)
        .unwrap()
        .at;
    let overrides = mock.overrides();
    let release = overrides
        .iter()
        .find(|(t, o)| *t >= manual_at && o.chan1_raw == 0)
        .expect("released");
    eprintln!(
        "measured: released {:?} after the MANUAL frame",
        release.0 - manual_at
    );
    assert!(
        release.0 - manual_at <= SEND_PERIOD + SLACK,
        "released {:?} after the switch frame",
        release.0 - manual_at
    );
    assert!(
        !overrides
            .iter()
            .any(|(t, o)| *t > release.0 && is_roll(o.chan1_raw)),
        "rolled again after the pilot took over"
    );
    assert!(daemon.log().contains("manoeuvre cut"), "{}", daemon.log());
    assert!(daemon.stop().success());
}

#[test]
fn stale_attitude_or_rc_stops_commands() {
    for (which, limit) in [("attitude", 100u64), ("rc", 300)] {
        let (mock, mut daemon) = start(Controls::default());
        assert!(
            mock.wait_for(Duration::from_secs(10), |m| first_roll(m).is_some()),
            "{which}: no roll: {}",
            daemon.log()
        );
        std::thread::sleep(Duration::from_millis(200));
        let flag = match which {
            "attitude" => &mock.controls.send_attitude,
            _ => &mock.controls.send_rc,
        };
        flag.store(false, Ordering::Relaxed);
        let stopped = Instant::now();
        std::thread::sleep(Duration::from_millis(limit + 400));
        let overrides = mock.overrides();
        let release = overrides
            .iter()
            .find(|(t, o)| *t >= stopped && o.chan1_raw == 0)
            .unwrap_or_else(|| panic!("{which}: never released"));
        let bound = Duration::from_millis(limit) + 2 * SEND_PERIOD + SLACK;
        eprintln!(
            "measured: {which} stopped, released after {:?}",
            release.0 - stopped
        );
        assert!(
            release.0 - stopped <= bound,
            "{which}: released {:?} after the data stopped",
            release.0 - stopped
        );
        assert!(
            !overrides
                .iter()
                .any(|(t, o)| *t > release.0 && is_roll(o.chan1_raw)),
            "{which}: rolled on stale data"
        );
        assert!(daemon.log().contains("stale"), "{}", daemon.log());
        daemon.stop();
    }
}

#[test]
fn disarmed_means_no_commands() {
    let controls = Controls::default();
    controls.armed.store(false, Ordering::Relaxed);
    let (mock, daemon) = start(controls);
    let decided = mock.wait_for(Duration::from_secs(8), |_| {
        daemon.log().contains("decision: roll")
    });
    assert!(decided, "{}", daemon.log());
    std::thread::sleep(Duration::from_millis(300));
    assert!(mock.heartbeats() > 0);
    assert!(mock.overrides().is_empty(), "{:?}", mock.overrides());
    assert!(daemon.log().contains("vehicle disarmed"));
}

#[test]
fn garbage_and_truncated_frames_are_skipped() {
    let controls = Controls::default();
    controls.garbage.store(true, Ordering::Relaxed);
    let (mock, mut daemon) = start(controls);
    // The garbage includes a broken-checksum and a truncated HEARTBEAT saying
    // "disarmed": had either been believed, the gate would have stayed shut.
    assert!(
        mock.wait_for(Duration::from_secs(10), |m| first_roll(m).is_some()),
        "no roll through the garbage: {}",
        daemon.log()
    );
    assert!(daemon.is_running());
    assert!(!daemon.log().contains("panicked"));
    assert!(daemon.stop().success());
}

#[test]
fn the_port_vanishing_and_returning_is_survived() {
    let dir = TempDir::new("replug");
    let link = dir.0.join("ttyFC");
    let controls = Arc::new(Controls::default());
    let mock = MockAutopilot::start(controls.clone());
    point_symlink(&link, &mock.slave_path);
    let mut daemon = Daemon::start(&format!("serial:{}", link.display()), "");
    assert!(
        mock.wait_for(Duration::from_secs(5), |m| m.heartbeats() > 0),
        "{}",
        daemon.log()
    );
    mock.unplug();
    std::thread::sleep(Duration::from_millis(700));
    assert!(daemon.is_running(), "faithd died with the port");
    let mock = MockAutopilot::start(controls);
    point_symlink(&link, &mock.slave_path);
    // Back: heartbeats flow again and the next approach is avoided.
    assert!(
        mock.wait_for(Duration::from_secs(10), |m| first_roll(m).is_some()),
        "no roll after the port came back: {}",
        daemon.log()
    );
    let log = daemon.log();
    assert!(log.contains("autopilot link lost"), "{log}");
    assert!(log.matches("autopilot link up").count() >= 2, "{log}");
    assert!(daemon.stop().success());
}

#[test]
fn sigterm_releases_the_roll_channel() {
    let (mock, mut daemon) = start(Controls::default());
    assert!(mock.wait_for(Duration::from_secs(10), |m| first_roll(m).is_some()));
    let stopped = Instant::now();
    assert!(daemon.stop().success());
    std::thread::sleep(Duration::from_millis(100));
    assert!(
        mock.overrides()
            .iter()
            .any(|(t, o)| *t >= stopped && o.chan1_raw == 0),
        "no release on shutdown"
    );
}

#[test]
fn msp_sink_sends_the_roll_as_msp_set_raw_rc_and_nothing_over_mavlink() {
    use faithd::command::msp::{Decoder, MSP_SET_RAW_RC};
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let msp = common::MspPort::start();
    let mut daemon = Daemon::start(
        &format!("serial:{}", mock.slave_path.display()),
        &format!(
            "[command]\nsink = \"msp\"\nmsp_endpoint = \"serial:{}\"\n",
            msp.slave_path.display()
        ),
    );
    let roll_ch1 = |bytes: &[(Instant, Vec<u8>)]| {
        let mut d = Decoder::default();
        let mut frames = Vec::new();
        let mut out = Vec::new();
        for (t, chunk) in bytes {
            d.push(chunk, &mut frames);
            for f in frames.drain(..) {
                assert_eq!(f.direction, b'<');
                assert_eq!(f.command, MSP_SET_RAW_RC);
                assert_eq!(f.payload.len(), 16, "8 channels");
                out.push((*t, u16::from_le_bytes([f.payload[0], f.payload[1]])));
            }
        }
        out
    };
    let released = || {
        let ch1 = roll_ch1(&msp.bytes.lock().unwrap());
        ch1.iter().any(|(_, v)| is_roll(*v)) && ch1.last().is_some_and(|(_, v)| *v == 1500)
    };
    let deadline = Instant::now() + Duration::from_secs(10);
    while !released() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(released(), "no MSP roll and release: {}", daemon.log());
    let ch1 = roll_ch1(&msp.bytes.lock().unwrap());
    let start = ch1.iter().find(|(_, v)| is_roll(*v)).unwrap().0;
    let end = ch1
        .iter()
        .find(|(t, v)| *t > start && *v == 1500)
        .unwrap()
        .0;
    assert!(end - start + SEND_PERIOD >= ROLL && end - start <= ROLL + SEND_PERIOD + SLACK);
    assert!(
        mock.overrides().is_empty(),
        "MAVLink override sent with the MSP sink"
    );
    assert!(daemon.stop().success());
}

#[test]
fn an_impossible_budget_sheds_load_logs_overruns_and_still_flies() {
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let mut daemon = Daemon::start(
        &format!("serial:{}", mock.slave_path.display()),
        "[daemon]\nbudget_us = 100\n",
    );
    assert!(
        mock.wait_for(Duration::from_secs(10), |m| first_roll(m).is_some()),
        "no roll under load shedding: {}",
        daemon.log()
    );
    let log = daemon.log();
    assert!(log.contains("cycle overran its budget"), "{log}");
    assert!(log.contains("load level changed"), "{log}");
    assert!(log.contains("max_vectors=300"), "shed to the floor: {log}");
    assert!(daemon.stop().success());
}

#[test]
fn every_flight_is_recorded_and_the_recording_replays_to_a_roll() {
    use faithd::link::tlog::TlogReader;
    use mavlink::dialects::common::MavMessage;
    let (mock, mut daemon) = start(Controls::default());
    assert!(mock.wait_for(Duration::from_secs(10), |m| first_roll(m).is_some()));
    std::thread::sleep(Duration::from_millis(300));
    assert!(daemon.stop().success());
    let dir = daemon.flights_dir();
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    let aedat = names
        .iter()
        .find(|p| p.extension().unwrap() == "aedat4")
        .expect("event recording");
    let tlog = names
        .iter()
        .find(|p| p.extension().unwrap() == "tlog")
        .expect("mavlink recording");

    let mut reader = faithd::source::open_events(aedat).unwrap();
    let events = faithd::source::read_all(&mut reader).unwrap();
    assert!(events.len() > 10_000, "{} events recorded", events.len());

    let mut r = TlogReader::new(std::fs::File::open(tlog).unwrap());
    let (mut attitude_in, mut overrides_out, mut own_heartbeats) = (0, 0, 0);
    while let Some(rec) = r.next_record().unwrap() {
        match rec.message {
            Some(MavMessage::ATTITUDE(_))
                if rec.header.system_id == 1 && rec.header.component_id == 1 =>
            {
                attitude_in += 1
            }
            Some(MavMessage::RC_CHANNELS_OVERRIDE(_)) if rec.header.component_id == 191 => {
                overrides_out += 1
            }
            Some(MavMessage::HEARTBEAT(_)) if rec.header.component_id == 191 => own_heartbeats += 1,
            _ => {}
        }
    }
    assert!(attitude_in > 50, "{attitude_in} ATTITUDE recorded");
    assert!(
        overrides_out >= mock.overrides().len().min(70),
        "{overrides_out} overrides recorded"
    );
    assert!(own_heartbeats >= 1);

    // The window log replays the flight exactly: every window, with the recorded
    // attitude put back on the daemon clock, gives the decision made in flight.
    let windows = names
        .iter()
        .find(|p| p.to_string_lossy().ends_with(".windows.jsonl"))
        .expect("window log");
    let logged_windows = std::fs::read_to_string(windows).unwrap().lines().count() - 1;
    assert!(logged_windows > 50, "{logged_windows} windows logged");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_faithd"))
        .args(["replay", "--json", "--events"])
        .arg(aedat)
        .arg("--mavlink")
        .arg(tlog)
        .arg("--windows")
        .arg(windows)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "replayed {logged_windows} windows: every one as decided in flight"
        )),
        "{stderr}"
    );
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), logged_windows);
    let derotated = lines.iter().filter(|l| l["derotated"] == true).count();
    assert!(
        derotated * 10 > lines.len() * 9,
        "only {derotated} of {} windows had attitude",
        lines.len()
    );
    let rolls = lines
        .iter()
        .filter(|l| l["decision"]["action"]["kind"] == "roll")
        .count();
    assert!(
        rolls > 0,
        "the recorded approach replays to a roll decision"
    );

    // Other settings on the same flight give other windows, and the replay says so.
    let dir = TempDir::new("replay-config");
    let config = dir.0.join("faithd.toml");
    std::fs::write(&config, "[pipeline]\nseed = 7\n").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_faithd"))
        .args(["replay", "--events"])
        .arg(aedat)
        .arg("--mavlink")
        .arg(tlog)
        .arg("--windows")
        .arg(windows)
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("differ from the flight"), "{stderr}");
}
