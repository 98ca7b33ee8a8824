//! faithd against iniVation's real libcaer 3.x: in CI (and with
//! `LIBCAER_PATH=$(bash tests/peers/libcaer-wheel)`) libcaer 3.3.15 from the
//! event-camera-drivers wheel on PyPI, unzipped beside the build, or a libcaer the
//! person running the tests built from iniVation's public source (nothing of libcaer
//! is in this repository: no code, no binary, no recipe). Two variables point at it:
//!
//! - `LIBCAER_PATH`: the shared library (`.../lib/libcaer.so.3`);
//! - `LIBCAER_INCLUDE`: its headers' directory (the one holding `libcaer/`), for the
//!   test that builds containers with libcaer's own inline allocators.
//!
//! Without them each test says in one line that it is skipped and passes. With them:
//! the library exports every symbol faithd loads and none of the container functions
//! its headers make static inline; a session with no camera plugged in is a clean
//! "no camera" (and `faithd run` says so and stops on SIGTERM with status 0); and
//! containers built by libcaer's own inline code (compiled at test time from a C file
//! this test writes) read through faithd's reader to the events libcaer's own getters
//! read.

// Calls into libcaer (the mock, or the real library) and reads the memory it
// hands over: foreign code, so `unsafe`, each block with why it holds.
#![allow(unsafe_code)]

use crate::common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use faithd::clock::DaemonClock;
use faithd::shutdown::Shutdown;
use faithd::source::CaerDevice;
use faithd::source::SourceIo;
use faithd::source::caer::{Camera, Ended, SensorSize, SessionError, no_camera, serve_device};
use libcaer_sys::{Container, INLINE_IN_LIBCAER, LOADED_SYMBOLS, Libcaer};

/// One line on the real standard error (the harness captures `eprintln!`).
fn skipped(why: &str) {
    let _ = writeln!(std::io::stderr(), "skipped: {why}");
}

/// The real libcaer's path, or `None` (and one line saying the test is skipped).
fn real_library() -> Option<String> {
    let path = crate::common::peers::libcaer_path();
    if path.is_none() {
        skipped(if cfg!(all(target_os = "linux", target_arch = "x86_64")) {
            "no libcaer: run `bash tests/peers/prepare` (it fetches libcaer 3.3.15) or set LIBCAER_PATH (docs/camera.md)"
        } else {
            "LIBCAER_PATH is not set, and there is no libcaer wheel for this architecture (x86-64 only): build libcaer for it (docs/camera.md)"
        });
    }
    path
}

#[test]
fn the_real_library_exports_every_symbol_faithd_loads_and_no_inline_one() {
    let Some(path) = real_library() else { return };
    for symbol in LOADED_SYMBOLS {
        assert!(
            libcaer_sys::exports(&path, symbol).unwrap(),
            "{path} does not export {symbol}"
        );
    }
    for symbol in INLINE_IN_LIBCAER {
        assert!(
            !libcaer_sys::exports(&path, symbol).unwrap(),
            "{path} exports {symbol}: not the libcaer 3.x faithd was written for"
        );
    }
    Libcaer::load(Some(&path)).expect("faithd loads the real libcaer");
}

/// With no camera plugged in, a session is a "no camera" to retry, and nothing
/// crashes (no DataStop on what never started). With a camera, it streams until the
/// pipeline hangs up (the receiver is gone before the first batch).
#[test]
fn a_session_on_the_real_library_without_a_camera_is_a_clean_no_camera() {
    let Some(path) = real_library() else { return };
    let lib = Libcaer::load(Some(&path)).unwrap();
    let (tx, rx) = std::sync::mpsc::sync_channel(1);
    drop(rx);
    let dvs240 = Camera {
        device: CaerDevice::Davis240,
        settings: Vec::new(),
        expected: SensorSize {
            width_px: 240,
            height_px: 180,
        },
    };
    let result = serve_device(
        &lib,
        &dvs240,
        &SourceIo {
            clock: DaemonClock::start(),
            batches: tx.clone(),
            stop: Shutdown::new().handle(),
        },
    );
    match result {
        Err(SessionError::Retry(why)) => assert_eq!(why, no_camera(CaerDevice::Davis240)),
        Ok(Ended::Receiver) => {
            skipped("a camera is plugged in: it streamed, no 'no camera' to check")
        }
        other => panic!("{other:?}"),
    }
}

