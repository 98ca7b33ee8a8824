//! faithd against iNav's own firmware: iNav's SITL build (9.1, and 10.x built from
//! `maintenance-10.x`), set up from the committed CLI scripts (tests/inav/pilot.cli,
//! then hil/inav/faithd.cli, or hil/inav/faithd-msp.cli in [`msp_only`]), the
//! pilot's radio on a real IBUS receiver, the real `faithd run` binary on SITL's
//! MAVLink and MSP ports. Every assertion is on what iNav itself uses, read back over
//! MSP (MSP_RC, MSP2_INAV_STATUS) on a port of its own, never on what faithd sent.
//!
//! `cargo test --release --test testsuite inav_sitl:: -- --nocapture` prints the measured
//! figures (application delay, in-effect share, release delay) docs/inav.md quotes.

mod msp_only;
mod osd;

use crate::common;
use crate::require_sitl;

use std::time::Duration;

use common::daemon::Daemon;
use common::sitl::*;

/// faithd's defaults (config/faithd.toml).
const NEUTRAL_US: u16 = 1500;
const ROLL_MS: i64 = 1500;
/// The bounds: the roll in effect within 100 ms of the decision, for at
/// least 95 % of its 1.5 s; the pilot's control back within 100 ms.
const APPLY_BOUND_US: i64 = 100_000;
const IN_EFFECT_MIN: f64 = 0.95;
const RELEASE_BOUND_US: i64 = 100_000;

/// How faithd reads iNav on the bench.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Link {
    /// iNav's MAVLink telemetry on UART3 (hil/inav/faithd.cli).
    Mavlink,
    /// A second MSP port on UART3 (hil/inav/faithd-msp.cli): no MAVLink at all.
    Msp,
}

/// A vehicle on the bench: SITL with the committed set-up plus `extra` CLI lines,
/// the pilot's radio, the monitor, armed in ANGLE, the pilot's roll stick slightly
/// left of centre.
struct Bench {
    sitl: Sitl,
    radio: Radio,
    monitor: Monitor,
    link: Link,
}

impl Bench {
    fn new(extra: &[&str]) -> Self {
        Self::with(Link::Mavlink, &[], extra)
    }

    /// With `link` and, after faithd's script for it, the `more` scripts.
    fn with(link: Link, more: &[&str], extra: &[&str]) -> Self {
        let mut scripts = vec![match link {
            Link::Mavlink => FAITHD_CLI,
            Link::Msp => FAITHD_MSP_CLI,
        }];
        scripts.extend_from_slice(more);
        // iNav allows three MSP ports (msp/msp_serial.h MAX_MSP_PORT_COUNT; a save
        // with more resets every port, io/serial.c isSerialConfigValid). SITL's
        // UART1 and UART2 are both MSP: with faithd's two, the monitor moves to UART1,
        // as a board's USB port is the third.
        let monitor_uart = match link {
            Link::Mavlink => UART_MONITOR,
            Link::Msp => UART_CLI,
        };
        let mut lines: Vec<&str> = Vec::new();
        if link == Link::Msp {
            lines.push("serial 1 0 115200 115200 115200 115200");
        }
        lines.extend_from_slice(extra);
        let sitl = Sitl::with_scripts(&scripts, &lines);
        let radio = Radio::start(&sitl);
        let monitor = Monitor::start_on(&sitl, monitor_uart);
        arm(&radio, &monitor, &sitl);
        radio.set(CH_ROLL, PILOT_ROLL_US);
        Bench {
            sitl,
            radio,
            monitor,
            link,
        }
    }

    /// faithd.toml's lines for the autopilot's telemetry on `endpoint` (UART3, or a
    /// tap on it).
    fn telemetry_toml(&self, endpoint: &str) -> String {
        match self.link {
            Link::Mavlink => format!(
                "[mavlink]\nendpoint = \"{endpoint}\"\nreconnect_min_us = 50000\nreconnect_max_us = 200000\n"
            ),
            Link::Msp => format!(
                "[telemetry]\nkind = \"msp\"\nendpoint = \"{endpoint}\"\n[mavlink]\nreconnect_min_us = 50000\nreconnect_max_us = 200000\n"
            ),
        }
    }

    /// `faithd run` on this SITL: the telemetry on UART3, the MSP stream on UART4,
    /// the simulated camera's first approach at `first_approach_us`.
    fn faithd(&self, first_approach_us: i64, extra: &str) -> Daemon {
        self.faithd_on(
            &self.sitl.endpoint(UART_MAVLINK),
            &self.sitl.endpoint(UART_MSP_FAITHD),
            first_approach_us,
            extra,
        )
    }

