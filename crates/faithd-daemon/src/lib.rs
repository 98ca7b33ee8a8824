//! faithd's flight daemon: the adapters around the pure core (`faithd-core`) that
//! connect it to a drone. The one simulated part is the bench camera `source::sim`
//! (generated events, which `faithd run` takes only with `--simulated-camera`); the
//! lab, `faithd-lab`, drives this crate through the seams that fly. Events come from
//! the camera, attitude and the pilot's switch from iNav over MAVLink; decisions go
//! back to iNav as timed roll overrides, only while the safety gate is open. Modules
//! from the outside in (docs/design.md):

pub mod clock; // the daemon's one monotonic clock, in microseconds
pub mod config; // faithd.toml: typed settings, checked before anything opens
pub mod source; // events: the DVS240 over libcaer and its clock, or the bench's sim
pub mod transport; // the ports faithd opens: serial, TCP, UDP, in-process; bounded writes
pub mod link; // MAVLink from iNav: vehicle state, attitude, faithd's heartbeat
pub mod cycle; // the pipeline thread: a window every period, load shedding
pub mod command; // the roll sent to iNav (MSP RC override) and read back
pub mod actuator; // the seam the daemon reaches the autopilot's roll through
pub mod record; // the flight's events, MAVLink and windows on disk, within a budget
pub mod shutdown; // one stop for a run's tasks and threads, and the wait for them
pub mod supervise; // heartbeats of every task for systemd's watchdog; panics
pub mod daemon; // `faithd run`: wires the above together, the commander, shutdown
pub mod replay; // a recorded flight through the same pipeline, off line
pub mod logging; // journal-friendly logs that never block the cycle
