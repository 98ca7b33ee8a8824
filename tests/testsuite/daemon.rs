//! The flight daemon end to end against a mock iNav: the real `faithd run` binary,
//! its sim camera flying at a pole, MAVLink 2 bytes on one pseudo-terminal and the
//! MSP roll stream on another, answered by faithd's model of iNav's MSP RC override.
//!
//! These are the situations iNav's own firmware cannot be made to produce on
//! demand: stale telemetry, garbage on the wire, a port that vanishes, a status that
//! says failsafe, a roll iNav silently ignores. What the route does on the real
//! firmware is `tests/testsuite/inav_sitl.rs`.

use crate::common;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use common::autopilot::{Controls, MockAutopilot, PILOT_ROLL_US};
use common::daemon::Daemon;
use common::msp::MspMock;
use common::{TempDir, point_symlink, poll_until};

/// The defaults the daemon runs with (config/faithd.toml).
/// One MSP command per 20 ms slot; the roll frame at least every 40 ms.
const SLOT: Duration = Duration::from_millis(20);
const ROLL_FRAME_PERIOD: Duration = Duration::from_millis(40);
/// From a change in the commander to iNav using it: the request in flight answered
/// (iNav's next serial task run, up to 10 ms), the next slot (20 ms), iNav serving
/// the frame (10 ms).
const TO_INAV: Duration = Duration::from_millis(40);
/// The mock sends RC_CHANNELS every 20 ms (tests/testsuite/common/autopilot.rs says why).
const TELEMETRY: Duration = Duration::from_millis(20);
const ROLL: Duration = Duration::from_millis(1500);
const CENTRE_US: u16 = 1500;
/// Scheduling slack for a loaded 2-core test machine, on top of the spec'd bound.
const SLACK: Duration = Duration::from_millis(15);

fn start(controls: Controls) -> (MockAutopilot, Daemon) {
    let mock = MockAutopilot::start(Arc::new(controls));
    let daemon = Daemon::start_mock(&mock, "");
    (mock, daemon)
}

fn wait_for_roll(mock: &MockAutopilot, daemon: &Daemon, what: &str) -> Instant {
    assert!(
        mock.msp
            .wait_for(Duration::from_secs(10), |m| m.first_roll().is_some()),
        "{what}: iNav never used a roll; journal:\n{}",
        daemon.log()
    );
    mock.first_roll().unwrap()
}

/// The release as iNav took it: when, at or after `t`, it first used a roll that is
/// not faithd's, and what it used (the centre in AUTO, the pilot's stick in MANUAL).
fn released_after(msp: &MspMock, t: Instant) -> Option<(Instant, u16)> {
    msp.unrolled_after(t)
}

/// Whether iNav used a roll of faithd's at or after `t`.
fn rolled_after(msp: &MspMock, t: Instant) -> bool {
    msp.roll_after(t).is_some()
}

/// What faithd's frames carried, for where iNav does not use them, so that what iNav
/// used cannot show a roll: in MANUAL (a roll left in the stream would come back at
/// the next AUTO) and with an override iNav ignores. The first frame iNav served at
/// or after `t` with the centre on roll.
fn centre_frame_after(msp: &MspMock, t: Instant) -> Option<Instant> {
    msp.frames
        .lock()
        .unwrap()
        .iter()
        .find(|(at, ch)| *at >= t && ch[0] == CENTRE_US)
        .map(|(at, _)| *at)
}

/// The frames iNav served after `t` with anything but the centre on roll (see
/// [`centre_frame_after`] for where they are the evidence).
fn roll_frames_after(msp: &MspMock, t: Instant) -> usize {
    msp.frames
        .lock()
        .unwrap()
        .iter()
        .filter(|(at, ch)| *at > t && ch[0] != CENTRE_US)
        .count()
}

#[test]
fn a_roll_in_auto_lasts_its_time_and_touches_roll_alone() {
    let (mock, mut daemon) = start(Controls::default());
    let start = wait_for_roll(&mock, &daemon, "auto");
    std::thread::sleep(ROLL + Duration::from_millis(300));
    let (end, value) = mock.msp.unrolled_after(start).expect("the roll ended");
    let lasted = end - start;
    eprintln!("measured: roll in use for {lasted:?}, then {value} us");
    assert!(
        lasted + TO_INAV >= ROLL && lasted <= ROLL + TO_INAV + SLACK,
        "roll in use for {lasted:?}, configured {ROLL:?}; journal:\n{}",
        daemon.log()
    );
    assert_eq!(value, CENTRE_US, "AUTO holds the centre after the roll");
    // Every frame: roll in the roll slot, and elsewhere what iNav reports using (the
    // pilot's throttle 1400 in the radio's third slot, the AUX channels), or the centre
    // on the four flight channels before the first report. iNav takes roll alone from
    // it (msp_override_channels = 1); a channel added to that mask keeps the pilot's.
    let frames = mock.msp.frames.lock().unwrap().clone();
    let span = frames.last().unwrap().0 - frames[0].0;
    let expected = (span.as_secs_f64() / ROLL_FRAME_PERIOD.as_secs_f64()) as usize;
    assert!(
        frames.len() + 2 >= expected,
        "{} frames in {span:?}",
        frames.len()
    );
    let mut pilots = vec![CENTRE_US, 1400, CENTRE_US, 1900, 1900, 1000, 1000];
    pilots.extend([CENTRE_US; 10]);
    for (_, ch) in &frames {
        // The centre, or the 300 us roll faithd means.
        assert!([CENTRE_US, 1200, 1800].contains(&ch[0]), "{ch:?}");
        assert!(ch[1..] == [CENTRE_US; 3] || ch[1..] == pilots[..], "{ch:?}");
    }
    assert!(frames.iter().any(|(_, ch)| ch[1..] == pilots[..]));
    let gaps = frames.windows(2).map(|w| w[1].0 - w[0].0);
    let worst = gaps.max().unwrap();
    assert!(
        worst <= ROLL_FRAME_PERIOD + SLOT / 2 + SLACK,
        "stream gap {worst:?}"
    );
    assert!(daemon.stop().success());
}

