//! iNav's own flight controller flying a quadrotor: iNav 9.1's SITL (`INAV_SITL`) on
//! its RealFlight interface (`--sim=rf`) against faithd-lab's physics server
//! (`realflight`), so that iNav's mixer, PIDs and ANGLE mode, not faithd's model of
//! them, turn a roll stick into a bank. The pilot's radio is IBUS, as in the route
//! tests; a scripted pilot holds the height with the throttle, looking at the true
//! state as a person looks at the drone. Skipped with one line without `INAV_SITL`.

use std::net::{IpAddr, Ipv4Addr};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nalgebra::Vector3;

use crate::common::sitl::{self, CH_ROLL, CH_THROTTLE, Monitor, Radio, Sitl};
use crate::require_sitl;
use faithd::inav_sitl::SitlError;
use faithd::inav_sitl::flight::Link;
use faithd::realflight::{Server, World};
use faithd_inav::msp::{Setup, rc_command};
use faithd_sim::world::quad::{Quad, QuadConfig};
use faithd_sim::world::quad_x::{QuadX, QuadXConfig};

/// The simulated airframe's part of iNav's set-up (quad-X mixer, fake GPS).
const QUAD_CLI: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/inav/quad_rf.cli");

/// RealFlight's address for this SITL (its port is fixed at 18083).
const SIM_IP: Ipv4Addr = Ipv4Addr::new(127, 0, 0, 2);

fn quad_on_the_ground() -> (Server, Sitl) {
    let world = World::new(QuadX::on_ground(
        QuadXConfig::default(),
        Vector3::zeros(),
        0.0,
    ));
    let server = Server::start(IpAddr::V4(SIM_IP), world).expect("bind the RealFlight port");
    let mut lines = sitl::read_script(sitl::PILOT_CLI);
    lines.extend(sitl::read_script(sitl::FAITHD_CLI));
    lines.extend(sitl::read_script(QUAD_CLI));
    // iNav 9.1's SITL with --sim=rf sometimes dies of SIGSEGV while it starts; a
    // fresh one is started then, as `faithd sim --autopilot inav-sitl` does.
    for _ in 0..3 {
        let booted = Sitl::try_start_with(&[
            "--sim=rf".into(),
            format!("--simip={SIM_IP}"),
            "--chanmap=M01-01,M02-02,M03-03,M04-04".into(),
        ])
        .and_then(|sitl| sitl.try_cli_save(&lines).map(|()| sitl));
        match booted {
            Ok(sitl) => return (server, sitl),
            Err(e @ SitlError::Crashed { .. }) => eprintln!("{e}\nstarting a fresh SITL"),
            Err(e) => panic!("{e}"),
        }
    }
    panic!("SITL ended by itself while starting, three times running");
}

/// One moment of the flight: time since the roll (s), bank (deg), height (m), y (m).
#[derive(Clone, Copy, Debug)]
struct Seen {
    t_s: f64,
    bank_deg: f64,
    height_m: f64,
    right_m: f64,
    tilt_deg: f64,
}

