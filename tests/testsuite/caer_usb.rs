//! iniVation's real libcaer, driving a camera that exists only on a pretend USB bus:
//! the USB stand-in (`libcaer-sys/usb_standin/usb_standin.c`, built by libcaer-sys's
//! `mock` feature as [`USB_STANDIN`]) defines libusb-1.0's functions and is preloaded
//! (`LD_PRELOAD`) ahead of the libusb libcaer links, so libcaer's USB calls reach it.
//! It presents a DAVIS240, DAVIS346, DVXplorer or DVXplorer Lite with the registers
//! libcaer reads, streams the device's own 16-bit event words from a scripted scene,
//! unplugs and replugs, refuses a setting, starts its clock near the 31-bit wrap, and
//! plays the cameras libcaer cannot use (old firmware or logic, busy, no permission).
//! It logs every USB request and every event it put on the wire, and these tests
//! hold libcaer's output (and `faithd run`'s recording) to that log.
//!
//! The real libcaer comes from `LIBCAER_PATH` (checked with libcaer 3.3.15, the
//! PyPI wheel event-camera-drivers 0.2.0's); each test says in one line that it is
//! skipped when it is unset. Nothing of libcaer is in this repository.
//!
//! Direct calls into libcaer run in a child process (this test binary, re-run with
//! the stand-in preloaded and one `ffi_child` command), as the stand-in is one bus
//! per process and chosen by environment variables when it loads.

// Calls into the real libcaer and reads the memory it hands over: foreign code, so
// `unsafe`, each block with why it holds.
#![allow(unsafe_code)]

use crate::common;

use std::collections::HashMap;
use std::ffi::c_void;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use faithd_core::event::{Event, Polarity};
use libcaer_sys::mock::USB_STANDIN;
use libcaer_sys::{
    CAER_DEVICE_DAVIS, CAER_DEVICE_DVXPLORER, Container, Libcaer, caer_davis_info, caer_dvx_info,
    caerDeviceHandle,
};

/// One line on the real standard error (the harness captures `eprintln!`).
fn say(line: &str) {
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// The real libcaer's path, or `None` (and one line saying the test is skipped).
fn real_library() -> Option<String> {
    let path = crate::common::peers::libcaer_path();
    if path.is_none() {
        say(&format!(
            "skipped: no libcaer: run `{}` or set LIBCAER_PATH (iniVation's libcaer 3.x, which the USB stand-in runs under: docs/camera.md)",
            crate::common::peers::PREPARE
        ));
    }
    path
}

// ------------------------------------------------------------ the stand-in's logs

/// One line of the stand-in's log: milliseconds since it loaded, then the words.
#[derive(Clone, Debug)]
struct Line {
    ms: f64,
    words: Vec<String>,
}

impl Line {
    fn what(&self) -> &str {
        self.words.first().map_or("", String::as_str)
    }

    fn field(&self, key: &str) -> Option<&str> {
        self.words
            .iter()
            .find_map(|w| w.strip_prefix(key)?.strip_prefix('='))
    }

    /// The register writes the device took in this line ("set M.P=V").
    fn sets(&self) -> Vec<(u32, u32, u32)> {
        self.decoded("set")
    }

    /// The register writes in this line marked `word`: "set" (taken), "attempt"
    /// (a request libusb refused to send: the device was gone).
    fn decoded(&self, word: &str) -> Vec<(u32, u32, u32)> {
        self.words
            .windows(2)
            .filter(|w| w[0] == word)
            .filter_map(|w| {
                let (address, value) = w[1].split_once('=')?;
                let (module, param) = address.split_once('.')?;
                Some((
                    module.parse().ok()?,
                    param.parse().ok()?,
                    value.parse().ok()?,
                ))
            })
            .collect()
    }
}

fn read_log(path: &Path) -> Vec<Line> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| {
            let mut words = l.split_whitespace();
            let ms = words.next()?.parse().ok()?;
            Some(Line {
                ms,
                words: words.map(str::to_string).collect(),
            })
        })
        .collect()
}

/// Every register write in the log, in order: (line index, module, parameter, value).
fn writes(log: &[Line]) -> Vec<(usize, u32, u32, u32)> {
    log.iter()
        .enumerate()
        .flat_map(|(i, l)| l.sets().into_iter().map(move |(m, p, v)| (i, m, p, v)))
        .collect()
}

/// An event the stand-in put on the wire: device time, pixel, polarity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Encoded {
    t_us: i64,
    x: u16,
    y: u16,
    on: bool,
}

/// The encoded events, one list per stream (each timestamp reset starts one).
fn read_encoded(path: &Path) -> Vec<Vec<Encoded>> {
    let mut sessions: Vec<Vec<Encoded>> = Vec::new();
    for line in std::fs::read_to_string(path).unwrap_or_default().lines() {
        if line.starts_with("# reset") {
            sessions.push(Vec::new());
            continue;
        }
        let f: Vec<i64> = line
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect();
        if let ([t_us, x, y, p], Some(session)) = (f.as_slice(), sessions.last_mut()) {
            session.push(Encoded {
                t_us: *t_us,
                x: *x as u16,
                y: *y as u16,
                on: *p == 1,
            });
        }
    }
    sessions
}

// DAVIS and DVXplorer module and parameter addresses (devices/davis.h,
// devices/dvxplorer.h): the run bits DataStart and DataStop write.
const DVS_RUN: (u32, u32) = (1, 3);
const APS_RUN: (u32, u32) = (2, 4);
const IMU_RUNS: [(u32, u32); 3] = [(3, 2), (3, 3), (3, 4)];
const MUX_RUN: (u32, u32) = (0, 0);
const USB_RUN: (u32, u32) = (9, 0);

/// What the log says of each device session (open to close), in order.
#[derive(Debug, Default)]
struct Session {
    /// The DVS run bit was written on (libcaer's DataStart went through).
    started: bool,
    /// After that, the DVS and the output were written off (or, the camera being
    /// gone, libcaer tried to) and the data transfers cancelled (or had ended with
    /// NO_DEVICE): libcaer's DataStop.
    stopped: bool,
    /// The data transfers ended with NO_DEVICE: the camera was unplugged.
    lost: bool,
    /// `libusb_close` on the handle (libcaer's Close, or a failed open cleaning up).
    closed: bool,
    /// Writes after the DVS was turned on, in order.
    after_start: Vec<(u32, u32, u32)>,
}