#[test]
fn manual_or_disarmed_means_no_roll_is_ever_commanded() {
    for (what, switch_us, armed, blocker) in [
        ("manual", 1000, true, "pilot switch not in AUTO"),
        ("disarmed", 1900, false, "vehicle disarmed"),
    ] {
        let controls = Controls::default();
        controls.switch_us.store(switch_us, Ordering::Relaxed);
        controls.armed.store(armed, Ordering::Relaxed);
        let (mock, mut daemon) = start(controls);
        assert!(
            daemon.wait_for_log("decision: roll", Duration::from_secs(8)),
            "{what}: the pipeline never wanted to roll:\n{}",
            daemon.log()
        );
        std::thread::sleep(Duration::from_millis(500));
        assert!(mock.heartbeats() > 0, "{what}: the link never came up");
        assert_eq!(mock.first_roll(), None, "{what}: iNav used a roll");
        // In MANUAL iNav does not use the override: only the frames show one not sent.
        assert_eq!(
            roll_frames_after(&mock.msp, Instant::now() - Duration::from_secs(60)),
            0,
            "{what}: faithd wrote a roll"
        );
        assert!(daemon.log().contains(blocker), "{what}: {}", daemon.log());
        assert!(daemon.stop().success());
    }
}

#[test]
fn switching_to_manual_mid_manoeuvre_releases_within_one_send_period() {
    let (mock, mut daemon) = start(Controls::default());
    wait_for_roll(&mock, &daemon, "manual mid-roll");
    std::thread::sleep(Duration::from_millis(300));
    mock.controls.switch_us.store(1000, Ordering::Relaxed);
    let flipped = Instant::now();
    std::thread::sleep(Duration::from_millis(800));
    // iNav drops the override itself once its switch leaves AUTO: the pilot's stick.
    let (back, used) = released_after(&mock.msp, flipped).expect("iNav released the roll");
    assert_eq!(
        used, PILOT_ROLL_US,
        "iNav used {used} after the switch left AUTO"
    );
    assert!(
        !rolled_after(&mock.msp, back),
        "iNav used a roll after the pilot took over"
    );
    // faithd lets go too: iNav no longer uses its frames, so they are the evidence
    // (a roll left in them would come back at the next AUTO).
    let centre = centre_frame_after(&mock.msp, flipped).expect("released");
    eprintln!(
        "measured: iNav on the pilot's stick {:?}, faithd's centre served {:?} after the \
         switch left AUTO",
        back - flipped,
        centre - flipped
    );
    // iNav's status (MSP, every period) or RC_CHANNELS (every 20 ms here), whichever
    // tells first, then one period.
    assert!(
        centre - flipped <= TELEMETRY + TO_INAV + SLACK,
        "released {:?} after the switch",
        centre - flipped
    );
    assert_eq!(
        roll_frames_after(&mock.msp, centre),
        0,
        "rolled again after the pilot took over"
    );
    assert!(daemon.log().contains("manoeuvre cut"), "{}", daemon.log());
    assert!(daemon.stop().success());
}

#[test]
fn stale_attitude_or_rc_stops_commands() {
    for (which, limit) in [("attitude", 100u64), ("rc", 300)] {
        let (mock, mut daemon) = start(Controls::default());
        wait_for_roll(&mock, &daemon, which);
        std::thread::sleep(Duration::from_millis(200));
        let flag = match which {
            "attitude" => &mock.controls.send_attitude,
            _ => &mock.controls.send_rc,
        };
        flag.store(false, Ordering::Relaxed);
        let stopped = Instant::now();
        std::thread::sleep(Duration::from_millis(limit + 400));
        let (centre, used) =
            released_after(&mock.msp, stopped).unwrap_or_else(|| panic!("{which}: never released"));
        assert_eq!(used, CENTRE_US, "{which}: AUTO holds the centre");
        let bound = Duration::from_millis(limit) + TO_INAV + SLACK;
        eprintln!(
            "measured: {which} stopped, released after {:?}",
            centre - stopped
        );
        assert!(
            centre - stopped <= bound,
            "{which}: released {:?} after the data stopped",
            centre - stopped
        );
        assert!(
            !rolled_after(&mock.msp, centre),
            "{which}: rolled on stale data"
        );
        assert!(daemon.log().contains("stale"), "{}", daemon.log());
        daemon.stop();
    }
}