/// `faithd run` with `source.libcaer_path` at the real library: it loads it, says
/// there is no camera (and keeps trying), and stops cleanly on SIGTERM, at once.
#[test]
fn faithd_run_loads_the_real_library_and_reports_no_camera() {
    let Some(path) = real_library() else { return };
    use common::autopilot::{Controls, MockAutopilot};
    let mock = MockAutopilot::start(std::sync::Arc::new(Controls::default()));
    let dir = common::TempDir::new("caer-real");
    let config = dir.0.join("faithd.toml");
    std::fs::write(&config, mock.service_toml(&path, "enabled = false")).unwrap();
    let log = dir.0.join("faithd.log");
    let mut child = crate::common::faithd()
        .args(["run", "--config"])
        .arg(&config)
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let said = common::poll_until(Duration::from_secs(10), || {
        std::fs::read_to_string(&log).is_ok_and(|t| {
            t.matches(&no_camera(CaerDevice::Davis240)).count() >= 2
                || t.contains("camera open: streaming")
        })
    });
    let signalled = std::time::Instant::now();
    let _ = nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    );
    let status = child.wait().unwrap();
    let took = signalled.elapsed();
    let text = std::fs::read_to_string(&log).unwrap();
    let _ = writeln!(
        std::io::stderr(),
        "real libcaer, no camera: SIGTERM to exit {} ms",
        took.as_millis()
    );
    if std::env::var_os("FAITHD_SHOW_JOURNAL").is_some() {
        let _ = writeln!(std::io::stderr(), "{text}");
    }
    assert!(said, "{text}");
    assert!(text.contains("libcaer loaded"), "{text}");
    assert_eq!(status.code(), Some(0), "{text}");
    // Waiting between attempts to open, the camera thread hears the stop at once
    // (it used to sleep out its backoff and be given up after 1 s, never joined).
    if !text.contains("camera open: streaming") {
        assert!(
            text.contains("camera: stopped while waiting to retry"),
            "{text}"
        );
    }
    assert!(!text.contains("did not stop within"), "{text}");
    assert!(took < Duration::from_millis(1000), "{took:?}\n{text}");
}

/// This test's own C, compiled against the real headers: containers built with
/// libcaer's inline allocators and setters, and the valid polarity events as
/// libcaer's own iterators and getters read them.
const BUILDER_C: &str = r#"
#include <libcaer/events/frame.h>
#include <libcaer/events/imu6.h>
#include <libcaer/events/packetContainer.h>
#include <libcaer/events/polarity.h>
#include <libcaer/events/special.h>

/* Container k: `events` polarity events (every 17th left invalid) in slot 1, with
   `overflow` in the packet header; a special packet in slot 0 when k is even, a
   small frame in slot 2 when k is a multiple of 3, two IMU samples in slot 3; the
   other slots NULL. */