/// The scripted pilot's left hand: the throttle that holds `target_m` of height, from
/// the height and climb rate it sees, every 20 ms.
struct Pilot {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Pilot {
    fn start(world: Arc<World>, radio: Arc<Radio>, target_m: f64) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut integral = 0.0;
                while !stop.load(Ordering::Relaxed) {
                    let quad = world.quad();
                    let height_m = -quad.position_m.z;
                    let climb_m_s = -quad.velocity_m_s.z;
                    let error_m = target_m - height_m;
                    integral = (integral + error_m * 0.02).clamp(-5.0, 5.0);
                    let throttle = 1500.0 + 120.0 * error_m + 40.0 * integral - 150.0 * climb_m_s;
                    radio.set(CH_THROTTLE, throttle.clamp(1150.0, 1850.0) as u16);
                    std::thread::sleep(Duration::from_millis(20));
                }
            })
        };
        Self {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Pilot {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn seen(world: &World, since: Instant) -> Seen {
    let quad = world.quad();
    let (roll, _, _) = quad.euler_rad();
    Seen {
        t_s: since.elapsed().as_secs_f64(),
        bank_deg: roll.to_degrees(),
        height_m: -quad.position_m.z,
        right_m: quad.position_m.y,
        tilt_deg: quad.tilt_rad().to_degrees(),
    }
}

/// The pilot takes off to 2 m in ANGLE and holds it; a full 1.5 s roll stick of
/// +300 us (what faithd commands) then banks the vehicle right through iNav's own
/// ANGLE controller and mixer: the bank it reaches, how soon, how far it goes, and that
/// it neither flips nor changes height by more than 0.5 m.
#[test]
fn inavs_angle_mode_banks_the_quad_on_a_roll_stick() {
    require_sitl!();
    let (server, sitl) = quad_on_the_ground();
    let world = server.world.clone();
    let radio = Arc::new(Radio::start(&sitl));
    let monitor = Monitor::start(&sitl);
    sitl::arm(&radio, &monitor, &sitl);
    assert!(
        monitor.latest().is_some_and(|s| s.mode(sitl::MODE_ANGLE)),
        "ANGLE is on while armed (tests/inav/pilot.cli)"
    );
    let pilot = Pilot::start(world.clone(), radio.clone(), 2.0);
    let start = Instant::now();
    let mut steady_since = None;
    while start.elapsed() < Duration::from_secs(20) {
        let s = seen(&world, start);
        assert!(
            s.tilt_deg < 60.0,
            "lost control in the take-off: {s:?}; SITL log:\n{}",
            sitl.log()
        );
        let quad = world.quad();
        let steady = (s.height_m - 2.0).abs() < 0.2 && quad.velocity_m_s.norm() < 0.3;
        match (steady, steady_since) {
            (true, None) => steady_since = Some(Instant::now()),
            (false, _) => steady_since = None,
            _ => {}
        }
        if steady_since.is_some_and(|t| t.elapsed() > Duration::from_secs(1)) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        steady_since.is_some(),
        "the pilot never held 2 m: {:?}, exchanges {}; SITL log:\n{}",
        seen(&world, start),
        world.counters.exchanges.load(Ordering::Relaxed),
        sitl.log()
    );

    let before = seen(&world, start);
    let rolled = Instant::now();
    radio.set(CH_ROLL, 1800);
    let mut path = Vec::new();
    while rolled.elapsed() < Duration::from_millis(2500) {
        if rolled.elapsed() >= Duration::from_millis(1500) {
            radio.set(CH_ROLL, 1500);
        }
        path.push(seen(&world, rolled));
        std::thread::sleep(Duration::from_millis(5));
    }
    drop(pilot);

    let peak = path.iter().map(|s| s.bank_deg).fold(f64::MIN, f64::max);
    let to_5_deg = path.iter().find(|s| s.bank_deg > 5.0).map(|s| s.t_s);
    let to_90 = path.iter().find(|s| s.bank_deg > 0.9 * peak).map(|s| s.t_s);
    let max_tilt = path.iter().map(|s| s.tilt_deg).fold(0.0, f64::max);
    let height_change = path
        .iter()
        .map(|s| (s.height_m - before.height_m).abs())
        .fold(0.0, f64::max);
    let moved_right = path.last().unwrap().right_m - before.right_m;
    println!(
        "iNav ANGLE, roll stick 1800 us for 1.5 s: peak bank {peak:.1} deg, 5 deg after \
         {to_5_deg:?} s, 90 % of peak after {to_90:?} s, moved {moved_right:.2} m right in \
         2.5 s, height within {height_change:.2} m, tilt at most {max_tilt:.1} deg; \
         {} exchanges, {} late",
        world.counters.exchanges.load(Ordering::Relaxed),
        world.counters.late_exchanges.load(Ordering::Relaxed),
    );
    // faithd's model of the same (the closed loop's `world::quad`: ANGLE as a bank
    // target with a first-order lag), on the same stick, for the record: where the two
    // differ is what the model is to learn from iNav.
    let mut model = Quad::new(QuadConfig::default(), Vector3::zeros(), 0.0);
    let (mut model_peak, mut model_5, mut model_banks) = (0.0f64, None, Vec::new());
    for ms in 0..2500 {
        // iNav's target for the stick (14.85 degrees for 1800 us), as the closed
        // loop's simulated iNav hands it to the physics.
        let stick_us = if ms < 1500 { 1800 } else { 1500 };
        let command = rc_command(&Setup::default(), stick_us);
        model.step((command / 500.0 * 45.0).to_radians(), 0.001);
        let bank = model.bank_rad.to_degrees();
        model_peak = model_peak.max(bank);
        if bank > 5.0 && model_5.is_none() {
            model_5 = Some(f64::from(ms + 1) / 1000.0);
        }
        model_banks.push(bank);
    }
    let model_90 = model_banks
        .iter()
        .position(|b| *b > 0.9 * model_peak)
        .map(|ms| (ms + 1) as f64 / 1000.0);
    println!(
        "faithd's model, same stick: peak bank {model_peak:.1} deg, 5 deg after \
         {model_5:?} s, 90 % of peak after {model_90:?} s, moved {:.2} m right",
        model.position_m.y
    );
    assert!(max_tilt < 90.0, "flipped: {path:?}");
    assert!((5.0..=45.0).contains(&peak), "peak bank {peak}: {path:?}");
    assert!(to_5_deg.is_some_and(|t| t < 0.5), "{path:?}");
    assert!(moved_right > 0.3, "moved {moved_right} m: {path:?}");
    assert!(
        height_change < 0.5,
        "height changed {height_change} m: {path:?}"
    );
}

/// faithd, its camera and iNav's own controller in one loop: the first five flights
/// of `faithd sim --autopilot inav-sitl` (three collision courses, two near passes),
/// the real daemon on iNav's MAVLink and MSP UARTs, the scripted pilot on IBUS, the
/// quad-X flown by iNav's mixer. Every collision course is avoided by a roll iNav's
/// controller flew, no near pass rolls, and iNav's figures are still those the model
/// is held to in CI (`faithd::inav_sitl::measured`).
#[test]
fn faithd_avoids_the_pole_through_inavs_own_controller() {
    require_sitl!();
    avoids_the_pole(Link::Mavlink);
}

/// The same five flights with faithd reading iNav over a second MSP port and no
/// MAVLink at all (hil/inav/faithd-msp.cli, `faithd sim --autopilot inav-sitl --link
/// msp`), as on the iNav 10 boards without MAVLink: the same outcomes, within the
/// same bounds.
#[test]
fn msp_only_faithd_avoids_the_pole_through_inavs_own_controller() {
    require_sitl!();
    avoids_the_pole(Link::Msp);
}

fn avoids_the_pole(link: Link) {
    use faithd::inav_sitl::experiment::{RollFigures, fly_all, plan};
    use faithd::inav_sitl::measured;
    let _cpu = crate::common::cpu::timed();
    let exe = sitl::executable().unwrap();
    let flights = fly_all(&plan(5, 1), &exe, link, |i, c| {
        println!(
            "flight {} ({link:?}): {} {:+.2} m; faithd decided {:?} ms after the event; \
             iNav's loop: {}; iNav {:?}; model {:?}",
            i + 1,
            if c.inav.collision_course {
                "collision"
            } else {
                "near pass"
            },
            c.spec.lateral_offset_m,
            c.decision_ms,
            c.stalls.describe(),
            c.inav,
            c.model
        )
    })
    .unwrap_or_else(|e| panic!("{e}"));
    // A stall of iNav's loop (a loaded machine) is reported; it fails a flight only
    // where it could have changed what the flight shows (faithd::inav_sitl::stalls).
    let mut rolls: Vec<RollFigures> = Vec::new();
    let mut disturbed = 0;
    for c in &flights {
        let f = c.inav;
        assert!(f.max_tilt_deg < 30.0, "{f:?}");
        if f.collision_course {
            assert!(f.rolled && !f.collided, "not avoided: {f:?}");
            if let Some(why) = c.stalls.doubts_avoidance(f.min_clearance_m) {
                panic!("{why}: {f:?}");
            }
            assert!(f.height_change_m.unwrap() < 0.5, "{f:?}");
            if c.stalls.disturbs_roll() {
                disturbed += 1;
                continue;
            }
            assert!(
                measured::PEAK_BANK_DEG.holds_on_inav(f.peak_bank_deg.unwrap()),
                "{f:?}"
            );
            rolls.push(f);
        } else {
            assert!(!f.rolled, "rolled on a near pass: {f:?}");
        }
    }
    let late: u64 = flights.iter().map(|c| c.stalls.late_exchanges).sum();
    let exchanges: u64 = flights.iter().map(|c| c.exchanges).sum();
    let worst_ms = flights
        .iter()
        .map(|c| c.stalls.worst_ms)
        .fold(0.0, f64::max);
    println!(
        "iNav's loop ({link:?}): {late} of {exchanges} exchanges late, the longest stall \
         {worst_ms:.0} ms; {disturbed} of {} rolls disturbed by a stall and left out of \
         the bounds",
        disturbed + rolls.len()
    );
    assert!(
        !rolls.is_empty(),
        "a stall of iNav's loop fell in every roll: nothing left to hold iNav's timings to"
    );
    let timings = measured::RollTimings::of(&rolls);
    println!("iNav ({link:?}): {timings:?}");
    if let Err(why) = timings.check_inav() {
        panic!("iNav no longer does what it did in the experiment: {why}");
    }
}