#[test]
fn the_autopilots_failsafe_or_radio_loss_closes_the_gate() {
    for (what, blocker) in [
        ("failsafe", "the autopilot is in failsafe"),
        ("radio", "pilot's radio lost"),
    ] {
        let (mock, mut daemon) = start(Controls::default());
        wait_for_roll(&mock, &daemon, what);
        std::thread::sleep(Duration::from_millis(200));
        match what {
            // iNav: HEARTBEAT system_status CRITICAL and its FAILSAFE mode over MSP.
            "failsafe" => mock.controls.system_status.store(5, Ordering::Relaxed),
            // iNav clears SYS_STATUS's receiver health the moment frames stop.
            _ => mock.controls.radio_healthy.store(false, Ordering::Relaxed),
        }
        let at = Instant::now();
        std::thread::sleep(Duration::from_millis(600));
        let (centre, used) = released_after(&mock.msp, at)
            .unwrap_or_else(|| panic!("{what}: never released:\n{}", daemon.log()));
        assert_eq!(used, CENTRE_US, "{what}: AUTO holds the centre");
        eprintln!("measured: {what}: released {:?} after", centre - at);
        // The mock reports both every 200 ms (MSP status every period).
        assert!(centre - at <= Duration::from_millis(200) + TO_INAV + SLACK);
        assert!(!rolled_after(&mock.msp, centre), "{what}");
        assert!(daemon.log().contains(blocker), "{what}: {}", daemon.log());
        assert!(daemon.stop().success());
    }
}

#[test]
fn a_roll_that_does_not_take_effect_is_an_error_and_closes_the_gate() {
    let controls = Controls::default();
    controls.override_ignored.store(true, Ordering::Relaxed);
    let (mock, mut daemon) = start(controls);
    assert!(
        daemon.wait_for_log("manoeuvre started", Duration::from_secs(10)),
        "{}",
        daemon.log()
    );
    assert!(
        daemon.wait_for_log(
            "roll not in effect on the flight controller",
            Duration::from_secs(2)
        ),
        "{}",
        daemon.log()
    );
    // The gate's own line follows the error's: on a loaded or emulated machine it can
    // reach the journal a moment later.
    assert!(
        daemon.wait_for_log("did not take effect", Duration::from_secs(2)),
        "{}",
        daemon.log()
    );
    let log = daemon.log();
    assert!(log.contains("ERROR"), "{log}");
    assert!(
        !log.contains("manoeuvre completed"),
        "never reported as a success: {log}"
    );
    // Closed until the pilot leaves AUTO: the next approach (4 s later) rolls nothing.
    std::thread::sleep(TO_INAV);
    let rolls_so_far = roll_frames_after(&mock.msp, Instant::now() - Duration::from_secs(60));
    std::thread::sleep(Duration::from_secs(5));
    assert_eq!(
        roll_frames_after(&mock.msp, Instant::now() - Duration::from_secs(60)),
        rolls_so_far,
        "rolled again with the fault standing: {}",
        daemon.log()
    );
    // MANUAL and back clears it.
    mock.controls.switch_us.store(1000, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(300));
    mock.controls.switch_us.store(1900, Ordering::Relaxed);
    assert!(
        daemon.wait_for_log("the roll fault is cleared", Duration::from_secs(1)),
        "{}",
        daemon.log()
    );
    assert!(daemon.stop().success());
}

#[test]
fn garbage_and_truncated_frames_are_skipped() {
    let controls = Controls::default();
    controls.garbage.store(true, Ordering::Relaxed);
    let (mock, mut daemon) = start(controls);
    // The garbage includes a broken-checksum and a truncated HEARTBEAT saying
    // "disarmed": had either been believed, the gate would have stayed shut.
    wait_for_roll(&mock, &daemon, "garbage");
    assert!(daemon.is_running());
    assert!(!daemon.log().contains("panicked"));
    assert!(daemon.stop().success());
}

#[test]
fn both_ports_vanishing_and_returning_is_survived_and_released() {
    let dir = TempDir::new("replug");
    let (link, msp_link) = (dir.0.join("ttyFC"), dir.0.join("ttyMSP"));
    let controls = Arc::new(Controls::default());
    let mock = MockAutopilot::start(controls.clone());
    point_symlink(&link, &mock.slave_path);
    point_symlink(&msp_link, &mock.msp.slave_path);
    let mut daemon = Daemon::start(
        &format!("serial:{}", link.display()),
        &format!(
            "[command.sink]\nkind = \"msp\"\nendpoint = \"serial:{}\"\n",
            msp_link.display()
        ),
    );
    wait_for_roll(&mock, &daemon, "before the unplug");
    // Mid-roll, both cables out.
    std::thread::sleep(Duration::from_millis(300));
    mock.unplug();
    std::thread::sleep(Duration::from_millis(700));
    assert!(daemon.is_running(), "faithd died with the ports");
    let mock = MockAutopilot::start(controls);
    point_symlink(&link, &mock.slave_path);
    point_symlink(&msp_link, &mock.msp.slave_path);
    // Back: the first roll frame written on the new port is the centre (the release
    // owed since the roll was cut), and the next approach is avoided.
    wait_for_roll(&mock, &daemon, "after the port came back");
    let first = mock.msp.frames.lock().unwrap()[0].1.clone();
    assert_eq!(
        first[0], CENTRE_US,
        "first frame after the reconnect: {first:?}"
    );
    let log = daemon.log();
    assert!(log.contains("autopilot link lost"), "{log}");
    assert!(log.contains("MSP command port lost"), "{log}");
    assert!(log.matches("autopilot link up").count() >= 2, "{log}");
    assert!(daemon.stop().success());
}

