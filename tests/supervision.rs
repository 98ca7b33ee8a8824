//! A panic in any of the daemon's threads ends it on purpose: the roll is released
//! on the wire at once and `serve` returns a fault (the binary exits non-zero and
//! systemd restarts it), instead of a half-alive daemon that systemd cannot see.
//! In its own test binary: the panic hook and the fault are process-wide.

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use common::autopilot::{Controls, MockAutopilot};
use common::msp::is_roll;
use faithd::clock::DaemonClock;
use faithd::daemon::{Ended, Execution, Hooks, serve};
use faithd::source::{SourceConfig, sim::run_sim};
use faithd::supervise;

#[test]
fn a_panic_mid_roll_releases_the_roll_at_once_and_ends_the_daemon_with_a_fault() {
    supervise::install_panic_hook();
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let (config, endpoint, msp_endpoint) = mock.serve_config("first_approach_us = 1000000\n");
    // The camera thread forwards the simulated camera until told to panic.
    let panic_now = Arc::new(AtomicBool::new(false));
    let SourceConfig::Sim(source_config) = config.source.clone() else {
        panic!("serve_config gives a simulated camera")
    };
    let camera = config.pipeline.camera;
    let trigger = panic_now.clone();
    let hooks = Hooks {
        clock: DaemonClock::start(),
        execution: Execution::Threads {
            source: Box::new(move |clock, batches| {
                let (tx, rx) = std::sync::mpsc::sync_channel(256);
                std::thread::spawn(move || run_sim(source_config, camera, clock, tx));
                for batch in rx {
                    assert!(!trigger.load(Ordering::SeqCst), "injected camera fault");
                    if batches.send(batch).is_err() {
                        return;
                    }
                }
            }),
        },
        observer: None,
    };
    let daemon = std::thread::spawn(move || {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap()
            .block_on(serve(
                config,
                endpoint,
                msp_endpoint,
                hooks,
                std::future::pending(),
            ))
    });

    assert!(
        mock.msp
            .wait_for(Duration::from_secs(10), |m| m.first_roll().is_some()),
        "iNav never used a roll"
    );
    std::thread::sleep(Duration::from_millis(200));
    let panicked_at = Instant::now();
    panic_now.store(true, Ordering::SeqCst);
    let ended = daemon.join().expect("serve returns");
    let returned_at = Instant::now();

    match &ended {
        Ended::Fault(why) => {
            assert!(why.contains("panic in faithd-source"), "{why}");
            assert!(why.contains("injected camera fault"), "{why}");
        }
        other => panic!("ended without a fault: {other:?}"),
    }
    // Mid-roll (the roll lasts 1.5 s), the centre reaches the port well before the
    // pipeline could notice the missing events (200 ms), and nothing rolls after.
    let frames = mock.msp.frames.lock().unwrap().clone();
    let centre = frames
        .iter()
        .find(|(at, ch)| *at >= panicked_at && !is_roll(ch[0]))
        .map(|(at, _)| *at)
        .expect("a centre frame after the panic");
    assert!(
        centre - panicked_at < Duration::from_millis(100),
        "released {:?} after the panic",
        centre - panicked_at
    );
    assert!(
        frames
            .iter()
            .filter(|(at, ch)| *at > centre && is_roll(ch[0]))
            .count()
            == 0,
        "a roll frame after the release"
    );
    assert!(returned_at - panicked_at < Duration::from_secs(3));
}
