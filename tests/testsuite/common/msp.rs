//! iNav's MSP port on a pseudo-terminal, answered by faithd's model of iNav.

use std::os::fd::OwnedFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use faithd_core::safety::rc::NEUTRAL_US;
use faithd_inav::msp::{InavMsp, MAX_GLOBAL_VARIABLES, Pilot, Setup};

use super::autopilot::{Controls, PILOT_ROLL_US};
use super::{hold_output, poll_until, raw_pty};

/// iNav's MSP port on a pseudo-terminal, answered by faithd's own model of iNav as it
/// behaves on a flight controller (`faithd_inav::msp`: one command per
/// 10 ms, a 256-byte receive ring, the override's timing and scaling, modes). It
/// records the roll the model's iNav uses every millisecond, and what crossed the
/// port. A model encodes our assumptions: `tests/testsuite/inav_sitl.rs` holds faithd to iNav's
/// own firmware; these tests cover what SITL cannot be made to do (stale telemetry,
/// garbage on the wire, a vanishing port) and run in CI, which has no SITL.
pub struct MspMock {
    pub slave_path: PathBuf,
    /// (time, roll value the model's iNav uses); one log for all of a board's ports.
    pub roll_log: Arc<Mutex<Vec<(Instant, u16)>>>,
    /// Every MSP_SET_RAW_RC iNav served on this port: (time, channels).
    pub frames: Arc<Mutex<Vec<Written>>>,
    /// Every request that reached this port, and every one iNav answered.
    pub traffic: Arc<Mutex<Traffic>>,
    /// Every MSP2_INAV_SET_GVAR iNav accepted on this port: (time served, index, the
    /// value sent, before iNav clamped it).
    pub gvar_log: Arc<Mutex<Vec<(Instant, u8, i32)>>>,
    /// The board's global variables as of the model's last run.
    gvars: Arc<Mutex<[i32; MAX_GLOBAL_VARIABLES]>>,
    /// A set-up change to make while faithd runs (a configurator on another port).
    setup_change: Arc<Mutex<Option<Setup>>>,
    /// The board's set-up, shared by its ports.
    setup: Arc<Mutex<Setup>>,
    /// The thread that runs the board: it stops when the board's last port is dropped.
    _board: Arc<Board>,
    slave: Arc<OwnedFd>,
    /// A timed test: no heavy test runs while iNav's port does (dropped last).
    _cpu: super::cpu::Slot,
}

/// The thread running a board's model for all its ports.
struct Board {
    stop: Arc<AtomicBool>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

impl Drop for Board {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.lock().unwrap().take() {
            let _ = t.join();
        }
    }
}

/// What the board's thread fills for one port.
struct PortShared {
    frames: Arc<Mutex<Vec<Written>>>,
    traffic: Arc<Mutex<Traffic>>,
    gvar_log: Arc<Mutex<Vec<(Instant, u8, i32)>>>,
}

/// One MSP_SET_RAW_RC iNav served: when, and its channels.
pub type Written = (Instant, Vec<u16>);

/// What crossed the port: requests as they arrived, commands as iNav served them.
#[derive(Clone, Debug, Default)]
pub struct Traffic {
    pub arrived: Vec<(Instant, u16)>,
    pub served: Vec<(Instant, u16)>,
    pub bytes_lost: u64,
}

/// A roll iNav uses that is faithd's doing: neither its stick centre (what faithd's
/// stream holds in AUTO) nor the pilot's stick ([`PILOT_ROLL_US`], what iNav uses with
/// the override off). Any other value counts, not only the 1200 and 1800 faithd means:
/// a roll of 1650 is a roll.
pub fn is_roll(v: u16) -> bool {
    v != NEUTRAL_US && v != PILOT_ROLL_US
}

impl MspMock {
    pub fn start(controls: Arc<Controls>) -> Self {
        Self::start_with(controls, Setup::default())
    }

    /// The port of a flight controller set up as `setup` says.
    pub fn start_with(controls: Arc<Controls>, setup: Setup) -> Self {
        Self::start_board(controls, setup, 1).remove(0)
    }