#[test]
fn the_mavlink_link_lost_mid_roll_releases_on_the_msp_port_at_once() {
    let dir = TempDir::new("mavlink-loss");
    let link = dir.0.join("ttyFC");
    let mut mock = MockAutopilot::start(Arc::new(Controls::default()));
    point_symlink(&link, &mock.slave_path);
    let mut daemon = Daemon::start(&format!("serial:{}", link.display()), &mock.command_toml());
    wait_for_roll(&mock, &daemon, "mavlink loss");
    std::thread::sleep(Duration::from_millis(300));
    mock.unplug_mavlink();
    let at = Instant::now();
    std::thread::sleep(Duration::from_millis(500));
    let (centre, used) = released_after(&mock.msp, at).expect("released");
    assert_eq!(used, CENTRE_US, "AUTO holds the centre");
    eprintln!(
        "measured: MAVLink port gone, centre in use on iNav {:?} after",
        centre - at
    );
    // The port reports the loss at once, or ATTITUDE goes stale (100 ms).
    assert!(
        centre - at <= Duration::from_millis(100) + TO_INAV + SLACK,
        "released {:?} after the link went",
        centre - at
    );
    assert!(!rolled_after(&mock.msp, centre));
    assert!(daemon.stop().success());
}

#[test]
fn every_shutdown_signal_writes_the_release_repeatedly() {
    use nix::sys::signal::Signal;
    for signal in [Signal::SIGTERM, Signal::SIGINT, Signal::SIGHUP] {
        let (mock, mut daemon) = start(Controls::default());
        wait_for_roll(&mock, &daemon, signal.as_str());
        std::thread::sleep(Duration::from_millis(200));
        let at = Instant::now();
        let status = daemon.signal(signal);
        // SIGHUP is no request to stay down: non-zero, so that systemd's
        // Restart=on-failure starts faithd again.
        let expected = if signal == Signal::SIGHUP { 1 } else { 0 };
        assert_eq!(status.code(), Some(expected), "{signal}: {status:?}");
        std::thread::sleep(Duration::from_millis(50));
        let centres = mock
            .msp
            .frames
            .lock()
            .unwrap()
            .iter()
            .filter(|(t, ch)| *t >= at && ch[0] == CENTRE_US)
            .count();
        // release_repeats = 3 (and perhaps one regular frame before the signal).
        assert!(centres >= 3, "{signal}: {centres} centre frames after it");
        assert!(
            !rolled_after(&mock.msp, at + TO_INAV),
            "{signal}: iNav used a roll after the release"
        );
        let log = daemon.log();
        assert!(
            log.contains(&format!("shutdown requested ({signal})")),
            "{log}"
        );
        assert!(log.contains("3 centre frames written"), "{log}");
    }
}

#[test]
fn a_daemon_restarted_after_a_kill_mid_roll_releases_first() {
    use nix::sys::signal::Signal;
    let (mock, mut daemon) = start(Controls::default());
    wait_for_roll(&mock, &daemon, "kill");
    std::thread::sleep(Duration::from_millis(200));
    // SIGKILL (the OOM killer, a watchdog kill): no release from this one.
    daemon.signal(Signal::SIGKILL);
    let killed = Instant::now();
    // The killed daemon's last frames may still be in the terminal's buffer: the
    // restarted one's start when no frame has come for 100 ms (longer than the unit
    // waits before it restarts faithd).
    let mut before = mock.msp.frames.lock().unwrap().len();
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let now = mock.msp.frames.lock().unwrap().len();
        if now == before {
            break;
        }
        before = now;
    }
    std::thread::sleep(common::unit_restart_delay().saturating_sub(killed.elapsed()));
    let daemon = Daemon::start_mock(&mock, "");
    assert!(
        mock.msp
            .wait_for(Duration::from_secs(3), |m| m.frames.lock().unwrap().len()
                > before),
        "the restarted faithd wrote nothing: {}",
        daemon.log()
    );
    let (at, first) = mock.msp.frames.lock().unwrap()[before].clone();
    eprintln!(
        "measured: restarted faithd's first frame {:?} after the kill",
        at - killed
    );
    assert_eq!(
        first[0], CENTRE_US,
        "its first frame is the release: {first:?}"
    );
}

#[test]
fn an_impossible_budget_sheds_load_logs_overruns_and_still_flies() {
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let mut daemon = Daemon::start_mock(&mock, "[daemon]\nbudget_us = 100\n");
    wait_for_roll(&mock, &daemon, "budget");
    let log = daemon.log();
    assert!(log.contains("cycle overran its budget"), "{log}");
    assert!(log.contains("load level changed"), "{log}");
    assert!(log.contains("max_vectors=300"), "shed to the floor: {log}");
    assert!(daemon.stop().success());
}