/// Splits the log into device sessions: from each successful claim of interface 0
/// (libcaer's open got that far) to the next close.
fn sessions(log: &[Line]) -> Vec<Session> {
    let mut out: Vec<Session> = Vec::new();
    let mut open = false;
    let mut cancels = 0;
    for l in log {
        match l.what() {
            "claim" if l.field("result") == Some("0") => {
                out.push(Session::default());
                open = true;
                cancels = 0;
            }
            "close" if open => {
                out.last_mut().unwrap().closed = true;
                open = false;
            }
            "cancel" if open && l.field("endpoint") == Some("0x82") => cancels += 1,
            _ => {}
        }
        let Some(s) = out.last_mut().filter(|_| open) else {
            continue;
        };
        if l.what() == "complete" && l.field("status") == Some("NO_DEVICE") {
            s.lost = true;
        }
        for (m, p, v) in l.sets().into_iter().chain(l.decoded("attempt")) {
            if (m, p) == DVS_RUN && v == 1 {
                s.started = true;
                s.after_start.clear();
            } else if s.started {
                s.after_start.push((m, p, v));
            }
        }
        let off = |(m, p): (u32, u32)| s.after_start.contains(&(m, p, 0));
        if s.started && off(DVS_RUN) && off(MUX_RUN) && off(USB_RUN) && (cancels > 0 || s.lost) {
            s.stopped = true;
        }
    }
    out
}

/// Every session closed; those started stopped, the others not.
fn assert_sessions_ended_cleanly(log: &[Line]) -> Vec<Session> {
    let all = sessions(log);
    for (k, s) in all.iter().enumerate() {
        assert!(s.closed, "session {k} was never closed: {s:?}");
        assert_eq!(s.stopped, s.started, "session {k}: {s:?}");
    }
    let opened = log
        .iter()
        .filter(|l| l.what() == "open" && l.field("result") == Some("0"))
        .count();
    let closed = log.iter().filter(|l| l.what() == "close").count();
    assert_eq!(opened, closed, "every handle libusb_open gave is closed");
    let inits = log.iter().filter(|l| l.what() == "init").count();
    let exits = log.iter().filter(|l| l.what() == "exit").count();
    assert_eq!(inits, exits, "every libusb_init has its libusb_exit");
    all
}

// ------------------------------------------------ direct calls, in a child process

/// What a child process did and what the stand-in saw.
struct ChildRun {
    report: Vec<String>,
    log: Vec<Line>,
    encoded: Vec<Vec<Encoded>>,
}

