//! Another architecture's build against this one, bit for bit: with
//! `FAITHD_UNDER_TEST` naming another build (CI: the arm64 flight build under
//! `qemu-aarch64 -L /`), `faithd replay --json` of the real DAVIS240C recordings and
//! of the simulator's flights prints the same window log as the build these tests were
//! compiled with. serde_json prints the shortest text that reads back to the same
//! f64, so equal logs mean equal numbers, not only equal printing: a flight recorded on
//! the drone replays to the same decisions on a laptop.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use faithd_core::camera::CameraIntrinsics;
use faithd_formats::events::aedat4::{Aedat4Config, Aedat4Writer};

use crate::common::{self, TempDir};
use crate::real_events;

/// Whether another build is under test; when not (these tests would only compare the
/// native build with itself), one line on the real standard error says so.
fn other_build_given() -> bool {
    let given = common::faithd_under_test().is_some();
    if !given {
        let _ = writeln!(
            std::io::stderr(),
            "skipped: FAITHD_UNDER_TEST is unset (another architecture's faithd to compare with this build)"
        );
    }
    given
}

/// `faithd replay --json ARGS` on `binary`: its window log, or the failure.
fn window_log(mut binary: Command, args: &[&std::ffi::OsStr]) -> String {
    let out = binary
        .arg("replay")
        .arg("--json")
        .args(args)
        .output()
        .expect("run faithd replay");
    assert!(
        out.status.success(),
        "faithd replay {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("a UTF-8 window log")
}

/// Replays `args` on both builds and asserts the logs are equal, naming how many
/// windows differ and the first number that does. Returns the number of windows.
fn assert_same_replay(what: &str, args: &[&std::ffi::OsStr]) -> usize {
    let native = window_log(Command::new(env!("CARGO_BIN_EXE_faithd")), args);
    let other = window_log(common::faithd(), args);
    let (native_lines, other_lines): (Vec<&str>, Vec<&str>) =
        (native.lines().collect(), other.lines().collect());
    assert_eq!(
        native_lines.len(),
        other_lines.len(),
        "{what}: the builds replay a different number of windows"
    );
    assert!(!native_lines.is_empty(), "{what}: no window replayed");
    let differing: Vec<usize> = (0..native_lines.len())
        .filter(|&i| native_lines[i] != other_lines[i])
        .collect();
    if let Some(&first) = differing.first() {
        let a: serde_json::Value = serde_json::from_str(native_lines[first]).unwrap();
        let b: serde_json::Value = serde_json::from_str(other_lines[first]).unwrap();
        panic!(
            "{what}: {} of {} windows differ between the builds; the first, window {first}, at {}",
            differing.len(),
            native_lines.len(),
            first_difference(&a, &b, String::new()).unwrap_or_default()
        );
    }
    native_lines.len()
}

/// The path of the first value that differs between `a` and `b`, with both values.
fn first_difference(a: &serde_json::Value, b: &serde_json::Value, path: String) -> Option<String> {
    use serde_json::Value;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) if x.len() == y.len() => x
            .iter()
            .find_map(|(k, v)| first_difference(v, y.get(k)?, format!("{path}.{k}"))),
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (v, w))| first_difference(v, w, format!("{path}[{i}]"))),
        _ if a == b => None,
        _ => Some(format!(
            "{path}: {a} (this build) against {b} (FAITHD_UNDER_TEST)"
        )),
    }
}

/// A faithd.toml whose camera is `camera` (the shipped file's other keys default).
fn config_for(dir: &Path, camera: &CameraIntrinsics) -> PathBuf {
    let path = dir.join("faithd.toml");
    std::fs::write(
        &path,
        format!(
            "[pipeline.camera]\nwidth_px = {}\nheight_px = {}\nfx_px = {:?}\nfy_px = {:?}\ncx_px = {:?}\ncy_px = {:?}\n",
            camera.width_px,
            camera.height_px,
            camera.fx_px,
            camera.fy_px,
            camera.cx_px,
            camera.cy_px
        ),
    )
    .unwrap();
    path
}

