//! faithd against iNav's own firmware: iNav 9.1's SITL build, set up from the
//! committed CLI scripts (tests/inav/pilot.cli, then hil/inav/faithd.cli), the
//! pilot's radio on a real IBUS receiver, the real `faithd run` binary on SITL's
//! MAVLink and MSP ports. Every assertion is on what iNav itself uses, read back over
//! MSP (MSP_RC, MSP2_INAV_STATUS) on a port of its own, never on what faithd sent.
//!
//! `cargo test --release --test inav_sitl -- --nocapture` prints the measured
//! figures (application delay, in-effect share, release delay) the README quotes.

mod common;

use std::time::Duration;

use common::Daemon;
use common::sitl::*;

/// faithd's defaults (config/faithd.toml).
const NEUTRAL_US: u16 = 1500;
const ROLL_MS: i64 = 1500;
/// The bounds: the roll in effect within 100 ms of the decision, for at
/// least 95 % of its 1.5 s; the pilot's control back within 100 ms.
const APPLY_BOUND_US: i64 = 100_000;
const IN_EFFECT_MIN: f64 = 0.95;
const RELEASE_BOUND_US: i64 = 100_000;

/// A vehicle on the bench: SITL with the committed set-up plus `extra` CLI lines,
/// the pilot's radio, the monitor, armed in ANGLE, the pilot's roll stick slightly
/// left of centre.
struct Bench {
    sitl: Sitl,
    radio: Radio,
    monitor: Monitor,
}

impl Bench {
    fn new(extra: &[&str]) -> Self {
        let sitl = Sitl::with_committed_setup(extra);
        let radio = Radio::start(&sitl);
        let monitor = Monitor::start(&sitl);
        arm(&radio, &monitor, &sitl);
        radio.set(CH_ROLL, PILOT_ROLL_US);
        Bench {
            sitl,
            radio,
            monitor,
        }
    }

    /// `faithd run` on this SITL: MAVLink on UART3, the MSP stream on UART4, the
    /// simulated camera's first approach at `first_approach_us`.
    fn faithd(&self, first_approach_us: i64, extra: &str) -> Daemon {
        Daemon::start_config(
            &format!(
                "[mavlink]\nendpoint = \"{}\"\nreconnect_min_us = 50000\nreconnect_max_us = 200000\n\
                 [command]\nmsp_endpoint = \"{}\"\n\
                 [source]\nkind = \"sim\"\nsim_first_approach_us = {first_approach_us}\nsim_repeat_us = 4000000\n\
                 [record]\nenabled = false\n{extra}",
                self.sitl.endpoint(UART_MAVLINK),
                self.sitl.endpoint(UART_MSP_FAITHD),
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
        } else if line.contains("manoeuvre completed") || line.contains("manoeuvre cut") {
            if let Some(m) = out.last_mut() {
                m.end_us = field(line, "unix_us");
            }
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
    assert!(
        during.len() > 100,
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
        // What the pilot sent up to 50 ms before the sample (iNav's receiver latency).
        let candidates: Vec<Vec<u16>> = sent
            .iter()
            .filter(|(t, _)| *t <= s.t_us)
            .rev()
            .take_while(|(t, _)| *t >= s.t_us - 50_000)
            .chain(
                sent.iter()
                    .filter(|(t, _)| *t < s.t_us - 50_000)
                    .next_back(),
            )
            .map(|(_, ch)| inav_order(ch))
            .collect();
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
    let bench = Bench::new(&[]);
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