impl ChildRun {
    /// The report's line starting with `key`, as key=value pairs.
    fn fields(&self, key: &str) -> HashMap<String, String> {
        let line = self
            .report
            .iter()
            .find(|l| l.split_whitespace().next() == Some(key))
            .unwrap_or_else(|| panic!("no `{key}` in the report: {:?}", self.report));
        line.split_whitespace()
            .filter_map(|w| w.split_once('='))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    fn number(&self, key: &str, field: &str) -> i64 {
        self.fields(key)[field].parse().unwrap()
    }

    /// The polarity events libcaer delivered, in order.
    fn delivered(&self) -> Vec<Encoded> {
        self.report
            .iter()
            .filter_map(|l| l.strip_prefix("event "))
            .map(|l| {
                let f: Vec<i64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
                Encoded {
                    t_us: f[0],
                    x: f[1] as u16,
                    y: f[2] as u16,
                    on: f[3] == 1,
                }
            })
            .collect()
    }
}

/// Runs `command` (see [`ffi_child`]) in a child of this test binary with the stand-in
/// preloaded and `env` choosing its camera.
fn in_child(library: &str, command: &str, env: &[(&str, &str)]) -> ChildRun {
    let dir = common::TempDir::new("caer-usb-child");
    let (report, log, events) = (
        dir.0.join("report"),
        dir.0.join("standin.log"),
        dir.0.join("events"),
    );
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "caer_usb::ffi_child",
            "--ignored",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("LIBCAER_PATH", library)
        .env("CAER_USB_CHILD", command)
        .env("CAER_USB_REPORT", &report)
        .env("LD_PRELOAD", USB_STANDIN)
        .env("USB_STANDIN_LOG", &log)
        .env("USB_STANDIN_EVENTS", &events)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{command} {env:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    ChildRun {
        report: std::fs::read_to_string(&report)
            .unwrap_or_default()
            .lines()
            .map(str::to_string)
            .collect(),
        log: read_log(&log),
        encoded: read_encoded(&events),
    }
}

static LOST: AtomicBool = AtomicBool::new(false);

unsafe extern "C" fn on_lost(_: *mut c_void) {
    LOST.store(true, Ordering::SeqCst);
}

unsafe extern "C" {
    /// The C library's `free`, which `caerDeviceDiscover`'s result is released with.
    fn free(ptr: *mut c_void);
}

type DvxInfoGet = unsafe extern "C" fn(caerDeviceHandle) -> caer_dvx_info;
type Discover = unsafe extern "C" fn(i16, *mut *mut u8) -> isize;

/// The identity both info structs share, as `key=value` words.
fn identity(
    serial: &[std::ffi::c_char; 9],
    (firmware, logic, chip): (i16, i16, i16),
    size: (i16, i16),
) -> String {
    let serial: String = serial
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8 as char)
        .collect();
    format!(
        "serial={serial} firmware={firmware} logic={logic} chip={chip} width={} height={}",
        size.0, size.1
    )
}

/// A command run by [`in_child`], in the child process: `stream TYPE MS [reopen]`
/// opens the first camera of that libcaer device type, reads its info, sends libcaer's
/// default configuration, starts the data (non-blocking), reads for MS milliseconds
/// or until the camera is lost, stops and closes it (and with `reopen` tries to open
/// it again); `discover TYPE` reports
/// `caerDeviceDiscover`'s first result. The report goes to `CAER_USB_REPORT`.
#[test]
#[ignore = "a child of the caer_usb tests: runs with the USB stand-in preloaded"]
fn ffi_child() {
    let Ok(command) = std::env::var("CAER_USB_CHILD") else {
        return;
    };
    let library = std::env::var("LIBCAER_PATH").unwrap();
    let words: Vec<&str> = command.split_whitespace().collect();
    let device_type: u16 = words[1].parse().unwrap();
    let mut report = Vec::new();
    match words[0] {
        "stream" => {
            stream_in_child(
                &library,
                device_type,
                Duration::from_millis(words[2].parse().unwrap()),
                &mut report,
            );
            if words.get(3) == Some(&"reopen") {
                let caer = Libcaer::load(Some(&library)).unwrap();
                // SAFETY: plain values; a handle, if any, is closed at once.
                let mut handle =
                    unsafe { (caer.caerDeviceOpen)(2, device_type, 0, 0, std::ptr::null()) };
                report.push(format!("reopen null={}", u8::from(handle.is_null())));
                if !handle.is_null() {
                    // SAFETY: an open handle, closed once.
                    unsafe { (caer.caerDeviceClose)(&mut handle) };
                }
            }
        }
        "discover" => discover_in_child(&library, device_type as i16, &mut report),
        other => panic!("unknown child command {other}"),
    }
    std::fs::write(
        std::env::var("CAER_USB_REPORT").unwrap(),
        report.join("\n") + "\n",
    )
    .unwrap();
}

fn stream_in_child(library: &str, device_type: u16, read_for: Duration, report: &mut Vec<String>) {
    let caer = Libcaer::load(Some(library)).unwrap();
    // SAFETY: plain values; the handle, when not NULL, is closed below.
    let mut handle = unsafe { (caer.caerDeviceOpen)(1, device_type, 0, 0, std::ptr::null()) };
    let errno = std::io::Error::last_os_error().raw_os_error().unwrap_or(0);
    if handle.is_null() {
        report.push(format!("open null=1 errno={errno}"));
        return;
    }
    report.push("open null=0".into());
    if device_type == CAER_DEVICE_DAVIS {
        // SAFETY: an open DAVIS handle; the struct's layout is pinned in libcaer-sys.
        let i: caer_davis_info = unsafe { (caer.caerDavisInfoGet)(handle) };
        let id = identity(
            &i.deviceSerialNumber,
            (i.firmwareVersion, i.logicVersion, i.chipID),
            (i.dvsSizeX, i.dvsSizeY),
        );
        report.push(format!("info {id} address={}", i.deviceUSBDeviceAddress));
    } else {
        // SAFETY: the same library, already loaded; the function has this type
        // (devices/dvxplorer.h line 688), called on an open DVXplorer handle.
        let i: caer_dvx_info = unsafe {
            let lib = libcaer_sys::libloading::Library::new(library).unwrap();
            let get = *lib.get::<DvxInfoGet>(b"caerDVXplorerInfoGet\0").unwrap();
            get(handle)
        };
        let id = identity(
            &i.deviceSerialNumber,
            (i.firmwareVersion, i.logicVersion, i.chipID),
            (i.dvsSizeX, i.dvsSizeY),
        );
        report.push(format!("info {id} address={}", i.deviceUSBDeviceAddress));
    }
    // SAFETY: an open handle and plain values; the shutdown callback writes a static.
    let started = unsafe {
        (caer.caerDeviceSendDefaultConfig)(handle);
        (caer.caerDeviceConfigSet)(handle, -2, 1, 0);
        (caer.caerDeviceDataStart)(
            handle,
            None,
            None,
            std::ptr::null_mut(),
            Some(on_lost),
            std::ptr::null_mut(),
        )
    };
    report.push(format!("start ok={}", u8::from(started)));
    let since = Instant::now();
    let mut events = Vec::new();
    while started && since.elapsed() < read_for && !LOST.load(Ordering::SeqCst) {
        // SAFETY: a started handle; the container is libcaer's, freed by its drop.
        let Some(container) = (unsafe { Container::from_raw((caer.caerDeviceDataGet)(handle)) })
        else {
            std::thread::sleep(Duration::from_millis(1));
            continue;
        };
        for packet in container.packets() {
            // SAFETY: a live packet of a live container.
            unsafe { libcaer_sys::read_polarity_packet(packet, &mut events) };
        }
    }
    report.push(format!(
        "read ms={} lost={}",
        since.elapsed().as_millis(),
        u8::from(LOST.load(Ordering::SeqCst))
    ));
    for e in &events {
        report.push(format!(
            "event {} {} {} {}",
            e.t_us,
            e.x,
            e.y,
            u8::from(e.on)
        ));
    }
    // SAFETY: DataStop only after a successful DataStart; Close once.
    unsafe {
        if started {
            (caer.caerDeviceDataStop)(handle);
        }
        (caer.caerDeviceClose)(&mut handle);
    }
}

fn discover_in_child(library: &str, device_type: i16, report: &mut Vec<String>) {
    // SAFETY: caerDeviceDiscover has this type (devices/device_discover.h line 56); its
    // result is an array it allocated, of which the first entry is read (the stand-in
    // presents one camera at most) and which is freed with the C library's free.
    unsafe {
        let lib = libcaer_sys::libloading::Library::new(library).unwrap();
        let discover = *lib.get::<Discover>(b"caerDeviceDiscover\0").unwrap();
        let mut found: *mut u8 = std::ptr::null_mut();
        let count = discover(device_type, &mut found);
        report.push(format!("discover count={count}"));
        if count > 0 {
            // struct caer_device_discovery_result (lines 29-42): the type, the two
            // error flags, then the union of infos at offset 8.
            let kind = found.cast::<u16>().read_unaligned();
            let (error_open, error_version) = (*found.add(2) != 0, *found.add(3) != 0);
            let id = if kind == CAER_DEVICE_DVXPLORER {
                let i = found.add(8).cast::<caer_dvx_info>().read_unaligned();
                identity(
                    &i.deviceSerialNumber,
                    (i.firmwareVersion, i.logicVersion, i.chipID),
                    (i.dvsSizeX, i.dvsSizeY),
                )
            } else {
                let i = found.add(8).cast::<caer_davis_info>().read_unaligned();
                identity(
                    &i.deviceSerialNumber,
                    (i.firmwareVersion, i.logicVersion, i.chipID),
                    (i.dvsSizeX, i.dvsSizeY),
                )
            };
            report.push(format!(
                "found type={kind} error_open={error_open} error_version={error_version} {id}"
            ));
        }
        if !found.is_null() {
            free(found.cast());
        }
    }
}

// ------------------------------------------------------ each camera, through libcaer

/// A camera the stand-in presents, as libcaer should report it.
struct Camera {
    name: &'static str,
    device_type: u16,
    chip: i64,
    firmware: i64,
    width: u16,
    height: u16,
}

const DAVIS240: Camera = Camera {
    name: "davis240",
    device_type: CAER_DEVICE_DAVIS,
    chip: 2,
    firmware: 4,
    width: 240,
    height: 180,
};

/// One camera through the real libcaer: found by its device type, its info, the
/// encoded events delivered at their pixels and times, and in the stand-in's log the
/// run bits written on by DataStart and off by DataStop, the transfers cancelled,
/// and the device closed.
fn a_camera_streams_through_the_real_libcaer(camera: &Camera) {
    let Some(library) = real_library() else {
        return;
    };
    let run = in_child(
        &library,
        &format!("stream {} 500", camera.device_type),
        &[("USB_STANDIN_CAMERA", camera.name)],
    );
    assert_eq!(run.fields("open")["null"], "0", "{:?}", run.report);
    assert_eq!(run.number("info", "width"), i64::from(camera.width));
    assert_eq!(run.number("info", "height"), i64::from(camera.height));
    assert_eq!(run.number("info", "chip"), camera.chip);
    assert_eq!(run.number("info", "firmware"), camera.firmware);
    assert_eq!(run.number("info", "logic"), 18);
    assert_eq!(run.fields("start")["ok"], "1");

    let delivered = run.delivered();
    let encoded = run.encoded.concat();
    assert_eq!(run.encoded.len(), 1, "one stream, one timestamp reset");
    // In order and unchanged: every delivered event is the encoded one at its place;
    // only those still on the wire when the data stopped are missing at the end.
    assert!(delivered.len() >= 3_000, "{} delivered", delivered.len());
    assert_eq!(delivered[..], encoded[..delivered.len()]);
    assert!(
        encoded.len() - delivered.len() < 200,
        "{} encoded, {} delivered",
        encoded.len(),
        delivered.len()
    );
    assert!(
        delivered
            .iter()
            .all(|e| e.x < camera.width && e.y < camera.height)
    );
    let span_us = delivered.last().unwrap().t_us - delivered[0].t_us;
    say(&format!(
        "{}: {} events in {} ms of device time through libcaer ({:.0} events/s)",
        camera.name,
        delivered.len(),
        span_us / 1000,
        delivered.len() as f64 * 1e6 / span_us as f64
    ));

    let all = assert_sessions_ended_cleanly(&run.log);
    assert_eq!(all.len(), 1, "{all:?}");
    let s = &all[0];
    assert!(s.started && s.stopped, "{s:?}");
    // DataStart turns the IMU (and a DAVIS's APS) on with the DVS.
    for run_bit in IMU_RUNS {
        assert!(s.after_start.contains(&(run_bit.0, run_bit.1, 1)), "{s:?}");
    }
    if camera.device_type == CAER_DEVICE_DAVIS {
        assert!(s.after_start.contains(&(APS_RUN.0, APS_RUN.1, 1)), "{s:?}");
    }
    let cancels = run
        .log
        .iter()
        .filter(|l| l.what() == "cancel" && l.field("endpoint") == Some("0x82"))
        .count();
    assert_eq!(cancels, 8, "libcaer's eight data transfers");
}

#[test]
fn a_davis240_streams_its_encoded_events_through_the_real_libcaer() {
    a_camera_streams_through_the_real_libcaer(&DAVIS240);
}

#[test]
fn a_davis346_streams_its_encoded_events_through_the_real_libcaer() {
    a_camera_streams_through_the_real_libcaer(&Camera {
        name: "davis346",
        device_type: CAER_DEVICE_DAVIS,
        chip: 5,
        firmware: 6,
        width: 346,
        height: 260,
    });
}

#[test]
fn a_dvxplorer_streams_its_encoded_events_through_the_real_libcaer() {
    a_camera_streams_through_the_real_libcaer(&Camera {
        name: "dvxplorer",
        device_type: CAER_DEVICE_DVXPLORER,
        chip: i64::from(libcaer_sys::DVXPLORER_CHIP_ID),
        firmware: 8,
        width: 640,
        height: 480,
    });
}

#[test]
fn a_dvxplorer_lite_streams_its_encoded_events_through_the_real_libcaer() {
    a_camera_streams_through_the_real_libcaer(&Camera {
        name: "dvxplorer-lite",
        device_type: CAER_DEVICE_DVXPLORER,
        chip: i64::from(libcaer_sys::DVXPLORER_LITE_CHIP_ID),
        firmware: 8,
        width: 320,
        height: 240,
    });
}

/// A DAVIS346 is not a DVXplorer, nor a DVXplorer a DAVIS: libcaer opens a camera by
/// its family's VID:PID only.
#[test]
fn libcaer_opens_a_camera_only_as_its_own_family() {
    let Some(library) = real_library() else {
        return;
    };
    let run = in_child(
        &library,
        &format!("stream {CAER_DEVICE_DVXPLORER} 10"),
        &[("USB_STANDIN_CAMERA", "davis346")],
    );
    assert_eq!(run.fields("open")["null"], "1");
    let run = in_child(
        &library,
        &format!("stream {CAER_DEVICE_DAVIS} 10"),
        &[("USB_STANDIN_CAMERA", "dvxplorer")],
    );
    assert_eq!(run.fields("open")["null"], "1");
    assert!(
        run.log.iter().all(|l| l.what() != "open"),
        "nothing of another family is even opened"
    );
}

/// A stream that starts 0.4 s before the device clock's 31-bit wrap crosses it in
/// libcaer's packets (the overflow counter in the packet header) without a step: the
/// delivered times are the encoded ones, on both sides of 2^31 us.
#[test]
fn the_31_bit_timestamp_wrap_crosses_cleanly_through_the_real_libcaer() {
    let Some(library) = real_library() else {
        return;
    };
    let start_us = (1i64 << 31) - 400_000;
    let run = in_child(
        &library,
        &format!("stream {CAER_DEVICE_DAVIS} 800"),
        &[("USB_STANDIN_CLOCK_START_US", &start_us.to_string())],
    );
    let delivered = run.delivered();
    let encoded = run.encoded.concat();
    assert_eq!(delivered[..], encoded[..delivered.len()]);
    let wrap = 1i64 << 31;
    let before = delivered.iter().filter(|e| e.t_us < wrap).count();
    let after = delivered.len() - before;
    assert!(
        before > 1_000 && after > 1_000,
        "{before} before, {after} after"
    );
    assert!(delivered.windows(2).all(|w| w[1].t_us > w[0].t_us));
}

/// Unplugged while streaming: the transfers in flight end with NO_DEVICE, libcaer
/// calls the shutdown callback, DataGet gives no more; the camera is then gone.
#[test]
fn an_unplugged_camera_ends_libcaers_stream_and_is_gone() {
    let Some(library) = real_library() else {
        return;
    };
    let run = in_child(
        &library,
        &format!("stream {CAER_DEVICE_DAVIS} 3000 reopen"),
        &[("USB_STANDIN_UNPLUG_MS", "300")],
    );
    assert_eq!(run.fields("reopen")["null"], "1", "the camera is gone");
    let lists: Vec<&str> = run
        .log
        .iter()
        .filter(|l| l.what() == "device-list")
        .filter_map(|l| l.field("count"))
        .collect();
    assert_eq!(lists.last(), Some(&"0"), "{lists:?}");
    assert_eq!(run.fields("read")["lost"], "1", "{:?}", run.fields("read"));
    assert!(run.number("read", "ms") < 1_000);
    let no_device = run
        .log
        .iter()
        .filter(|l| l.what() == "complete" && l.field("status") == Some("NO_DEVICE"))
        .count();
    assert_eq!(no_device, 8, "each data transfer in flight");
    let delivered = run.delivered();
    assert!(delivered.len() > 1_000);
    assert_eq!(delivered[..], run.encoded.concat()[..delivered.len()]);
    // Started, lost, then stopped and closed as faithd does it.
    let all = assert_sessions_ended_cleanly(&run.log);
    assert_eq!(all.len(), 1);
    assert!(all[0].lost && all[0].stopped);
}

// ----------------------------------------------------------- cameras libcaer refuses

/// (case, stand-in variables, deviceErrorOpen, deviceErrorVersion).
type DiscoverCase = (
    &'static str,
    &'static [(&'static str, &'static str)],
    bool,
    bool,
);

/// Each camera libcaer cannot use: what `caerDeviceDiscover` says of it (its error
/// fields), and that `caerDeviceOpen` does not open it (with its errno).
#[test]
fn discover_names_the_cameras_libcaer_cannot_use() {
    let Some(library) = real_library() else {
        return;
    };
    let cases: [DiscoverCase; 6] = [
        ("usable", &[], false, false),
        ("firmware 3", &[("USB_STANDIN_FIRMWARE", "3")], false, true),
        ("logic 17", &[("USB_STANDIN_LOGIC", "17")], false, true),
        (
            "logic patch 0",
            &[("USB_STANDIN_LOGIC_PATCH", "0")],
            false,
            true,
        ),
        (
            "no permission",
            &[("USB_STANDIN_FAULT", "access")],
            true,
            false,
        ),
        // Discovery opens without claiming, so a camera another program holds looks
        // usable to it; only the open that claims it fails.
        ("busy", &[("USB_STANDIN_FAULT", "busy")], false, false),
    ];
    for (case, env, error_open, error_version) in cases {
        let run = in_child(&library, &format!("discover {CAER_DEVICE_DAVIS}"), env);
        assert_eq!(run.number("discover", "count"), 1, "{case}");
        let found = run.fields("found");
        assert_eq!(found["type"], CAER_DEVICE_DAVIS.to_string(), "{case}");
        assert_eq!(found["error_open"], error_open.to_string(), "{case}");
        assert_eq!(found["error_version"], error_version.to_string(), "{case}");
        if !error_open {
            assert_eq!(found["width"], "240", "{case}");
        }
        let run = in_child(&library, &format!("stream {CAER_DEVICE_DAVIS} 50"), env);
        let opened = run.fields("open")["null"] == "0";
        assert_eq!(opened, case == "usable", "{case}: {:?}", run.report);
        let errno = run.fields("open").get("errno").cloned().unwrap_or_default();
        say(&format!(
            "{case}: deviceErrorOpen={error_open} deviceErrorVersion={error_version}, caerDeviceOpen {}",
            if opened {
                "opens it".to_string()
            } else {
                format!("refuses it (errno {errno})")
            }
        ));
        assert_sessions_ended_cleanly(&run.log);
    }
    // caerDeviceOpen's errno names the cause only where libcaer tried one kind of
    // board last: a DAVIS open tries the FX2 PID, then the FX3 one, whose "nothing
    // found" (CAER_ERROR_OPEN_ACCESS, -3) replaces an FX2 DAVIS240's version error.
    // (camera, libcaer device type, stand-in variable, errno)
    let errnos: [(&str, u16, (&str, &str), &str); 4] = [
        (
            "davis240",
            CAER_DEVICE_DAVIS,
            ("USB_STANDIN_LOGIC", "17"),
            "-3",
        ),
        (
            "davis346",
            CAER_DEVICE_DAVIS,
            ("USB_STANDIN_LOGIC", "17"),
            "-6",
        ),
        (
            "dvxplorer",
            CAER_DEVICE_DVXPLORER,
            ("USB_STANDIN_LOGIC", "17"),
            "-6",
        ),
        (
            "dvxplorer",
            CAER_DEVICE_DVXPLORER,
            ("USB_STANDIN_FIRMWARE", "7"),
            "-5",
        ),
    ];
    for (camera, device_type, fault, errno) in errnos {
        let run = in_child(
            &library,
            &format!("stream {device_type} 10"),
            &[("USB_STANDIN_CAMERA", camera), fault],
        );
        assert_eq!(run.fields("open")["errno"], errno, "{camera} {fault:?}");
    }
    // libcaer 3.3.15 takes a newer firmware but only its own logic version.
    let newer = in_child(
        &library,
        &format!("stream {CAER_DEVICE_DAVIS} 10"),
        &[("USB_STANDIN_FIRMWARE", "5")],
    );
    assert_eq!(newer.fields("open")["null"], "0", "firmware 5");
    let newer = in_child(
        &library,
        &format!("stream {CAER_DEVICE_DAVIS} 10"),
        &[("USB_STANDIN_LOGIC", "19")],
    );
    assert_eq!(newer.fields("open")["null"], "1", "logic 19");
}

// ------------------------------------------------------------------ faithd run

/// The real libcaer's path for `faithd run` tests, or `None` (and one line): also
/// when the faithd under test is another architecture's build (`FAITHD_UNDER_TEST`),
/// which could load neither this libcaer nor this stand-in.
fn real_library_for_faithd() -> Option<String> {
    if common::faithd_under_test().is_some() {
        say(
            "skipped: FAITHD_UNDER_TEST names another build; the USB stand-in and libcaer are this one's",
        );
        return None;
    }
    real_library()
}

/// `faithd run` with the real libcaer and the stand-in preloaded, against the mock
/// autopilot, recording its flight.
struct Faithd {
    child: std::process::Child,
    dir: common::TempDir,
    _autopilot: common::autopilot::MockAutopilot,
}

impl Faithd {
    /// `source_lines` go into `[source]`; `tail` (whole tables) at the end.
    fn start(
        tag: &str,
        library: &str,
        source_lines: &str,
        tail: &str,
        env: &[(&str, &str)],
    ) -> Self {
        use common::autopilot::{Controls, MockAutopilot};
        let autopilot = MockAutopilot::start(std::sync::Arc::new(Controls::default()));
        let dir = common::TempDir::new(tag);
        let config = dir.0.join("faithd.toml");
        let record = format!("dir = \"{}\"", dir.0.join("flights").display());
        let toml = autopilot.service_toml(library, &record).replace(
            "kind = \"caer\"\n",
            &format!("kind = \"caer\"\n{source_lines}"),
        ) + tail;
        std::fs::write(&config, toml).unwrap();
        let child = common::faithd()
            .args(["run", "--config"])
            .arg(&config)
            .env("RUST_LOG", "info")
            .env("LD_PRELOAD", USB_STANDIN)
            .env("USB_STANDIN_LOG", dir.0.join("standin.log"))
            .env("USB_STANDIN_EVENTS", dir.0.join("events"))
            .envs(env.iter().copied())
            .stdout(std::process::Stdio::null())
            .stderr(std::fs::File::create(dir.0.join("faithd.log")).unwrap())
            .spawn()
            .unwrap();
        Faithd {
            child,
            dir,
            _autopilot: autopilot,
        }
    }