    /// `ports` MSP ports of one flight controller set up as `setup` says, each on a
    /// pseudo-terminal of its own, answered by one model of iNav
    /// ([`InavMsp::add_port`]): what is behind them (the override, the modes, the
    /// global variables) is one. The board runs until all of them are dropped.
    pub fn start_board(controls: Arc<Controls>, setup: Setup, ports: usize) -> Vec<Self> {
        assert!((1..=3).contains(&ports), "iNav has 1 to 3 MSP ports");
        let mut cpu: Vec<_> = (0..ports).map(|_| super::cpu::timed()).collect();
        let ptys: Vec<_> = (0..ports)
            .map(|_| {
                let (master, slave, path) = raw_pty();
                (master, Arc::new(slave), path)
            })
            .collect();
        let shared: Vec<PortShared> = (0..ports)
            .map(|_| PortShared {
                frames: Arc::new(Mutex::new(Vec::new())),
                traffic: Arc::new(Mutex::new(Traffic::default())),
                gvar_log: Arc::new(Mutex::new(Vec::new())),
            })
            .collect();
        let roll_log = Arc::new(Mutex::new(Vec::new()));
        let gvars = Arc::new(Mutex::new([0; MAX_GLOBAL_VARIABLES]));
        let setup_change = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let mut masters = Vec::new();
        let mut thread_ports = Vec::new();
        let mut handles = Vec::new();
        for ((master, slave, path), port) in ptys.into_iter().zip(shared) {
            handles.push((slave.clone(), path, port.clone_handles()));
            // The thread keeps the slave open too: a port whose mock is dropped
            // first does not hang up under the others.
            masters.push((master, slave));
            thread_ports.push(port);
        }
        let thread = {
            let (roll_log, gvars, setup_change, stop) = (
                roll_log.clone(),
                gvars.clone(),
                setup_change.clone(),
                stop.clone(),
            );
            let setup = setup.clone();
            std::thread::spawn(move || {
                run_board(
                    controls,
                    setup,
                    masters,
                    thread_ports,
                    roll_log,
                    gvars,
                    setup_change,
                    stop,
                )
            })
        };
        let board = Arc::new(Board {
            stop,
            thread: Mutex::new(Some(thread)),
        });
        let setup = Arc::new(Mutex::new(setup));
        handles
            .into_iter()
            .map(|(slave, slave_path, port)| MspMock {
                slave_path,
                roll_log: roll_log.clone(),
                frames: port.frames,
                traffic: port.traffic,
                gvar_log: port.gvar_log,
                gvars: gvars.clone(),
                setup_change: setup_change.clone(),
                setup: setup.clone(),
                _board: board.clone(),
                slave,
                _cpu: cpu.pop().expect("a slot per port"),
            })
            .collect()
    }

    /// The board's global variables as iNav holds them now (MSP2_INAV_GVAR_STATUS).
    pub fn gvars(&self) -> Vec<i32> {
        self.gvars.lock().unwrap().to_vec()
    }

    /// Changes iNav's set-up while it runs, as a configurator or a script on another
    /// MSP port would (no reboot: what iNav fixes at boot stays).
    pub fn change_setup(&mut self, change: impl FnOnce(&mut Setup)) {
        let mut setup = self.setup.lock().unwrap();
        change(&mut setup);
        *self.setup_change.lock().unwrap() = Some(setup.clone());
    }

    /// Suspends (or resumes) output on faithd's side of the port, as a UART held
    /// off by flow control: faithd's writes stop completing.
    pub fn hold_faithds_writes(&self, held: bool) {
        hold_output(&self.slave, held);
    }

    /// faithd's `[command]` section for this port.
    pub fn command_toml(&self) -> String {
        format!(
            "[command.sink]\nkind = \"msp\"\nendpoint = \"serial:{}\"\n",
            self.slave_path.display()
        )
    }

    /// When iNav first used a roll ([`is_roll`]).
    pub fn first_roll(&self) -> Option<Instant> {
        self.roll_after(Instant::now() - Duration::from_secs(3600))
    }

    /// When iNav first used a roll at or after `t`.
    pub fn roll_after(&self, t: Instant) -> Option<Instant> {
        self.roll_log
            .lock()
            .unwrap()
            .iter()
            .find(|(at, v)| *at >= t && is_roll(*v))
            .map(|(at, _)| *at)
    }

    /// When iNav first used something other than a roll at or after `t`, and what:
    /// the release as iNav took it.
    pub fn unrolled_after(&self, t: Instant) -> Option<(Instant, u16)> {
        self.roll_log
            .lock()
            .unwrap()
            .iter()
            .find(|(at, v)| *at >= t && !is_roll(*v))
            .copied()
    }

    /// Waits until `pred` holds (or `timeout` passes).
    pub fn wait_for(&self, timeout: Duration, pred: impl Fn(&MspMock) -> bool) -> bool {
        poll_until(timeout, || pred(self))
    }
}