#[test]
fn the_real_recordings_replay_identically_on_both_builds() {
    if !other_build_given() {
        return;
    }
    let Some(root) = real_events::real_events() else {
        return;
    };
    let scratch = TempDir::new("arch-real");
    let mut windows = 0;
    for (name, _) in real_events::RECORDINGS {
        let dir = root.join(name);
        let camera = real_events::intrinsics(&dir);
        let config = config_for(&scratch.0, &camera);
        let events = dir.join("events.txt");
        windows += assert_same_replay(
            &dir.display().to_string(),
            &[
                "--events".as_ref(),
                events.as_os_str(),
                "--config".as_ref(),
                config.as_os_str(),
            ],
        );
    }
    eprintln!("real recordings: {windows} windows identical on both builds");
}

/// How long each simulated flight lasts: 300 windows of `daemon.period_us`.
#[cfg(feature = "sim")]
const FLIGHT_S: f64 = 3.0;

#[cfg(feature = "sim")]
/// The simulator's flights: a pole in the arena dead ahead, a swaying flight through
/// the kitchen, a rotating one through the warehouse (derotation from imu.txt).
#[test]
fn the_simulators_flights_replay_identically_on_both_builds() {
    use faithd_sim::world::{DvsConfig, ImuConfig, SceneKind, Trajectory, simulate};
    if !other_build_given() {
        return;
    }
    let scratch = TempDir::new("arch-sim");
    let camera = CameraIntrinsics::dvs240();
    let mut flights = vec![
        (
            SceneKind::Arena,
            Trajectory::straight([0.0, 0.0, -1.0], 0.0, 2.0, 2.0),
        ),
        (
            SceneKind::Kitchen,
            Trajectory::straight([-4.0, 0.5, -1.0], 0.0, -4.0, 1.5),
        ),
        (
            SceneKind::Warehouse,
            Trajectory::straight([-4.0, 0.0, -1.5], 0.0, 6.0, 2.0),
        ),
    ];
    flights[1].1.sway_m_s = 0.5;
    flights[1].1.sway_hz = 1.0;
    flights[2].1.yaw_amp_deg = 3.0;
    flights[2].1.yaw_hz = 0.8;
    flights[2].1.pitch_amp_deg = 1.5;
    flights[2].1.pitch_hz = 0.6;
    let mut windows = 0;
    for (seed, (scene, trajectory)) in flights.into_iter().enumerate() {
        let run = simulate(
            &scene.build(seed as u64),
            &trajectory,
            camera,
            DvsConfig::default(),
            ImuConfig::default(),
            FLIGHT_S,
            seed as u64,
        );
        let events = scratch.0.join(format!("{}.aedat4", scene.name()));
        let mut writer = Aedat4Writer::new(
            std::fs::File::create(&events).unwrap(),
            Aedat4Config::default(),
        )
        .unwrap();
        writer.write_events(&run.events).unwrap();
        writer.finish().unwrap();
        // imu.txt: t ax ay az gx gy gz, the gyro in camera axes (x right = pitch,
        // y down = yaw, z forward = roll), as `faithd replay --imu` reads it.
        let imu = scratch.0.join(format!("{}.imu.txt", scene.name()));
        let lines: String = run
            .attitude
            .iter()
            .map(|s| {
                format!(
                    "{:?} 0 0 9.81 {:?} {:?} {:?}\n",
                    s.t_us as f64 * 1e-6,
                    s.pitch_rate_rad_s,
                    s.yaw_rate_rad_s,
                    s.roll_rate_rad_s
                )
            })
            .collect();
        std::fs::write(&imu, lines).unwrap();
        windows += assert_same_replay(
            scene.name(),
            &[
                "--events".as_ref(),
                events.as_os_str(),
                "--imu".as_ref(),
                imu.as_os_str(),
            ],
        );
    }
    eprintln!("simulated flights: {windows} windows identical on both builds");
}