    /// As [`Bench::faithd`], on the endpoints given (taps on the UARTs).
    fn faithd_on(
        &self,
        telemetry: &str,
        command: &str,
        first_approach_us: i64,
        extra: &str,
    ) -> Daemon {
        Daemon::start_config(
            &format!(
                "{}[command.sink]\nkind = \"msp\"\nendpoint = \"{command}\"\n\
                 [source]\nkind = \"sim\"\nfirst_approach_us = {first_approach_us}\nrepeat_us = 4000000\n\
                 [record]\nenabled = false\n{extra}",
                self.telemetry_toml(telemetry),
            ),
            &[],
        )
    }
}

/// The pilot's radio channels in iNav's order (roll, pitch, yaw, throttle, AUX...)
/// under the default AETR map.
fn inav_order(radio: &[u16; PILOT_CHANNELS]) -> Vec<u16> {
    let mut v = vec![radio[0], radio[1], radio[3], radio[2]];
    v.extend_from_slice(&radio[4..]);
    v
}

/// A manoeuvre as faithd's journal tells it: Unix times and the commanded value.
#[derive(Clone, Copy, Debug)]
struct Manoeuvre {
    start_us: i64,
    end_us: Option<i64>,
    roll_us: u16,
}

fn field(line: &str, key: &str) -> Option<i64> {
    let at = line.find(&format!("{key}="))? + key.len() + 1;
    line[at..]
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

fn manoeuvres(log: &str) -> Vec<Manoeuvre> {
    let mut out: Vec<Manoeuvre> = Vec::new();
    for line in log.lines() {
        if line.contains("manoeuvre started") {
            out.push(Manoeuvre {
                start_us: field(line, "unix_us").expect("unix_us"),
                end_us: None,
                roll_us: field(line, "roll_us").expect("roll_us") as u16,
            });
        } else if (line.contains("manoeuvre completed") || line.contains("manoeuvre cut"))
            && let Some(m) = out.last_mut()
        {
            m.end_us = field(line, "unix_us");
        }
    }
    out
}

/// What iNav did with one manoeuvre.
#[derive(Debug)]
struct RouteFigures {
    /// From the decision (manoeuvre start) to the first sample using the roll.
    apply_us: i64,
    /// Share of the samples over the 1.5 s that use the roll.
    in_effect: f64,
    /// From the end of the manoeuvre to the first sample back at the centre.
    release_us: i64,
}

fn figures(monitor: &Monitor, m: &Manoeuvre) -> RouteFigures {
    let end = m.start_us + ROLL_MS * 1000;
    let during = monitor.between(m.start_us, end);
    // The monitor shares iNav's 100 Hz serial task on its own port: a sample (MSP_RC
    // and MSP2_INAV_STATUS) every 20 ms on a board's timing.
    assert!(
        during.len() >= 60,
        "only {} samples over the roll",
        during.len()
    );
    let first = during
        .iter()
        .find(|s| s.roll() == m.roll_us)
        .unwrap_or_else(|| panic!("iNav never used the roll {}: {:?}", m.roll_us, m));
    let in_effect =
        during.iter().filter(|s| s.roll() == m.roll_us).count() as f64 / during.len() as f64;
    let release_from = m.end_us.expect("manoeuvre ended");
    let after = monitor.between(release_from, release_from + 500_000);
    let back = after
        .iter()
        .find(|s| s.roll() == NEUTRAL_US)
        .expect("released to the centre");
    RouteFigures {
        apply_us: first.t_us - m.start_us,
        in_effect,
        release_us: back.t_us - release_from,
    }
}

/// Every sample: the channels other than roll are exactly the pilot's.
fn assert_only_roll_changed(monitor: &Monitor, radio: &Radio, from_us: i64, to_us: i64) {
    let sent = radio.sent.lock().unwrap().clone();
    for s in monitor.between(from_us, to_us) {
        // What the pilot sent from 50 ms before the sample (iNav's receiver latency)
        // to 30 ms after it (the sample is stamped when MSP_RC is asked, iNav answers
        // on its next MSP turn), or the last thing sent before that.
        let recent = sent
            .iter()
            .filter(|(t, _)| *t >= s.t_us - 50_000 && *t <= s.t_us + 30_000);
        let before = sent.iter().rfind(|(t, _)| *t < s.t_us - 50_000);
        let candidates: Vec<Vec<u16>> =
            recent.chain(before).map(|(_, ch)| inav_order(ch)).collect();
        assert!(
            candidates
                .iter()
                .any(|p| p[1..] == s.rc[1..p.len().min(s.rc.len())]),
            "a channel other than roll differs from the pilot's at {}: iNav {:?}, pilot {:?}",
            s.t_us,
            s.rc,
            candidates
        );
    }
}

#[test]
fn the_roll_route_works_beside_the_pilots_radio() {
    require_sitl!();
    route_beside_the_pilots_radio(&Bench::new(&[]));
}

/// Two rolls in AUTO, none in MANUAL: each in effect, held and given back in time,
/// nothing but roll ever changed, armed and in ANGLE throughout.
fn route_beside_the_pilots_radio(bench: &Bench) {
    bench.radio.set(CH_SWITCH, AUTO_US);
    let started_us = unix_us();
    let mut daemon = bench.faithd(1_000_000, "");
    // Two approaches in AUTO (at 1 s and 5 s of the daemon clock): two rolls.
    let two_rolls = (0..100).any(|_| {
        std::thread::sleep(Duration::from_millis(100));
        manoeuvres(&daemon.log())
            .iter()
            .filter(|m| m.end_us.is_some())
            .count()
            >= 2
    });
    assert!(
        two_rolls,
        "no two rolls in AUTO; journal:\n{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(300));
    // Then MANUAL; the third approach (9 s) makes the pipeline want to roll again.
    let manual_us = bench.radio.set(CH_SWITCH, MANUAL_US);
    assert!(
        daemon.wait_for_log("pilot switch not in AUTO", Duration::from_secs(2)),
        "{}",
        daemon.log()
    );
    let mark = daemon.log().len();
    let wanted = (0..60).any(|_| {
        std::thread::sleep(Duration::from_millis(100));
        daemon.log()[mark..].contains("decision: roll")
    });
    std::thread::sleep(Duration::from_millis(1700));
    let end_us = unix_us();
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    assert!(wanted, "the pipeline did not want a third roll:\n{log}");

    let rolls = manoeuvres(&log);
    assert_eq!(
        rolls.len(),
        2,
        "exactly the two rolls in AUTO, none in MANUAL:\n{log}"
    );
    for m in &rolls {
        let f = figures(&bench.monitor, m);
        eprintln!(
            "measured (roll {} us): in effect {:.1} ms after the decision, for {:.1} % of the 1.5 s; centre back {:.1} ms after the end",
            m.roll_us,
            f.apply_us as f64 / 1000.0,
            f.in_effect * 100.0,
            f.release_us as f64 / 1000.0
        );
        assert!(f.apply_us <= APPLY_BOUND_US, "{f:?}");
        assert!(f.in_effect >= IN_EFFECT_MIN, "{f:?}");
        assert!(f.release_us <= RELEASE_BOUND_US, "{f:?}");
    }

    // In AUTO between and after the rolls, iNav holds roll at faithd's centre (the
    // design: AUTO gives roll to faithd); it is the pilot's again in MANUAL.
    let warm = bench
        .monitor
        .between(started_us, rolls[0].start_us)
        .iter()
        .find(|s| s.roll() == NEUTRAL_US)
        .map(|s| s.t_us)
        .expect("the stream took roll to the centre before the first roll");
    let between = bench.monitor.between(
        rolls[0].end_us.unwrap() + RELEASE_BOUND_US,
        rolls[1].start_us,
    );
    assert!(
        between.iter().all(|s| s.roll() == NEUTRAL_US),
        "between rolls in AUTO iNav used {:?}",
        between.iter().map(|s| s.roll()).collect::<Vec<_>>()
    );
    let manual = bench.monitor.between(manual_us, end_us);
    let back = manual
        .iter()
        .find(|s| s.roll() == PILOT_ROLL_US)
        .expect("the pilot's roll back in MANUAL");
    eprintln!(
        "measured: pilot's roll back {:.1} ms after the radio sent MANUAL; stream warm {:.0} ms after faithd started",
        (back.t_us - manual_us) as f64 / 1000.0,
        (warm - started_us) as f64 / 1000.0
    );
    assert!(back.t_us - manual_us <= RELEASE_BOUND_US);
    assert!(
        manual
            .iter()
            .filter(|s| s.t_us >= back.t_us)
            .all(|s| s.roll() == PILOT_ROLL_US && !s.mode(MODE_MSP_RC_OVERRIDE)),
        "faithd's value used in MANUAL"
    );
    // Nothing but roll, ever; armed and in ANGLE throughout.
    assert_only_roll_changed(&bench.monitor, &bench.radio, started_us, end_us);
    assert!(
        bench
            .monitor
            .between(started_us, end_us)
            .iter()
            .all(|s| s.armed() && s.mode(MODE_ANGLE))
    );
}

/// The journal's first line containing `needle`, with its `unix_us`.
fn journal_time(log: &str, needle: &str) -> Option<i64> {
    log.lines()
        .find(|l| l.contains(needle))
        .and_then(|l| field(l, "unix_us"))
}

#[test]
fn every_stop_and_a_restart_after_a_kill_give_roll_back() {
    require_sitl!();
    stops_and_a_kill_give_roll_back(&Bench::new(&[]));
}

/// SIGTERM, SIGINT and SIGHUP mid-roll release at once; after a SIGKILL iNav holds the
/// roll no longer than its own override's timeout, or until the restarted faithd.
fn stops_and_a_kill_give_roll_back(bench: &Bench) {
    use nix::sys::signal::Signal;
    bench.radio.set(CH_SWITCH, AUTO_US);
    for signal in [Signal::SIGTERM, Signal::SIGINT, Signal::SIGHUP] {
        let mut daemon = bench.faithd(1_000_000, "");
        assert!(
            daemon.wait_for_log("manoeuvre started", Duration::from_secs(8)),
            "{signal}: {}",
            daemon.log()
        );
        std::thread::sleep(Duration::from_millis(300));
        let at = unix_us();
        let expected = if signal == Signal::SIGHUP { 1 } else { 0 };
        assert_eq!(daemon.signal(signal).code(), Some(expected), "{signal}");
        let log = daemon.log();
        assert!(log.contains("3 centre frames written"), "{signal}: {log}");
        std::thread::sleep(Duration::from_millis(1500));
        let after = bench.monitor.between(at, unix_us());
        let centre = after
            .iter()
            .find(|s| s.roll() == NEUTRAL_US)
            .unwrap_or_else(|| panic!("{signal}: iNav kept the roll"));
        // Then iNav's own MSP override times out (200 ms + failsafe_delay 0.5 s after
        // the last frame) and roll is the pilot's stick again, even in AUTO.
        let pilot = after
            .iter()
            .find(|s| s.roll() == PILOT_ROLL_US)
            .unwrap_or_else(|| panic!("{signal}: the pilot's roll never came back"));
        eprintln!(
            "measured ({signal} mid-roll): centre in use {:.1} ms after the signal, the pilot's stick {:.0} ms after",
            (centre.t_us - at) as f64 / 1000.0,
            (pilot.t_us - at) as f64 / 1000.0
        );
        assert!(centre.t_us - at <= RELEASE_BOUND_US, "{signal}");
        assert!(
            after
                .iter()
                .filter(|s| s.t_us >= centre.t_us)
                .all(|s| s.roll() == NEUTRAL_US || s.roll() == PILOT_ROLL_US),
            "{signal}: a roll after the release"
        );
        // The next daemon must wait for iNav's override to recover from the gap.
        std::thread::sleep(Duration::from_millis(200));
    }

    // SIGKILL mid-roll (OOM, watchdog, crash): nothing released. iNav holds the roll
    // until its override times out (0.4 s + failsafe_delay), or until the faithd that
    // systemd restarts (after the unit's RestartSec) puts the centre back.
    let mut daemon = bench.faithd(1_000_000, "");
    assert!(daemon.wait_for_log("manoeuvre started", Duration::from_secs(8)));
    let started = journal_time(&daemon.log(), "manoeuvre started").unwrap();
    std::thread::sleep(Duration::from_millis(300));
    daemon.signal(Signal::SIGKILL);
    let killed = unix_us();
    let restart = common::unit_restart_delay();
    std::thread::sleep(restart);
    let restarted = bench.faithd(60_000_000, "");
    std::thread::sleep(Duration::from_millis(1500));
    let after = bench.monitor.between(killed, unix_us());
    let rolled = after
        .iter()
        .take_while(|s| s.roll() == 1200 || s.roll() == 1800)
        .last()
        .map_or(0, |s| s.t_us - killed);
    let centre = after
        .iter()
        .find(|s| s.roll() == NEUTRAL_US)
        .unwrap_or_else(|| panic!("the restarted faithd did not release:\n{}", restarted.log()));
    eprintln!(
        "measured (SIGKILL {:.0} ms into a roll, restarted after RestartSec = {} ms): roll held {:.0} ms after the kill, centre in use {:.1} ms after it",
        (killed - started) as f64 / 1000.0,
        restart.as_millis(),
        rolled as f64 / 1000.0,
        (centre.t_us - killed) as f64 / 1000.0
    );
    assert!(
        after
            .iter()
            .filter(|s| s.t_us > centre.t_us)
            .all(|s| s.roll() == NEUTRAL_US),
        "the restarted faithd holds the centre in AUTO"
    );
    // Never longer than iNav's own hold of a dead stream (0.9 s with the defaults).
    assert!(
        rolled < 900_000 + 50_000,
        "roll held {rolled} us after the kill"
    );
}

#[test]
fn radio_loss_and_inavs_failsafe_close_the_gate() {
    require_sitl!();
    let log = radio_lost_mid_flight(&Bench::new(&[]));
    // SYS_STATUS says the radio is gone within a report or two (120 ms), long
    // before iNav's failsafe starts; then iNav's status reports the failsafe too.
    assert!(log.contains("failsafe=true"), "{log}");
}

/// The pilot's radio stops in AUTO before an approach: the gate closes on the lost
/// radio, nothing is commanded, and iNav uses no roll during its failsafe. The
/// journal, for what each link adds.
fn radio_lost_mid_flight(bench: &Bench) -> String {
    bench.radio.set(CH_SWITCH, AUTO_US);
    // The first approach long after the radio is gone.
    let mut daemon = bench.faithd(5_000_000, "");
    assert!(
        daemon.wait_for_log("safety gate open", Duration::from_secs(5)),
        "{}",
        daemon.log()
    );
    let lost = unix_us();
    bench.radio.transmit(false);
    let failsafe = bench
        .monitor
        .wait_until(Duration::from_secs(3), |s| s.mode(MODE_FAILSAFE))
        .expect("iNav entered failsafe");
    std::thread::sleep(Duration::from_secs(6));
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    eprintln!(
        "measured ({:?} link): iNav in FAILSAFE {:.0} ms after the radio stopped",
        bench.link,
        (failsafe.t_us - lost) as f64 / 1000.0
    );
    assert!(
        log.contains("safety gate closed: the autopilot reports the pilot's radio lost"),
        "{log}"
    );
    // The pipeline wanted to roll at the approach, but nothing was commanded.
    assert!(log.contains("decision: roll"), "{log}");
    assert!(!log.contains("manoeuvre started"), "{log}");
    let during = bench.monitor.between(failsafe.t_us, unix_us());
    assert!(
        during.iter().all(|s| s.roll() != 1200 && s.roll() != 1800),
        "a roll in use during the failsafe"
    );
    log
}

#[test]
fn an_msp_receiver_is_refused_and_never_streamed_to() {
    require_sitl!();
    // receiver_type = MSP: iNav would take faithd's frame as the pilot's whole frame.
    let sitl = Sitl::with_committed_setup(&["set receiver_type = MSP"]);
    let monitor = Monitor::start(&sitl);
    std::thread::sleep(Duration::from_millis(300));
    let before = monitor.latest().expect("a sample").rc;
    let bench_faithd = Daemon::start_config(
        &format!(
            "[mavlink]\nendpoint = \"{}\"\n[command.sink]\nkind = \"msp\"\nendpoint = \"{}\"\n\
             [source]\nkind = \"sim\"\n[record]\nenabled = false\n",
            sitl.endpoint(UART_MAVLINK),
            sitl.endpoint(UART_MSP_FAITHD)
        ),
        &[],
    );
    let from = unix_us();
    assert!(
        bench_faithd.wait_for_log("set-up refused", Duration::from_secs(5)),
        "{}",
        bench_faithd.log()
    );
    std::thread::sleep(Duration::from_secs(2));
    let log = bench_faithd.log();
    assert!(log.contains("set receiver_type = SERIAL"), "{log}");
    assert!(!log.contains("MSP roll stream started"), "{log}");
    for s in monitor.between(from, unix_us()) {
        assert_eq!(s.rc, before, "iNav's channels changed under faithd");
    }
}

/// `faithd check-fc` against this SITL; (exit code, stdout). Exit 1 (the flight
/// controller could not be read: SITL still settling after a save) is retried.
fn check_fc(sitl: &Sitl) -> (i32, String) {
    check_fc_with(sitl, "")
}

/// As [`check_fc`], with `extra` TOML in faithd.toml.
fn check_fc_with(sitl: &Sitl, extra: &str) -> (i32, String) {
    let dir = common::TempDir::new("check-fc");
    let config = dir.0.join("faithd.toml");
    std::fs::write(
        &config,
        format!(
            "[command.sink]\nkind = \"msp\"\nendpoint = \"{}\"\n{extra}",
            sitl.endpoint(UART_MSP_FAITHD)
        ),
    )
    .unwrap();
    let mut tries = Vec::new();
    for _ in 0..5 {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_faithd"))
            .args(["check-fc", "--config"])
            .arg(&config)
            .output()
            .unwrap();
        let code = out.status.code().unwrap_or(-1);
        if code != 1 {
            return (code, String::from_utf8_lossy(&out.stdout).into_owned());
        }
        tries.push(String::from_utf8_lossy(&out.stderr).into_owned());
        std::thread::sleep(Duration::from_millis(500));
    }
    panic!("check-fc could not read SITL: {tries:?}\n{}", sitl.log());
}

#[test]
fn check_fc_refuses_each_known_bad_wiring_and_its_fix_works() {
    require_sitl!();
    let sitl = Sitl::with_committed_setup(&[]);
    let (code, out) = check_fc(&sitl);
    assert_eq!(code, 0, "the committed set-up passes:\n{out}");
    // (what breaks it, the check that must fail, the CLI fix it must name)
    let cases = [
        (
            "set receiver_type = MSP",
            "pilot's receiver",
            "set receiver_type = SERIAL",
        ),
        (
            "set msp_override_channels = 15",
            "override channels",
            "set msp_override_channels = 1",
        ),
        ("aux 2 0 0 900 900", "override mode", "aux 2 50 1 1700 2100"),
        (
            "aux 2 50 1 1300 2100",
            "override mode",
            "aux 2 50 1 1700 2100",
        ),
        // ANGLE moved off the vehicle's ARM switch: AUTO without ANGLE.
        ("aux 1 1 2 1700 2100", "ANGLE on AUTO", " 1 1 1700 2100"),
        ("aux 0 0 1 1700 2100", "arm switch", "aux 0 0"),
        // iNav would hold faithd's last roll 1.4 s after a crash.
        (
            "set failsafe_delay = 10",
            "failsafe delays",
            "set failsafe_delay = 5",
        ),
        (
            "set mavlink_extra1_rate = 10",
            "ATTITUDE rate",
            "set mavlink_extra1_rate = 50",
        ),
        (
            "set mavlink_rc_chan_rate = 3",
            "RC_CHANNELS rate",
            "set mavlink_rc_chan_rate = 50",
        ),
        (
            "set mavlink_version = 1",
            "MAVLink version",
            "set mavlink_version = 2",
        ),
    ];
    for (breaks, what, fix) in cases {
        sitl.cli_save(&[breaks.to_string()]);
        let (code, out) = check_fc(&sitl);
        assert_eq!(code, 2, "{breaks}: refused\n{out}");
        let line = out
            .lines()
            .position(|l| l.starts_with("FAIL") && l.contains(what))
            .unwrap_or_else(|| panic!("{breaks}: no FAIL for {what}:\n{out}"));
        let fix_line = out.lines().nth(line + 1).unwrap_or("");
        assert!(
            fix_line.contains(fix),
            "{breaks}: fix {fix_line:?} lacks {fix}"
        );
        // The fixes as printed, pasted into iNav's CLI, make the check pass again (a
        // fix can bring the next problem to light: ARM moved off the switch that also
        // holds ANGLE needs ANGLE on AUTO too; each is printed in turn).
        let mut out = out;
        let mut pasted_all = Vec::new();
        for _ in 0..3 {
            let pasted = cli_fixes(&out);
            assert!(
                !pasted.is_empty(),
                "{breaks}: a refusal without a CLI fix:\n{out}"
            );
            sitl.cli_save(&pasted);
            pasted_all.extend(pasted);
            let (code, again) = check_fc(&sitl);
            out = again;
            if code == 0 {
                break;
            }
        }
        assert!(
            out.contains("ok for faithd's roll route"),
            "{breaks}: after {pasted_all:?}:\n{out}"
        );
    }

    // A calibrated receiver: iNav scales faithd's roll by it. check-fc reads it in
    // iNav's CLI and names the faithd.toml line that aims through it.
    sitl.cli_save(&["rxrange 0 988 2012".to_string()]);
    let (code, out) = check_fc(&sitl);
    assert_eq!(code, 2, "{out}");
    assert!(out.contains("rxrange 0 988 2012"), "{out}");
    assert!(
        out.contains("fix in faithd.toml: [command] roll_rxrange_us = [988, 2012]"),
        "{out}"
    );
    let (code, out) = check_fc_with(&sitl, "[command]\nroll_rxrange_us = [988, 2012]\n");
    assert_eq!(code, 0, "{out}");
}

/// The iNav CLI lines of every fix `faithd check-fc` printed (a parenthesis is advice
/// for the reader, the rest is CLI lines).
fn cli_fixes(out: &str) -> Vec<String> {
    out.lines()
        .filter_map(|l| l.split_once("fix (iNav CLI): "))
        .flat_map(|(_, f)| {
            f.split(" (")
                .next()
                .unwrap()
                .split(", then ")
                .map(|l| l.replace("<other aux channel>", "2"))
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn the_bench_script_measures_rates_switch_and_a_roll_on_inav() {
    require_sitl!();
    if !common::peers::python_module(
        "pymavlink",
        "the_bench_script_measures_rates_switch_and_a_roll_on_inav",
    ) {
        return;
    }
    let bench = Bench::new(&[]);
    let dir = common::TempDir::new("hil");
    let report = dir.0.join("report.json");
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/hil/bench_check.py");
    let mut child = std::process::Command::new("python3")
        .arg(script)
        .arg("--device")
        .arg(format!("tcp:127.0.0.1:{}", bench.sitl.port(UART_MAVLINK)))
        .arg("--msp-device")
        .arg(bench.sitl.endpoint(UART_MSP_FAITHD))
        .arg("--non-interactive")
        .arg("--report")
        .arg(&report)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python3 runs the bench script");
    // The pilot: MANUAL for the rate check and the first switch reading, then AUTO.
    // The script reads MANUAL right after it prints its rates, which come after iNav's
    // first HEARTBEAT and five seconds of counting: a fixed wait fails on a slow start.
    let lines = std::io::BufRead::lines(std::io::BufReader::new(child.stdout.take().unwrap()));
    let (tx, rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in lines.map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut stdout = String::new();
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    while let Ok(line) =
        rx.recv_timeout(deadline.saturating_duration_since(std::time::Instant::now()))
    {
        stdout.push_str(&line);
        stdout.push('\n');
        if line.starts_with("rates (Hz):") {
            break;
        }
    }
    std::thread::sleep(Duration::from_secs(1));
    bench.radio.set(CH_SWITCH, AUTO_US);
    let out = child.wait_with_output().unwrap();
    reader.join().unwrap();
    stdout.extend(rx.try_iter().map(|l| l + "\n"));
    assert!(
        out.status.success(),
        "bench script failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    eprintln!("bench report on SITL: {r}");
    assert_eq!(r["heartbeat"], true);
    // iNav's fastest stream: a message every 40 ms (24.6 Hz measured).
    for stream in ["ATTITUDE", "RC_CHANNELS"] {
        let hz = r["rates_hz"][stream].as_f64().unwrap();
        assert!((22.0..=26.0).contains(&hz), "{stream} at {hz} Hz");
    }
    assert_eq!(r["manual_value_us"], MANUAL_US);
    assert_eq!(r["auto_value_us"], AUTO_US);
    let roll = &r["test_roll"];
    assert_eq!(roll["echo_seen"], true, "{roll}");
    // RC_CHANNELS arrives every 40 ms: the echo comes within a period or two.
    assert!(roll["echo_delay_ms"].as_f64().unwrap() < 100.0, "{roll}");
    let held = roll["echo_held_s"].as_f64().unwrap();
    assert!((1.4..=1.6).contains(&held), "echo held {held} s");
    assert!(
        roll["centred_after_release_ms"].as_f64().unwrap() < 100.0,
        "{roll}"
    );
}

/// ANGLE moved off the AUTO switch (the pilot flies ACRO): a roll stick would be a
/// rotation rate. faithd refuses the set-up and iNav never uses a roll of faithd's.
#[test]
fn without_angle_on_the_auto_switch_no_roll_is_ever_applied() {
    require_sitl!();
    // ANGLE on AUX3 (channel 7), which the pilot's radio holds low.
    let bench = Bench::new(&["aux 1 1 2 1700 2100"]);
    bench.radio.set(CH_SWITCH, AUTO_US);
    let from = unix_us();
    let mut daemon = bench.faithd(1_000_000, "");
    assert!(
        daemon.wait_for_log("decision: roll", Duration::from_secs(8)),
        "the pipeline never wanted to roll:\n{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_secs(1));
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    assert!(log.contains("set-up refused"), "{log}");
    assert!(log.contains("ANGLE on AUTO"), "{log}");
    assert!(!log.contains("MSP roll stream started"), "{log}");
    let samples = bench.monitor.between(from, unix_us());
    assert!(samples.iter().all(|s| !s.mode(MODE_ANGLE)), "ANGLE was on");
    assert!(
        samples.iter().all(|s| s.roll() == PILOT_ROLL_US),
        "iNav used something other than the pilot's roll"
    );
}

/// A calibrated receiver (`rxrange 0 990 2030`: iNav's centre is no longer 1500 on
/// the wire): faithd aims through the range faithd.toml names, and iNav uses exactly
/// the roll and the centre faithd means.
#[test]
fn a_calibrated_receiver_gets_the_roll_meant() {
    require_sitl!();
    let bench = Bench::new(&["rxrange 0 990 2030"]);
    bench.radio.set(CH_SWITCH, AUTO_US);
    let mut daemon = bench.faithd(1_000_000, "[command]\nroll_rxrange_us = [990, 2030]\n");
    assert!(
        daemon.wait_for_log("manoeuvre completed", Duration::from_secs(8)),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(300));
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    assert!(
        log.contains("roll in effect on the flight controller"),
        "{log}"
    );
    assert!(!log.contains("roll not in effect"), "{log}");
    let m = &manoeuvres(&log)[0];
    let f = figures(&bench.monitor, m);
    eprintln!(
        "measured (rxrange 0 990 2030, roll {} us): in effect {:.1} ms after the decision, for {:.1} % of the 1.5 s; centre back {:.1} ms after the end",
        m.roll_us,
        f.apply_us as f64 / 1000.0,
        f.in_effect * 100.0,
        f.release_us as f64 / 1000.0
    );
    assert!(f.apply_us <= APPLY_BOUND_US, "{f:?}");
    assert!(f.in_effect >= IN_EFFECT_MIN, "{f:?}");
}

/// A configurator on another MSP port adds throttle to msp_override_channels in
/// flight while the pilot raises the throttle: iNav takes faithd's frame on throttle at
/// once, and that frame carries the pilot's throttle as iNav used it a report before,
/// never faithd's centre. faithd reads the set-up again within its traffic budget,
/// stops streaming and names the change; iNav's override then times out and the
/// pilot's live throttle is back.
#[test]
fn a_set_up_changed_in_flight_is_noticed_and_the_stream_stops() {
    require_sitl!();
    let bench = Bench::new(&[]);
    bench.radio.set(CH_SWITCH, AUTO_US);
    let mut daemon = bench.faithd(60_000_000, "");
    assert!(
        daemon.wait_for_log("safety gate open", Duration::from_secs(5)),
        "{}",
        daemon.log()
    );
    let pilot_before = bench.monitor.latest().expect("a sample").rc[3];
    let pilot_after = pilot_before + 200;
    // MSP2_COMMON_SET_SETTING on the CLI's port: msp_override_channels = 9.
    const MSP2_COMMON_SET_SETTING: u16 = 0x1004;
    let mut configurator = MspClient::connect(bench.sitl.port(UART_CLI)).expect("UART1");
    let mut payload = b"msp_override_channels\0".to_vec();
    payload.extend_from_slice(&9u32.to_le_bytes());
    configurator
        .request(MSP2_COMMON_SET_SETTING, &payload)
        .expect("iNav takes the setting");
    let changed = unix_us();
    bench.radio.set(CH_THROTTLE, pilot_after);
    assert!(
        daemon.wait_for_log(
            "set-up changed in flight (msp_override_channels is now 9, was 1)",
            Duration::from_secs(3)
        ),
        "{}",
        daemon.log()
    );
    // The journal line is read within a few milliseconds of being written.
    let noticed = unix_us();
    std::thread::sleep(Duration::from_millis(2000));
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    assert!(log.contains("set msp_override_channels = 1"), "{log}");
    // What iNav used on throttle: the pilot's earlier throttle from faithd's frame
    // until the stream stopped and iNav's override timed out, then the pilot's live
    // one. Never faithd's centre.
    let after = bench.monitor.between(changed, unix_us());
    assert!(
        after
            .iter()
            .all(|s| s.rc[3] == pilot_before || s.rc[3] == pilot_after),
        "throttle other than the pilot's: {:?}",
        after
            .iter()
            .map(|s| s.rc[3])
            .collect::<std::collections::BTreeSet<_>>()
    );
    let back = after
        .iter()
        .find(|s| s.rc[3] == pilot_after)
        .expect("the pilot's throttle back")
        .t_us;
    eprintln!(
        "measured: msp_override_channels changed in flight: noticed {:.0} ms after; throttle held at the pilot's earlier {pilot_before} us by faithd's frame until {:.0} ms after (the pilot's {pilot_after} us then), never faithd's centre",
        (noticed - changed) as f64 / 1000.0,
        (back - changed) as f64 / 1000.0
    );
    assert!(noticed - changed <= 1_000_000);
    assert!(back - changed <= 1_500_000);
    assert!(
        after
            .iter()
            .filter(|s| s.t_us >= back)
            .all(|s| s.rc[3] == pilot_after),
        "throttle back to the pilot's"
    );
}