caerEventPacketContainer faithd_build(int32_t k, int32_t events, int32_t overflow) {
    caerEventPacketContainer c = caerEventPacketContainerAllocate(4);
    caerPolarityEventPacket pol = caerPolarityEventPacketAllocate(events + 100, 1, overflow);
    for (int32_t i = 0; i < events; i++) {
        caerPolarityEvent e = caerPolarityEventPacketGetEvent(pol, i);
        caerPolarityEventSetTimestamp(e, 1000 * k + 3 * i);
        caerPolarityEventSetX(e, (uint16_t) ((7 * i + k) % 240));
        caerPolarityEventSetY(e, (uint16_t) ((11 * i + 2 * k) % 180));
        caerPolarityEventSetPolarity(e, (i % 3) != 0);
        if (i % 17 != 5) caerPolarityEventValidate(e, pol);
    }
    caerEventPacketHeaderSetEventNumber(&pol->packetHeader, events);
    caerEventPacketContainerSetEventPacket(c, POLARITY_EVENT, (caerEventPacketHeader) pol);
    if (k % 2 == 0) {
        caerSpecialEventPacket sp = caerSpecialEventPacketAllocate(8, 1, overflow);
        caerSpecialEvent e = caerSpecialEventPacketGetEvent(sp, 0);
        caerSpecialEventSetTimestamp(e, 1000 * k + 1);
        caerSpecialEventSetType(e, EXTERNAL_INPUT_RISING_EDGE);
        caerSpecialEventValidate(e, sp);
        caerEventPacketHeaderSetEventNumber(&sp->packetHeader, 1);
        caerEventPacketContainerSetEventPacket(c, SPECIAL_EVENT, (caerEventPacketHeader) sp);
    }
    if (k % 3 == 0) {
        caerFrameEventPacket fp = caerFrameEventPacketAllocate(1, 1, overflow, 4, 3, 1);
        caerFrameEvent e = caerFrameEventPacketGetEvent(fp, 0);
        caerFrameEventSetTSStartOfFrame(e, 1000 * k + 2);
        caerFrameEventSetTSEndOfFrame(e, 1000 * k + 9);
        caerFrameEventSetLengthXLengthYChannelNumber(e, 4, 3, GRAYSCALE, fp);
        caerFrameEventValidate(e, fp);
        caerEventPacketHeaderSetEventNumber(&fp->packetHeader, 1);
        caerEventPacketContainerSetEventPacket(c, FRAME_EVENT, (caerEventPacketHeader) fp);
    }
    caerIMU6EventPacket ip = caerIMU6EventPacketAllocate(4, 1, overflow);
    for (int32_t i = 0; i < 2; i++) {
        caerIMU6Event e = caerIMU6EventPacketGetEvent(ip, i);
        caerIMU6EventSetTimestamp(e, 1000 * k + 500 * i);
        caerIMU6EventSetAccelZ(e, 1.0f);
        caerIMU6EventValidate(e, ip);
    }
    caerEventPacketHeaderSetEventNumber(&ip->packetHeader, 2);
    caerEventPacketContainerSetEventPacket(c, IMU6_EVENT, (caerEventPacketHeader) ip);
    return c;
}

int32_t faithd_packets_number(caerEventPacketContainer c) {
    return caerEventPacketContainerGetEventPacketsNumber(c);
}

void *faithd_packet(caerEventPacketContainer c, int32_t n) {
    return caerEventPacketContainerGetEventPacket(c, n);
}

/* The valid polarity events of every polarity packet, as libcaer reads them; returns
   how many there are (up to `room` written). */
int32_t faithd_read(caerEventPacketContainer c, int64_t *t, uint16_t *x, uint16_t *y, uint8_t *on,
                    int32_t room) {
    int32_t n = 0;
    CAER_EVENT_PACKET_CONTAINER_ITERATOR_START(c)
    if (caerEventPacketHeaderGetEventType(caerEventPacketContainerIteratorElement) != POLARITY_EVENT) continue;
    caerPolarityEventPacket pol = (caerPolarityEventPacket) caerEventPacketContainerIteratorElement;
    CAER_POLARITY_ITERATOR_VALID_START(pol)
    if (n < room) {
        t[n] = caerPolarityEventGetTimestamp64(caerPolarityIteratorElement, pol);
        x[n] = caerPolarityEventGetX(caerPolarityIteratorElement);
        y[n] = caerPolarityEventGetY(caerPolarityIteratorElement);
        on[n] = caerPolarityEventGetPolarity(caerPolarityIteratorElement);
    }
    n++;
    CAER_POLARITY_ITERATOR_VALID_END
    CAER_EVENT_PACKET_CONTAINER_ITERATOR_END
    return n;
}
"#;

/// Compiles [`BUILDER_C`] against the real headers into `dir`, linked to the real
/// library.
fn build_builder(dir: &Path, include: &str, library: &str) -> PathBuf {
    let source = dir.join("builder.c");
    let output = dir.join("libbuilder.so");
    std::fs::write(&source, BUILDER_C).unwrap();
    let library_dir = Path::new(library).parent().unwrap();
    let status = std::process::Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
        .args(["-std=gnu11", "-shared", "-fPIC", "-O1", "-o"])
        .arg(&output)
        .arg(format!("-I{include}"))
        .arg(&source)
        .arg(library)
        .arg(format!("-Wl,-rpath,{}", library_dir.display()))
        .status()
        .expect("a C compiler (cc, or CC)");
    assert!(status.success(), "compiling the container builder failed");
    output
}