#[test]
fn every_flight_is_recorded_and_the_recording_replays_to_a_roll() {
    use faithd_formats::tlog::TlogReader;
    use mavlink::dialects::common::MavMessage;
    let (mock, mut daemon) = start(Controls::default());
    wait_for_roll(&mock, &daemon, "recording");
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

    let mut reader = faithd_formats::events::open_events(aedat).unwrap();
    let events = faithd_formats::events::read_all(&mut reader).unwrap();
    assert!(events.len() > 10_000, "{} events recorded", events.len());

    let mut r = TlogReader::new(std::fs::File::open(tlog).unwrap());
    let (mut attitude_in, mut own_heartbeats) = (0, 0);
    while let Some(rec) = r.next_record().unwrap() {
        match rec.message {
            Some(MavMessage::ATTITUDE(_))
                if rec.header.system_id == 1 && rec.header.component_id == 1 =>
            {
                attitude_in += 1
            }
            Some(MavMessage::HEARTBEAT(_)) if rec.header.component_id == 191 => own_heartbeats += 1,
            _ => {}
        }
    }
    // At iNav's 25 Hz, over the 1.5 s or so the daemon ran.
    assert!(attitude_in >= 25, "{attitude_in} ATTITUDE recorded");
    assert!(own_heartbeats >= 1);

    // The window log replays the flight exactly: every window, with the recorded
    // attitude put back on the daemon clock, gives the decision made in flight.
    let windows = names
        .iter()
        .find(|p| p.to_string_lossy().ends_with(".windows.jsonl"))
        .expect("window log");
    let logged_windows = std::fs::read_to_string(windows).unwrap().lines().count() - 1;
    assert!(logged_windows > 50, "{logged_windows} windows logged");
    let out = crate::common::faithd()
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

    // The same window boundaries: each replayed window ends where the flight's did
    // and holds the same events, and the flight took them by the one windowing rule
    // (`window::events_until`): no window holds an event stamped after its end.
    let logged: Vec<serde_json::Value> = std::fs::read_to_string(windows)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let mut taken = 0usize;
    for (replayed, flown) in lines.iter().zip(&logged) {
        assert_eq!(replayed["t_us"], flown["t_us"]);
        assert_eq!(replayed["events"], flown["events"]);
        let (end_us, count) = (
            flown["t_us"].as_i64().unwrap(),
            flown["events"].as_u64().unwrap() as usize,
        );
        let due = faithd_core::window::events_until(&events[taken..], end_us);
        assert!(
            count <= due,
            "the window ending at {end_us} us took {count} events, only {due} were due"
        );
        taken += count;
    }
    assert!(taken <= events.len());
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
    let out = crate::common::faithd()
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

#[test]
fn a_simulated_camera_needs_the_command_line_opt_in() {
    let dir = TempDir::new("sim-refused");
    let config = dir.0.join("faithd.toml");
    std::fs::write(&config, "[source]\nkind = \"sim\"\n").unwrap();
    let out = crate::common::faithd()
        .args(["run", "--config"])
        .arg(&config)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("source.kind"), "{stderr}");
    assert!(stderr.contains("--simulated-camera"), "{stderr}");
    // The service never gives it; the shipped config names the real camera.
    let unit = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/systemd/faithd.service"
    ))
    .unwrap();
    assert!(!unit.contains("--simulated-camera"), "{unit}");
    let shipped = faithd::config::FaithdConfig::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/faithd.toml"
    )))
    .unwrap();
    assert!(matches!(
        shipped.source,
        faithd::source::SourceConfig::Caer(_)
    ));
}