    fn journal(&self) -> String {
        std::fs::read_to_string(self.dir.0.join("faithd.log")).unwrap_or_default()
    }

    fn standin(&self) -> Vec<Line> {
        read_log(&self.dir.0.join("standin.log"))
    }

    fn encoded(&self) -> Vec<Vec<Encoded>> {
        read_encoded(&self.dir.0.join("events"))
    }

    /// Waits (up to `timeout`) until the journal satisfies `ready`.
    fn wait_for(&self, timeout: Duration, ready: impl Fn(&str) -> bool) -> bool {
        common::poll_until(timeout, || ready(&self.journal()))
    }

    /// Waits for the process to end by itself (up to `timeout`).
    fn wait_exit(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Some(status) = self.child.try_wait().unwrap() {
                return Some(status);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        None
    }

    /// SIGTERM; the exit status and how long it took to come.
    fn sigterm(&mut self) -> (ExitStatus, Duration) {
        let signalled = Instant::now();
        let _ = nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(self.child.id() as i32),
            nix::sys::signal::Signal::SIGTERM,
        );
        let status = self.child.wait().unwrap();
        (status, signalled.elapsed())
    }

    /// The events of the flight's recording (AEDAT 4.0, daemon clock).
    fn recorded(&self) -> Vec<Event> {
        let dir = self.dir.0.join("flights");
        let aedat: PathBuf = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.extension().is_some_and(|e| e == "aedat4"))
            .expect("an event recording");
        let mut reader = faithd_formats::events::open_events(aedat).unwrap();
        faithd_formats::events::read_all(&mut reader).unwrap()
    }
}