type Build = unsafe extern "C" fn(i32, i32, i32) -> libcaer_sys::caerEventPacketContainer;
type PacketsNumber = unsafe extern "C" fn(libcaer_sys::caerEventPacketContainer) -> i32;
type Packet = unsafe extern "C" fn(libcaer_sys::caerEventPacketContainer, i32) -> *mut u8;
type Read = unsafe extern "C" fn(
    libcaer_sys::caerEventPacketContainer,
    *mut i64,
    *mut u16,
    *mut u16,
    *mut u8,
    i32,
) -> i32;

#[test]
fn containers_from_the_real_inline_allocators_read_as_libcaers_own_getters_read_them() {
    let Some(library) = real_library() else {
        return;
    };
    let Ok(include) = std::env::var("LIBCAER_INCLUDE") else {
        skipped("LIBCAER_INCLUDE is not set (the real libcaer's include directory)");
        return;
    };
    let dir = common::TempDir::new("caer-containers");
    let builder_path = build_builder(&dir.0, &include, &library);
    // SAFETY: the builder's functions have exactly these C signatures.
    let builder = unsafe { libcaer_sys::libloading::Library::new(&builder_path) }.unwrap();
    // SAFETY: see the call: plain values into the loaded library.
    let (build, packets_number, packet, read) = unsafe {
        (
            *builder.get::<Build>(b"faithd_build\0").unwrap(),
            *builder
                .get::<PacketsNumber>(b"faithd_packets_number\0")
                .unwrap(),
            *builder.get::<Packet>(b"faithd_packet\0").unwrap(),
            *builder.get::<Read>(b"faithd_read\0").unwrap(),
        )
    };
    let mut compared = 0;
    for k in 0..60 {
        let (events, overflow) = (200 + 37 * k, k % 4);
        // SAFETY: a container libcaer's code allocated, handed over to `Container`.
        let raw = unsafe { build(k, events, overflow) };
        let expected = {
            let room = events as usize;
            let (mut t, mut x, mut y, mut on) = (
                vec![0i64; room],
                vec![0u16; room],
                vec![0u16; room],
                vec![0u8; room],
            );
            // SAFETY: see the call: plain values into the loaded library.
            let n = unsafe {
                read(
                    raw,
                    t.as_mut_ptr(),
                    x.as_mut_ptr(),
                    y.as_mut_ptr(),
                    on.as_mut_ptr(),
                    room as i32,
                )
            };
            (0..n as usize)
                .map(|i| libcaer_sys::Polarity {
                    t_us: t[i],
                    x: x[i],
                    y: y[i],
                    on: on[i] != 0,
                })
                .collect::<Vec<_>>()
        };
        // SAFETY: a container the library allocated and handed over, freed once by its drop.
        let container = unsafe { Container::from_raw(raw) }.unwrap();
        // SAFETY: see the call: plain values into the loaded library.
        assert_eq!(container.packets_number(), unsafe { packets_number(raw) });
        for n in 0..4 {
            // SAFETY: see the call: plain values into the loaded library.
            let theirs = unsafe { packet(raw, n) };
            assert_eq!(
                container.packet(n),
                (!theirs.is_null()).then_some(theirs),
                "slot {n}"
            );
        }
        assert_eq!((container.packet(-1), container.packet(4)), (None, None));
        let mut ours = Vec::new();
        for p in container.packets() {
            // SAFETY: a live packet of a live container (header and capacity in memory).
            unsafe { libcaer_sys::read_polarity_packet(p, &mut ours) };
        }
        assert_eq!(ours, expected, "container {k}");
        assert!(ours.iter().any(|e| e.t_us >> 31 == i64::from(overflow)));
        compared += ours.len();
        // Freed by faithd's own caerEventPacketContainerFree.
        drop(container);
    }
    let _ = writeln!(
        std::io::stderr(),
        "60 containers built by the real libcaer: {compared} polarity events read alike"
    );
}