#[test]
fn the_default_build_opens_libcaer_at_run_time_and_says_when_it_is_missing() {
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let dir = TempDir::new("caer-run");
    let run = |libcaer_path: &str| {
        let config = dir.0.join("faithd.toml");
        std::fs::write(&config, mock.service_toml(libcaer_path, "enabled = false")).unwrap();
        let log = std::fs::File::create(dir.0.join("faithd.log")).unwrap();
        let child = crate::common::faithd()
            .args(["run", "--config"])
            .arg(&config)
            .stderr(log)
            .spawn()
            .unwrap();
        (child, dir.0.join("faithd.log"))
    };
    // The real camera's library where it is not installed: refused, with the reason.
    let (mut child, log) = run("/nonexistent/libcaer.so.3");
    let status = child.wait().unwrap();
    let text = std::fs::read_to_string(&log).unwrap();
    assert_eq!(status.code(), Some(2), "{text}");
    assert!(text.contains("source.libcaer_path"), "{text}");
    assert!(text.contains("libcaer not found"), "{text}");
    // The C mock of libcaer in its place: the same binary opens it and streams,
    // with no --simulated-camera.
    let (mut child, log) = run(&crate::common::caer_mock_library());
    let deadline = Instant::now() + Duration::from_secs(5);
    let streaming = loop {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        if text.contains("camera open: streaming") || Instant::now() > deadline {
            break text;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let _ = nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    );
    let status = child.wait().unwrap();
    let journal = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(status.success(), "{status}: {journal}");
    assert!(streaming.contains("libcaer loaded"), "{streaming}");
    assert!(streaming.contains("camera open: streaming"), "{streaming}");
    assert!(!streaming.contains("SIMULATED CAMERA"), "{streaming}");
}

#[test]
fn writes_held_off_by_flow_control_time_out_close_the_gate_and_recover() {
    let (mock, mut daemon) = start(Controls::default());
    wait_for_roll(&mock, &daemon, "before the ports were held");
    // Both UARTs held off: faithd's writes stop completing. Each times out, the
    // session is reopened, and the gate stays closed while the roll cannot be sent.
    mock.msp.hold_faithds_writes(true);
    mock.hold_faithds_writes(true);
    let held_at = Instant::now();
    assert!(
        daemon.wait_for_log(
            "MSP command port lost: write failed: write not completed within 250 ms",
            Duration::from_secs(2)
        ),
        "{}",
        daemon.log()
    );
    assert!(
        daemon.wait_for_log(
            "autopilot link lost: write failed: write not completed within 250 ms",
            Duration::from_secs(3)
        ),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(500));
    assert!(daemon.is_running(), "{}", daemon.log());
    let log = daemon.log();
    let after_hold = &log[log.find("MSP command port lost").unwrap()..];
    assert!(after_hold.contains("safety gate closed"), "{after_hold}");
    // Let go: the stream starts again at the centre, and the next approach rolls.
    mock.msp.hold_faithds_writes(false);
    mock.hold_faithds_writes(false);
    let released_at = Instant::now();
    assert!(
        mock.msp.wait_for(Duration::from_secs(12), |m| m
            .roll_after(released_at)
            .is_some()),
        "no roll after the ports were let go (held {:?}); journal:\n{}",
        released_at - held_at,
        daemon.log()
    );
    assert!(daemon.stop().success());
}

#[test]
fn telemetry_queued_before_a_reconnect_is_not_taken_as_fresh() {
    let dir = TempDir::new("backlog");
    let link = dir.0.join("ttyFC");
    let mut first = MockAutopilot::start(Arc::new(Controls::default()));
    point_symlink(&link, &first.slave_path);
    let daemon = Daemon::start(&format!("serial:{}", link.display()), &first.command_toml());
    wait_for_roll(&first, &daemon, "before the reconnect");
    // Another port fills with half a second of AUTO, armed telemetry nobody reads,
    // then goes quiet: what a reopened port holds after a glitch.
    let mut second = MockAutopilot::start(Arc::new(Controls::default()));
    std::thread::sleep(Duration::from_millis(500));
    second.go_quiet();
    point_symlink(&link, &second.slave_path);
    first.unplug_mavlink();
    assert!(
        poll_until(Duration::from_secs(5), || daemon
            .log()
            .matches("autopilot link up endpoint")
            .count()
            >= 2),
        "{}",
        daemon.log()
    );
    // The backlog is discarded: nothing arrives, and the gate never opens on it.
    std::thread::sleep(Duration::from_millis(800));
    let log = daemon.log();
    let lost_at = log
        .find("autopilot link lost")
        .unwrap_or_else(|| panic!("{log}"));
    let after = &log[lost_at..];
    assert!(!after.contains("safety gate open"), "{after}");
    assert!(!after.contains("autopilot state"), "{after}");
}

#[test]
fn a_journal_that_stops_reading_never_holds_up_a_roll() {
    // stderr into a pipe nobody reads, with a line per cycle: the pipe fills in
    // seconds. faithd logs through a queue, so the pipeline, the link and the
    // commander go on, and later approaches are still avoided.
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let dir = TempDir::new("stuck-journal");
    let config = dir.0.join("faithd.toml");
    std::fs::write(
        &config,
        format!(
            "[mavlink]\nendpoint = \"serial:{}\"\n{}[source]\nkind = \"sim\"\nfirst_approach_us = 1000000\nrepeat_us = 3000000\n[record]\nenabled = false\n",
            mock.slave_path.display(),
            mock.command_toml()
        ),
    )
    .unwrap();
    let started = Instant::now();
    let mut child = crate::common::faithd()
        .args(["run", "--simulated-camera", "--config"])
        .arg(&config)
        .env("RUST_LOG", "debug")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let late = started + Duration::from_secs(7);
    let rolled_late = mock
        .msp
        .wait_for(Duration::from_secs(15), |m| m.roll_after(late).is_some());
    let _ = nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGKILL,
    );
    let _ = child.wait();
    assert!(
        mock.msp.first_roll().is_some(),
        "no roll at all with the journal unread"
    );
    assert!(rolled_late, "no roll after the journal's pipe filled up");
}

#[test]
fn a_camera_of_another_kind_stops_the_daemon_with_the_keys_to_change() {
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let dir = TempDir::new("caer-size");
    let config = dir.0.join("faithd.toml");
    std::fs::write(
        &config,
        mock.service_toml(&crate::common::caer_mock_library(), "enabled = false"),
    )
    .unwrap();
    let output = crate::common::faithd()
        .args(["run", "--config"])
        .arg(&config)
        .env("RUST_LOG", "info")
        .env("CAER_MOCK_SENSOR", "346x260")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&output.stderr);
    // A configuration error: exit 2, which the unit does not restart.
    assert_eq!(output.status.code(), Some(2), "{text}");
    assert!(text.contains("camera is a DAVIS346 (346x260 px)"), "{text}");
    assert!(text.contains("`source.device`"), "{text}");
    assert!(text.contains("pipeline.camera for its size"), "{text}");
    assert!(text.contains("roll channel"), "{text}");
}