impl PortShared {
    fn clone_handles(&self) -> PortShared {
        PortShared {
            frames: self.frames.clone(),
            traffic: self.traffic.clone(),
            gvar_log: self.gvar_log.clone(),
        }
    }
}

/// The board's loop: reads every port, runs the model to now, writes its replies,
/// and publishes what the ports did, the roll iNav uses and the global variables.
#[allow(clippy::too_many_arguments)]
fn run_board(
    controls: Arc<Controls>,
    setup: Setup,
    masters: Vec<(OwnedFd, Arc<OwnedFd>)>,
    ports: Vec<PortShared>,
    roll_log: Arc<Mutex<Vec<(Instant, u16)>>>,
    gvars: Arc<Mutex<[i32; MAX_GLOBAL_VARIABLES]>>,
    setup_change: Arc<Mutex<Option<Setup>>>,
    stop: Arc<AtomicBool>,
) {
    let start = Instant::now();
    let at = |t_us: i64| start + Duration::from_micros(t_us as u64);
    let mut fc = InavMsp::new(setup, 0);
    for _ in 1..masters.len() {
        fc.add_port();
    }
    let mut buf = [0u8; 4096];
    // Per port: how much of its log was published (frames, arrived, served, gvars).
    let mut seen = vec![(0, 0, 0, 0); masters.len()];
    while !stop.load(Ordering::Relaxed) {
        let mut fds: Vec<_> = masters
            .iter()
            .map(|(master, _)| {
                nix::poll::PollFd::new(
                    std::os::fd::AsFd::as_fd(master),
                    nix::poll::PollFlags::POLLIN,
                )
            })
            .collect();
        let _ = nix::poll::poll(&mut fds, 1u16);
        let ready: Vec<bool> = fds
            .iter()
            .map(|fd| {
                fd.revents()
                    .is_some_and(|r| r.contains(nix::poll::PollFlags::POLLIN))
            })
            .collect();
        if let Some(s) = setup_change.lock().unwrap().take() {
            fc.setup = s;
        }
        let now_us = start.elapsed().as_micros() as i64;
        let switch_us = controls.switch_us.load(Ordering::Relaxed);
        let mut pilot =
            Pilot::flying([PILOT_ROLL_US, 1500, 1500, 1400, 1900, switch_us, 1000, 1000]);
        pilot.armed = controls.armed.load(Ordering::Relaxed);
        pilot.failsafe = controls.system_status.load(Ordering::Relaxed) >= 5;
        fc.set_pilot(pilot);
        fc.set_motion(*controls.motion.lock().unwrap());
        fc.ignore_frames = controls.override_ignored.load(Ordering::Relaxed);
        for (port, (master, _)) in masters.iter().enumerate() {
            if ready[port]
                && let Ok(n) = nix::unistd::read(master, &mut buf)
                && n > 0
            {
                fc.receive_on(port, &buf[..n], now_us);
            }
        }
        fc.advance(now_us);
        for (port, ((master, _), shared)) in masters.iter().zip(&ports).enumerate() {
            let out = fc.take_output_on(port);
            if !out.is_empty() {
                let _ = nix::unistd::write(master, &out);
            }
            let log = fc.port_log(port);
            let seen = &mut seen[port];
            shared.frames.lock().unwrap().extend(
                log.frames[seen.0..]
                    .iter()
                    .map(|(t, ch)| (at(*t), ch.clone())),
            );
            {
                let mut traffic = shared.traffic.lock().unwrap();
                traffic
                    .arrived
                    .extend(log.arrived[seen.1..].iter().map(|(t, c)| (at(*t), *c)));
                traffic
                    .served
                    .extend(log.served[seen.2..].iter().map(|(t, c)| (at(*t), *c)));
                traffic.bytes_lost = log.bytes_lost;
            }
            shared.gvar_log.lock().unwrap().extend(
                log.gvar_writes[seen.3..]
                    .iter()
                    .map(|(t, i, v)| (at(*t), *i, *v)),
            );
            *seen = (
                log.frames.len(),
                log.arrived.len(),
                log.served.len(),
                log.gvar_writes.len(),
            );
        }
        *gvars.lock().unwrap() = fc.gvars();
        let roll_us = fc.roll_in_use();
        controls.roll_us.store(roll_us, Ordering::Relaxed);
        roll_log.lock().unwrap().push((at(now_us), roll_us));
    }
}