impl Drop for Faithd {
    fn drop(&mut self) {
        if self.child.try_wait().unwrap().is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Within this of SIGTERM faithd has released the roll, stopped the camera and exited.
const EXIT_WITHIN: Duration = Duration::from_millis(1000);

fn streaming(journal: &str) -> bool {
    journal.contains("camera open: streaming") && journal.contains("ready:")
}

/// How a recording matched the encoded events.
struct Matched {
    events: usize,
    /// Encoded events missing between matched ones (a batch the pipeline dropped).
    skipped: usize,
    /// Each event's daemon time minus its device time, above the least of them (the
    /// clock mapping's lower envelope): at the 99th percentile and at worst.
    p99_us: i64,
    worst_us: i64,
}

/// Matches the recording to the encoded events: each recorded event must be the next
/// encoded one with its pixel and polarity (a gap where a batch was dropped), and
/// its daemon time its device time on the mapped clock (see [`Matched`]).
fn match_recording(recorded: &[Event], encoded: &[Encoded]) -> Matched {
    let mut at = 0;
    let mut skipped = 0;
    let mut offsets = Vec::with_capacity(recorded.len());
    for (k, e) in recorded.iter().enumerate() {
        let on = e.polarity == Polarity::On;
        let start = at;
        while at < encoded.len()
            && (encoded[at].x, encoded[at].y, encoded[at].on) != (e.x_px, e.y_px, on)
        {
            at += 1;
        }
        assert!(
            at < encoded.len(),
            "recorded event {k} {e:?} is not among the encoded ones after {start}"
        );
        skipped += at - start;
        offsets.push(e.t_us - encoded[at].t_us);
        at += 1;
    }
    let least = offsets.iter().copied().min().unwrap_or(0);
    let mut above: Vec<i64> = offsets.iter().map(|o| o - least).collect();
    above.sort_unstable();
    Matched {
        events: recorded.len(),
        skipped,
        p99_us: above.get(above.len() * 99 / 100).copied().unwrap_or(0),
        worst_us: above.last().copied().unwrap_or(0),
    }
}

/// The recorded times are the device's on the daemon clock: within 3 ms of the
/// mapping's envelope for 99 % of the events (the USB latency the mapping removes
/// varies by about the 1 ms early-packet delay and libcaer's 1 ms polling), and
/// within 50 ms for all (the first containers, before the envelope settles, on a
/// loaded machine).
fn assert_on_the_device_clock(m: &Matched) {
    assert!(
        m.p99_us <= 3_000 && m.worst_us <= 50_000,
        "99 % within {} us, all within {} us",
        m.p99_us,
        m.worst_us
    );
}

/// `faithd run` streams a camera's encoded events into its flight recording, turns
/// the APS and the IMU off after DataStart (the stand-in's log), and on SIGTERM stops
/// and closes it and exits 0 at once.
fn faithd_streams(camera: &Camera, source_lines: &str, tail: &str) {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let mut faithd = Faithd::start(
        &format!("usb-{}", camera.name),
        &library,
        source_lines,
        tail,
        &[("USB_STANDIN_CAMERA", camera.name)],
    );
    assert!(
        faithd.wait_for(Duration::from_secs(10), streaming),
        "{}",
        faithd.journal()
    );
    std::thread::sleep(Duration::from_millis(1_200));
    let (status, took) = faithd.sigterm();
    let journal = faithd.journal();
    say(&format!(
        "faithd run, {} streaming: SIGTERM to exit {} ms",
        camera.name,
        took.as_millis()
    ));
    assert_eq!(status.code(), Some(0), "{journal}");
    assert!(took < EXIT_WITHIN, "{took:?}\n{journal}");
    assert!(journal.contains("camera stopped and closed"), "{journal}");

    let log = faithd.standin();
    let all = assert_sessions_ended_cleanly(&log);
    assert_eq!(all.len(), 1, "{all:?}");
    let after = &all[0].after_start;
    // DataStart wrote the APS and IMU run bits on; faithd wrote them off after it.
    let mut apsimu = IMU_RUNS.to_vec();
    if camera.device_type == CAER_DEVICE_DAVIS {
        apsimu.push(APS_RUN);
    }
    for (m, p) in apsimu {
        let on = after.iter().position(|&w| w == (m, p, 1));
        let off = after.iter().position(|&w| w == (m, p, 0));
        assert!(
            matches!((on, off), (Some(a), Some(b)) if a < b),
            "{m}.{p}: on at {on:?}, off at {off:?} among {after:?}"
        );
    }

    let recorded = faithd.recorded();
    let encoded = faithd.encoded();
    assert_eq!(encoded.len(), 1);
    let m = match_recording(&recorded, &encoded[0]);
    let (matched, skipped) = (m.events, m.skipped);
    let span_s = (recorded.last().unwrap().t_us - recorded[0].t_us) as f64 / 1e6;
    say(&format!(
        "faithd run, {}: {matched} events recorded at their encoded pixels and times ({:.0}/s, 99 % within {} us of the device's clock, all within {} us), {skipped} skipped",
        camera.name,
        matched as f64 / span_s,
        m.p99_us,
        m.worst_us
    ));
    assert_on_the_device_clock(&m);
    assert!(matched >= 8_000, "{matched} recorded");
    assert_eq!(skipped, 0, "no batch dropped at 10,000 events/s");
}

#[test]
fn faithd_run_records_a_davis240s_encoded_events_and_turns_its_aps_and_imu_off() {
    faithd_streams(&DAVIS240, "", "");
}

#[test]
fn faithd_run_records_a_davis346s_encoded_events() {
    faithd_streams(
        &Camera {
            name: "davis346",
            device_type: CAER_DEVICE_DAVIS,
            chip: 5,
            firmware: 6,
            width: 346,
            height: 260,
        },
        "device = \"davis346\"\n",
        "[pipeline.camera]\nwidth_px = 346\nheight_px = 260\nfx_px = 280.0\nfy_px = 280.0\ncx_px = 172.5\ncy_px = 129.5\n",
    );
}

#[test]
fn faithd_run_records_a_dvxplorers_encoded_events() {
    faithd_streams(
        &Camera {
            name: "dvxplorer",
            device_type: CAER_DEVICE_DVXPLORER,
            chip: 20,
            firmware: 8,
            width: 640,
            height: 480,
        },
        "device = \"dvxplorer\"\n",
        "[pipeline.camera]\nwidth_px = 640\nheight_px = 480\nfx_px = 520.0\nfy_px = 520.0\ncx_px = 319.5\ncy_px = 239.5\n",
    );
}

/// A dark scene (no events for a second, the clock's wrap words still coming) is not
/// a lost camera: the session goes on, and the events after the dark are recorded.
#[test]
fn faithd_run_survives_a_dark_scene_and_streams_after_it() {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let mut faithd = Faithd::start(
        "usb-dark",
        &library,
        "",
        "",
        &[("USB_STANDIN_DARK_MS", "300-1300")],
    );
    assert!(faithd.wait_for(Duration::from_secs(10), streaming));
    // The stream started some 0.3 s before "streaming" (libcaer's waits in DataStart).
    std::thread::sleep(Duration::from_millis(1_600));
    let (status, _) = faithd.sigterm();
    let journal = faithd.journal();
    assert_eq!(status.code(), Some(0), "{journal}");
    assert!(!journal.contains("camera lost"), "{journal}");
    let encoded = faithd.encoded();
    assert_eq!(encoded.len(), 1, "one stream: never reopened");
    let recorded = faithd.recorded();
    let m = match_recording(&recorded, &encoded[0]);
    assert_on_the_device_clock(&m);
    let matched = m.events;
    let gap_us = recorded
        .windows(2)
        .map(|w| w[1].t_us - w[0].t_us)
        .max()
        .unwrap();
    assert!(
        (900_000..1_200_000).contains(&gap_us),
        "the dark lasted {gap_us} us in the recording"
    );
    let after_dark = recorded
        .iter()
        .filter(|e| e.t_us > recorded[0].t_us + 1_000_000)
        .count();
    assert!(
        after_dark > 1_000,
        "{after_dark} events after the dark of {matched}"
    );
    assert_sessions_ended_cleanly(&faithd.standin());
}

/// Unplugged while streaming and plugged back half a second later: faithd says the
/// camera is lost, reopens it when it is back and streams again (a second stream in
/// the stand-in's log, and its events in the recording).
#[test]
fn faithd_run_streams_again_after_the_camera_is_unplugged_and_plugged_back() {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let mut faithd = Faithd::start(
        "usb-replug",
        &library,
        "",
        "",
        &[
            ("USB_STANDIN_UNPLUG_MS", "500"),
            ("USB_STANDIN_REPLUG_MS", "1000"),
        ],
    );
    assert!(
        faithd.wait_for(Duration::from_secs(10), |j| j
            .matches("camera open: streaming")
            .count()
            >= 2),
        "{}",
        faithd.journal()
    );
    std::thread::sleep(Duration::from_millis(400));
    let (status, took) = faithd.sigterm();
    let journal = faithd.journal();
    assert_eq!(status.code(), Some(0), "{journal}");
    assert!(took < EXIT_WITHIN, "{took:?}");
    assert!(journal.contains("camera lost"), "{journal}");

    let log = faithd.standin();
    let all = assert_sessions_ended_cleanly(&log);
    let started: Vec<&Session> = all.iter().filter(|s| s.started).collect();
    assert_eq!(started.len(), 2, "{all:?}");
    let at = |what: &str| log.iter().find(|l| l.what() == what).map(|l| l.ms).unwrap();
    let replug_ms = at("replug");
    let second_start_ms = writes(&log)
        .iter()
        .filter(|&&(_, m, p, v)| (m, p, v) == (DVS_RUN.0, DVS_RUN.1, 1))
        .map(|&(i, ..)| log[i].ms)
        .nth(1)
        .unwrap();
    say(&format!(
        "faithd run: camera lost {:.0} ms after the unplug, streaming again {:.0} ms after the replug",
        log.iter()
            .find(|l| l.what() == "release")
            .map_or(f64::NAN, |l| l.ms - at("unplug")),
        second_start_ms - replug_ms
    ));
    assert!(second_start_ms - replug_ms < 3_000.0);
    let encoded = faithd.encoded();
    assert_eq!(encoded.len(), 2, "two streams");
    // Both streams play the same scene from the same clock: the recording splits at
    // its one long silence, the camera's absence.
    let recorded = faithd.recorded();
    let split = (1..recorded.len())
        .max_by_key(|&k| recorded[k].t_us - recorded[k - 1].t_us)
        .unwrap();
    let (first, second) = recorded.split_at(split);
    assert!(second[0].t_us - first.last().unwrap().t_us > 500_000);
    assert_on_the_device_clock(&match_recording(first, &encoded[0]));
    let m = match_recording(second, &encoded[1]);
    assert_on_the_device_clock(&m);
    let matched = m.events;
    assert!(matched > 1_000, "{matched} events after the replug");
}

/// A setting the camera refuses (the device stalls the request) stops faithd with
/// exit code 2 naming `source.caer_settings`; the started camera was stopped and
/// closed first.
#[test]
fn faithd_run_stops_with_exit_2_on_a_setting_the_camera_refuses() {
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let mut faithd = Faithd::start(
        "usb-refused",
        &library,
        "caer_settings = [[5, 2, 16399], [5, 1, 24575]]\n",
        "",
        &[("USB_STANDIN_REFUSE", "5:1")],
    );
    let status = faithd
        .wait_exit(Duration::from_secs(10))
        .expect("faithd keeps running with a refused setting");
    let journal = faithd.journal();
    assert_eq!(status.code(), Some(2), "{journal}");
    assert!(
        journal.contains("`source.caer_settings`: entry [1] = [5, 1, 24575] refused by libcaer"),
        "{journal}"
    );
    let log = faithd.standin();
    assert!(
        log.iter().any(|l| l.words.contains(&"refuse".to_string())
            && l.words.contains(&"5.1=24575".to_string())),
        "the device refused the write"
    );
    let all = assert_sessions_ended_cleanly(&log);
    assert_eq!(all.len(), 1, "no retry: {all:?}");
    assert!(all[0].started && all[0].stopped);
}

/// The device clock 0.5 s before its 31-bit wrap: faithd's recording crosses it
/// without a step or a re-seeded clock.
#[test]
fn faithd_run_crosses_the_31_bit_timestamp_wrap_cleanly() {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let start_us = (1i64 << 31) - 500_000;
    let mut faithd = Faithd::start(
        "usb-wrap",
        &library,
        "",
        "",
        &[("USB_STANDIN_CLOCK_START_US", &start_us.to_string())],
    );
    assert!(faithd.wait_for(Duration::from_secs(10), streaming));
    std::thread::sleep(Duration::from_millis(1_200));
    let (status, _) = faithd.sigterm();
    let journal = faithd.journal();
    assert_eq!(status.code(), Some(0), "{journal}");
    assert!(!journal.contains("afresh"), "{journal}");
    let encoded = faithd.encoded();
    let wrap = 1i64 << 31;
    assert!(
        encoded[0].first().unwrap().t_us < wrap && encoded[0].last().unwrap().t_us > wrap + 300_000
    );
    let recorded = faithd.recorded();
    let m = match_recording(&recorded, &encoded[0]);
    assert_on_the_device_clock(&m);
    let (matched, skipped) = (m.events, m.skipped);
    assert!(
        matched > 8_000 && skipped == 0,
        "{matched} matched, {skipped} skipped"
    );
}

/// SIGTERM in every state the camera can be in: retrying without a camera, streaming
/// (`faithd_streams`), in a dark scene. Each exits 0 at once; a started camera is
/// stopped (DataStop) and every opened one closed, in the stand-in's log.
#[test]
fn faithd_run_exits_at_once_on_sigterm_while_retrying_without_a_camera() {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let mut faithd = Faithd::start(
        "usb-none",
        &library,
        "",
        "",
        &[("USB_STANDIN_CAMERA", "none")],
    );
    assert!(faithd.wait_for(Duration::from_secs(10), |j| {
        j.matches("no DAVIS240 on USB").count() >= 2
    }));
    let (status, took) = faithd.sigterm();
    let journal = faithd.journal();
    say(&format!(
        "faithd run, no camera: SIGTERM to exit {} ms",
        took.as_millis()
    ));
    assert_eq!(status.code(), Some(0), "{journal}");
    assert!(took < EXIT_WITHIN, "{took:?}\n{journal}");
    assert!(
        journal.contains("camera: stopped while waiting to retry"),
        "{journal}"
    );
    let log = faithd.standin();
    assert!(log.iter().any(|l| l.what() == "device-list"));
    assert!(
        log.iter().all(|l| l.what() != "open"),
        "no camera, nothing opened"
    );
    assert!(assert_sessions_ended_cleanly(&log).is_empty());
}

/// A camera another program holds: libcaer opens it, cannot claim it, closes it;
/// faithd keeps trying and stops at once on SIGTERM, nothing left open.
#[test]
fn faithd_run_exits_at_once_on_sigterm_while_retrying_a_busy_camera() {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let mut faithd = Faithd::start(
        "usb-busy",
        &library,
        "",
        "",
        &[("USB_STANDIN_FAULT", "busy")],
    );
    assert!(faithd.wait_for(Duration::from_secs(10), |j| {
        j.matches("libcaer could not claim it: another program has it open")
            .count()
            >= 2
    }));
    let (status, took) = faithd.sigterm();
    let journal = faithd.journal();
    say(&format!(
        "faithd run, busy camera: SIGTERM to exit {} ms",
        took.as_millis()
    ));
    assert_eq!(status.code(), Some(0), "{journal}");
    assert!(took < EXIT_WITHIN, "{took:?}\n{journal}");
    let log = faithd.standin();
    let claims = log
        .iter()
        .filter(|l| l.what() == "claim" && l.field("result") == Some("-6"))
        .count();
    assert!(claims >= 2, "{claims} claims refused");
    assert!(assert_sessions_ended_cleanly(&log).is_empty());
}

#[test]
fn faithd_run_exits_at_once_on_sigterm_in_a_dark_scene() {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let mut faithd = Faithd::start(
        "usb-dark-sigterm",
        &library,
        "",
        "",
        &[("USB_STANDIN_DARK_MS", "200-")],
    );
    assert!(faithd.wait_for(Duration::from_secs(10), streaming));
    std::thread::sleep(Duration::from_millis(700));
    let (status, took) = faithd.sigterm();
    let journal = faithd.journal();
    say(&format!(
        "faithd run, dark scene: SIGTERM to exit {} ms",
        took.as_millis()
    ));
    assert_eq!(status.code(), Some(0), "{journal}");
    assert!(took < EXIT_WITHIN, "{took:?}\n{journal}");
    assert!(journal.contains("camera stopped and closed"), "{journal}");
    let all = assert_sessions_ended_cleanly(&faithd.standin());
    assert_eq!(all.len(), 1);
    assert!(all[0].started && all[0].stopped);
}

/// (case, the stand-in's variables, what faithd's journal says).
type UnusableCase = (
    &'static str,
    &'static [(&'static str, &'static str)],
    &'static str,
);

/// A camera the real libcaer cannot use: faithd's journal names the cause, from
/// libcaer's own discovery, and the fix, and keeps trying; nothing is left open. The
/// stand-in presents each cause as a camera shows it on USB.
#[test]
fn faithd_run_names_why_a_camera_cannot_be_used_and_the_fix() {
    let _cpu = common::cpu::timed();
    let Some(library) = real_library_for_faithd() else {
        return;
    };
    let cases: [UnusableCase; 6] = [
        (
            "firmware too old",
            &[("USB_STANDIN_FIRMWARE", "3")],
            "a DAVIS240 is on USB (bus 1, address 5) but its firmware (3) or logic (18) is not the version this libcaer requires",
        ),
        (
            "logic not libcaer's",
            &[("USB_STANDIN_LOGIC", "17")],
            "but its firmware (4) or logic (17) is not the version this libcaer requires: update the camera's firmware",
        ),
        (
            "no permission",
            &[("USB_STANDIN_FAULT", "access")],
            "a DAVIS camera is on USB (bus 1, address 5) but could not be opened: no permission on its device node (install the udev rule",
        ),
        (
            "busy",
            &[("USB_STANDIN_FAULT", "busy")],
            "a DAVIS240 is on USB (bus 1, address 5) but libcaer could not claim it: another program has it open",
        ),
        (
            "none",
            &[("USB_STANDIN_CAMERA", "none")],
            "no DAVIS240 on USB (source.device = \"davis240\"): plug it in",
        ),
        (
            "a DVXplorer where a DAVIS240 is configured",
            &[("USB_STANDIN_CAMERA", "dvxplorer")],
            "no DAVIS240 on USB (source.device = \"davis240\")",
        ),
    ];
    for (case, env, said) in cases {
        let mut faithd = Faithd::start("usb-unusable", &library, "", "", env);
        let told = faithd.wait_for(Duration::from_secs(10), |j| j.contains(said));
        let (status, _) = faithd.sigterm();
        let journal = faithd.journal();
        assert!(told, "{case}: {journal}");
        say(&format!(
            "{case}: {}",
            journal
                .lines()
                .find(|l| l.contains(said))
                .unwrap_or_default()
        ));
        assert_eq!(status.code(), Some(0), "{case}: {journal}");
        assert!(!journal.contains("camera open: streaming"), "{case}");
        let sessions = assert_sessions_ended_cleanly(&faithd.standin());
        assert!(
            sessions.iter().all(|s| !s.started),
            "{case}: nothing started"
        );
    }
}