/// iNav's 100 Hz serial task serves one command per port per run: faithd uses at most
/// half of that, one request at a time, the whole flight long (rolls included), and
/// the board's 256-byte receive ring never loses a byte.
#[test]
fn the_msp_port_carries_at_most_half_of_what_inav_serves_over_a_whole_flight() {
    // A reply late by half a second (this machine loaded, the mock's thread not run)
    // would end the session and start a new one with a request of its own: a long
    // timeout keeps this flight one session, whose budget is what is counted.
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let mut daemon = Daemon::start_mock(&mock, "[command]\nmsp_timeout_us = 5000000\n");
    let first = wait_for_roll(&mock, &daemon, "budget");
    // The first roll, the second approach (4 s later) and its roll.
    assert!(
        mock.msp.wait_for(Duration::from_secs(8), |m| m
            .roll_after(first + Duration::from_secs(2))
            .is_some()),
        "no second roll:\n{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(1800));
    assert!(daemon.stop().success());
    let traffic = mock.msp.traffic.lock().unwrap().clone();
    assert_eq!(traffic.bytes_lost, 0, "the receive ring overflowed");
    let arrived: Vec<Instant> = traffic.arrived.iter().map(|(t, _)| *t).collect();
    let served: Vec<Instant> = traffic.served.iter().map(|(t, _)| *t).collect();
    let span = *arrived.last().unwrap() - arrived[0];
    assert!(span > Duration::from_secs(6), "{span:?}");
    // Commands per second at the port, over every one-second window.
    let busiest = arrived
        .iter()
        .map(|t0| {
            arrived
                .iter()
                .filter(|t| **t >= *t0 && **t < *t0 + Duration::from_secs(1))
                .count()
        })
        .max()
        .unwrap();
    // Backlog: requests that reached the port minus those iNav answered.
    let backlog = arrived
        .iter()
        .map(|t| {
            arrived.iter().filter(|a| *a <= t).count() - served.iter().filter(|s| *s <= t).count()
        })
        .max()
        .unwrap();
    let mean_per_s = (arrived.len() - 1) as f64 / span.as_secs_f64();
    eprintln!(
        "measured: {} commands in {span:?} ({mean_per_s:.1} a second), at most {busiest} in any second, backlog at most {backlog}",
        arrived.len()
    );
    assert!(mean_per_s <= 50.0, "{mean_per_s:.2} commands a second");
    // A slot every 20 ms; the time a frame takes on the wire and the thread's
    // scheduling move an arrival by a millisecond or two: 51 in one window at most.
    assert!(busiest <= 51, "{busiest} commands in one second");
    let at = arrived.iter().position(|t| {
        arrived.iter().filter(|a| *a <= t).count() - served.iter().filter(|s| *s <= t).count() > 1
    });
    assert!(
        backlog <= 1,
        "{backlog} requests waiting at the port: {:?}",
        at.map(|i| {
            let t0 = traffic.arrived[i.saturating_sub(3)].0;
            let ms = |t: Instant| (t - t0).as_secs_f64() * 1e3;
            (
                traffic.arrived[i.saturating_sub(3)..(i + 3).min(traffic.arrived.len())]
                    .iter()
                    .map(|(t, c)| (ms(*t), *c))
                    .collect::<Vec<_>>(),
                traffic
                    .served
                    .iter()
                    .filter(|(t, _)| *t >= t0)
                    .take(6)
                    .map(|(t, c)| (ms(*t), *c))
                    .collect::<Vec<_>>(),
            )
        })
    );
    assert_eq!(served.len(), arrived.len(), "every request answered");
}

/// In iNav a roll stick outside ANGLE is a rotation rate: with ANGLE not on the
/// pilot's switch, the gate never opens and iNav never uses a roll.
#[test]
fn without_angle_no_roll_is_ever_applied() {
    use faithd_inav::msp::Setup;
    // ANGLE on channel 7 (AUX3), which the pilot's radio holds low: ACRO.
    let setup = Setup {
        modes: vec![(0, 0, 0, 32, 48), (1, 1, 2, 32, 48), (2, 50, 1, 32, 48)],
        ..Setup::default()
    };
    let mock = MockAutopilot::start_with(Arc::new(Controls::default()), setup);
    let mut daemon = Daemon::start_mock(&mock, "");
    assert!(
        daemon.wait_for_log("decision: roll", Duration::from_secs(8)),
        "the pipeline never wanted to roll:\n{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(1000));
    let log = daemon.log();
    assert!(daemon.stop().success());
    // Refused when read (the switch can be in AUTO without ANGLE); the gate would
    // close on iNav's status too (tested beside the gate).
    assert!(log.contains("set-up refused"), "{log}");
    assert!(log.contains("ANGLE on AUTO"), "{log}");
    assert!(!log.contains("manoeuvre started"), "{log}");
    assert_eq!(mock.first_roll(), None, "iNav used a roll outside ANGLE");
    assert_eq!(
        roll_frames_after(&mock.msp, Instant::now() - Duration::from_secs(60)),
        0
    );
}

/// iNav scales faithd's values by the receiver's calibration: aimed through the range
/// faithd.toml names, they land on the microseconds meant; a range faithd was not
/// told of makes the roll arrive wrong, and the check calls it a fault.
#[test]
fn a_calibrated_asymmetric_receiver_gets_the_roll_meant() {
    use faithd_inav::msp::Setup;
    let setup = Setup {
        rxrange: [(990, 2030), (1000, 2000), (1000, 2000), (1000, 2000)],
        ..Setup::default()
    };
    // Told: iNav uses exactly 1200 or 1800 in the roll, 1500 between.
    let mock = MockAutopilot::start_with(Arc::new(Controls::default()), setup.clone());
    let mut daemon = Daemon::start_mock(&mock, "[command]\nroll_rxrange_us = [990, 2030]\n");
    let rolled = wait_for_roll(&mock, &daemon, "calibrated");
    std::thread::sleep(ROLL + Duration::from_millis(300));
    let log = daemon.log();
    assert!(daemon.stop().success());
    assert!(
        log.contains("roll in effect on the flight controller"),
        "{log}"
    );
    assert!(!log.contains("roll not in effect"), "{log}");
    let used: Vec<u16> = mock
        .msp
        .roll_log
        .lock()
        .unwrap()
        .iter()
        .filter(|(t, _)| *t >= rolled)
        .map(|(_, v)| *v)
        .collect();
    let meant = [1200, CENTRE_US, 1800];
    assert!(
        used.iter().all(|v| meant.contains(v)),
        "iNav used {:?}",
        used.iter()
            .filter(|v| !meant.contains(v))
            .collect::<Vec<_>>()
    );
    // Not told: faithd's 1800 arrives as 1788, its centre as 1490, and the roll is
    // refused as not in effect.
    let mock = MockAutopilot::start_with(Arc::new(Controls::default()), setup);
    let mut daemon = Daemon::start_mock(&mock, "");
    assert!(
        daemon.wait_for_log("roll not in effect", Duration::from_secs(10)),
        "{}",
        daemon.log()
    );
    assert!(daemon.stop().success());
    // What iNav used: the centre shifted, and never the roll meant.
    let used: std::collections::BTreeSet<u16> = mock
        .msp
        .roll_log
        .lock()
        .unwrap()
        .iter()
        .map(|(_, v)| *v)
        .collect();
    assert!(used.contains(&1490), "iNav used {used:?}");
    assert!(
        !used.contains(&1200) && !used.contains(&1800),
        "iNav used {used:?}"
    );
}

/// iNav reads msp_override_channels on every frame: a configurator on another port
/// that adds throttle would put faithd's centre on it. faithd notices within its
/// traffic budget, stops streaming and closes the gate, naming what changed.
#[test]
fn a_set_up_changed_in_flight_stops_the_stream_and_closes_the_gate() {
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let mut mock = mock;
    let mut daemon = Daemon::start_mock(&mock, "");
    assert!(
        daemon.wait_for_log("MSP roll stream started", Duration::from_secs(5)),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(500));
    mock.msp.change_setup(|s| s.msp_override_channels = 0b1001);
    let changed = Instant::now();
    assert!(
        daemon.wait_for_log(
            "set-up changed in flight (msp_override_channels is now 9, was 1)",
            Duration::from_secs(3)
        ),
        "{}",
        daemon.log()
    );
    let noticed = Instant::now();
    std::thread::sleep(Duration::from_millis(1500));
    let log = daemon.log();
    assert!(daemon.stop().success());
    eprintln!(
        "measured: set-up change noticed within {:?}",
        noticed - changed
    );
    // Refused when read again, with the fix.
    assert!(log.contains("set msp_override_channels = 1"), "{log}");
    // No frame after the change was noticed (give the one in flight a slot).
    let late = mock
        .msp
        .frames
        .lock()
        .unwrap()
        .iter()
        .filter(|(t, _)| *t > noticed + SLOT)
        .count();
    assert_eq!(late, 0, "faithd kept streaming on a changed set-up:\n{log}");
}

/// SYS_STATUS that stops must not leave its last "healthy" standing.
#[test]
fn a_radio_status_that_stops_closes_the_gate() {
    let (mock, mut daemon) = start(Controls::default());
    wait_for_roll(&mock, &daemon, "radio status");
    mock.controls
        .send_sys_status
        .store(false, Ordering::Relaxed);
    let at = Instant::now();
    assert!(
        daemon.wait_for_log("SYS_STATUS stale", Duration::from_secs(2)),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(500));
    let (centre, used) = released_after(&mock.msp, at).expect("released");
    assert_eq!(used, CENTRE_US, "AUTO holds the centre");
    assert!(centre - at <= Duration::from_millis(300) + TO_INAV + SLACK);
    assert!(!rolled_after(&mock.msp, centre));
    assert!(daemon.stop().success());
}