/// The harness itself: a board without MAVLink answers on both MSP ports from one
/// model.
mod self_test {
    use std::io::Write;
    use std::os::fd::AsFd;
    use std::path::Path;
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    use faithd_inav::frame::{Decoder, Frame, request};
    use faithd_inav::msp::{
        MSP_ATTITUDE, MSP_FC_VERSION, MSP_RAW_IMU, MSP2_INAV_GVAR_STATUS, MSP2_INAV_SET_GVAR,
        Motion, Setup,
    };

    use crate::common::autopilot::{Controls, MockAutopilot};

    /// One request on the port at `path` and its reply.
    fn ask(path: &Path, command: u16, payload: &[u8]) -> Frame {
        let mut port = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .unwrap();
        port.write_all(&request(command, payload)).unwrap();
        let deadline = Instant::now() + Duration::from_secs(2);
        let (mut decoder, mut frames, mut buf) = (Decoder::default(), Vec::new(), [0u8; 512]);
        while frames.is_empty() && Instant::now() < deadline {
            let mut fds = [nix::poll::PollFd::new(
                port.as_fd(),
                nix::poll::PollFlags::POLLIN,
            )];
            if nix::poll::poll(&mut fds, 50u16).unwrap_or(0) > 0 {
                let n = nix::unistd::read(&port, &mut buf).unwrap();
                decoder.push(&buf[..n], &mut frames);
            }
        }
        assert_eq!(frames.len(), 1, "one reply to {command}");
        frames.remove(0)
    }

    fn i16s(payload: &[u8]) -> Vec<i16> {
        payload
            .chunks_exact(2)
            .map(|c| i16::from_le_bytes([c[0], c[1]]))
            .collect()
    }

    #[test]
    fn an_msp_only_mock_answers_on_two_ports_of_one_board() {
        let controls = Arc::new(Controls::default());
        let setup = Setup {
            fc_version: [10, 0, 0],
            ..Setup::default()
        };
        let mock = MockAutopilot::start_msp_only(controls.clone(), setup);
        let telemetry = mock.telemetry.as_ref().unwrap();
        assert_eq!(
            mock.msp_only_toml(),
            format!(
                "[telemetry]\nkind = \"msp\"\nendpoint = \"serial:{}\"\n\n\
                 [command.sink]\nkind = \"msp\"\nendpoint = \"serial:{}\"\n",
                telemetry.slave_path.display(),
                mock.msp.slave_path.display()
            )
        );
        assert_eq!(mock.slave_path, Path::new(""), "no MAVLink port");
        let version = ask(&mock.msp.slave_path, MSP_FC_VERSION, &[]);
        assert_eq!(version.payload, vec![10, 0, 0]);
        // The default motion: level, heading 30 degrees, still.
        let attitude = ask(&telemetry.slave_path, MSP_ATTITUDE, &[]);
        assert_eq!(i16s(&attitude.payload), vec![0, 0, 30]);
        *controls.motion.lock().unwrap() = Motion {
            roll_ddeg: -250,
            pitch_ddeg: 40,
            yaw_ddeg: 1805,
            gyro_dps: [12.5, -3.6, 0.0],
        };
        std::thread::sleep(Duration::from_millis(20));
        let attitude = ask(&telemetry.slave_path, MSP_ATTITUDE, &[]);
        assert_eq!(i16s(&attitude.payload), vec![-250, 40, 180]);
        let imu = ask(&telemetry.slave_path, MSP_RAW_IMU, &[]);
        assert_eq!(i16s(&imu.payload), vec![0, 0, 512, 12, -4, 0, 0, 0, 0]);
        // A variable written on the telemetry port is the board's.
        let mut payload = vec![5];
        payload.extend_from_slice(&7i32.to_le_bytes());
        let set = ask(&telemetry.slave_path, MSP2_INAV_SET_GVAR, &payload);
        assert_eq!((set.direction, set.payload.len()), (b'>', 0));
        let status = ask(&mock.msp.slave_path, MSP2_INAV_GVAR_STATUS, &[]);
        assert_eq!(status.payload[20..24], 7i32.to_le_bytes());
        assert!(
            mock.msp
                .wait_for(Duration::from_secs(1), |m| m.gvars()[5] == 7)
        );
        assert_eq!(telemetry.gvars(), mock.msp.gvars());
        let logged: Vec<(u8, i32)> = telemetry
            .gvar_log
            .lock()
            .unwrap()
            .iter()
            .map(|&(_, i, v)| (i, v))
            .collect();
        assert_eq!(logged, vec![(5, 7)]);
        assert!(mock.msp.gvar_log.lock().unwrap().is_empty());
        assert!(mock.received.lock().unwrap().is_empty(), "no MAVLink");
    }
}
