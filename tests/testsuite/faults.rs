//! How a run of the daemon ends, every way, in one test binary: a requested stop joins
//! every task and thread; a panic on the camera thread or in the commander releases the
//! roll at once and ends that run with a fault. Faults belong to a run (a
//! `supervise::Faults` handle passed to every task and thread), so these runs, in one
//! process and in parallel, never end each other.

use crate::common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::autopilot::{Controls, MockAutopilot};
use common::msp::is_roll;
use faithd::clock::DaemonClock;
use faithd::daemon::{Ended, Execution, Hooks, Observation, serve};
use faithd::source::{SourceConfig, SourceIo, sim::run_sim};
use faithd::supervise::{self, Faults};

/// A multi-threaded runtime as `faithd run` builds it: its workers are this run's.
fn runtime_of(faults: &Faults) -> tokio::runtime::Runtime {
    faults.runtime().unwrap()
}

/// Sets its flag when dropped: when the thread that owns it has ended.
struct SetOnDrop(Arc<AtomicBool>);

impl Drop for SetOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::SeqCst);
    }
}

#[test]
fn a_requested_stop_joins_every_thread_before_serve_returns() {
    let faults = Faults::new();
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let (config, endpoint, msp_endpoint) = mock.serve_config("");
    let camera_ended = Arc::new(AtomicBool::new(false));
    let flag = camera_ended.clone();
    let SourceConfig::Sim(source_config) = config.source.clone() else {
        panic!("serve_config gives a simulated camera")
    };
    let camera = config.pipeline.camera;
    let hooks = Hooks {
        clock: DaemonClock::start(),
        execution: Execution::Threads {
            source: Box::new(move |io| {
                let _ended = SetOnDrop(flag);
                run_sim(source_config, camera, io);
                Ok(())
            }),
        },
        observer: None,
        faults: faults.clone(),
    };
    let ended = runtime_of(&faults).block_on(serve(config, endpoint, msp_endpoint, hooks, async {
        tokio::time::sleep(Duration::from_millis(1500)).await;
        "the test"
    }));
    assert_eq!(ended, Ended::Requested("the test"));
    assert!(
        camera_ended.load(Ordering::SeqCst),
        "the camera thread outlived serve"
    );
    // The release reached iNav: the roll it uses now is none of faithd's.
    let last = mock.msp.roll_log.lock().unwrap().last().map(|(_, v)| *v);
    assert!(last.is_some_and(|v| !is_roll(v)), "iNav uses {last:?}");
}

#[test]
fn a_panic_mid_roll_releases_the_roll_at_once_and_ends_the_daemon_with_a_fault() {
    supervise::install_panic_hook();
    let faults = Faults::new();
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
            source: Box::new(move |io: SourceIo| {
                let (tx, rx) = std::sync::mpsc::sync_channel(256);
                let inner = SourceIo {
                    clock: io.clock,
                    batches: tx,
                    stop: io.stop.clone(),
                };
                std::thread::spawn(move || run_sim(source_config, camera, inner));
                for batch in rx {
                    assert!(!trigger.load(Ordering::SeqCst), "injected camera fault");
                    if io.batches.send(batch).is_err() {
                        break;
                    }
                }
                Ok(())
            }),
        },
        observer: None,
        faults: faults.clone(),
    };
    let daemon = std::thread::spawn(move || {
        runtime_of(&faults).block_on(serve(
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
    // Mid-roll (the roll lasts 1.5 s), iNav uses the centre well before the pipeline
    // could notice the missing events (200 ms), and nothing rolls after.
    let (centre, used) = mock
        .msp
        .unrolled_after(panicked_at)
        .expect("iNav released the roll after the panic");
    assert_eq!(used, 1500, "AUTO holds the centre");
    assert!(
        centre - panicked_at < Duration::from_millis(100),
        "released {:?} after the panic",
        centre - panicked_at
    );
    assert!(
        mock.msp.roll_after(centre).is_none(),
        "iNav used a roll after the release"
    );
    assert!(returned_at - panicked_at < Duration::from_secs(3));
}

#[test]
fn a_panic_in_the_commander_mid_roll_releases_within_100_ms() {
    // As `faithd run` does.
    supervise::install_panic_hook();
    let faults = Faults::new();
    let mock = MockAutopilot::start(Arc::new(Controls::default()));
    let (config, endpoint, msp_endpoint) = mock.serve_config("first_approach_us = 1000000\n");
    let SourceConfig::Sim(source_config) = config.source.clone() else {
        panic!("serve_config gives a simulated camera")
    };
    let camera = config.pipeline.camera;
    // The commander calls its observer with the roll it just started, and panics
    // there: the roll is set, its frame on its way.
    let panicked_at: Arc<Mutex<Option<Instant>>> = Arc::default();
    let at = panicked_at.clone();
    let roll_log = mock.msp.roll_log.clone();
    let hooks = Hooks {
        clock: DaemonClock::start(),
        execution: Execution::Threads {
            source: Box::new(move |io| {
                run_sim(source_config, camera, io);
                Ok(())
            }),
        },
        observer: Some(Box::new(move |o| {
            if let Observation::ManoeuvreStarted { .. } = o {
                // Let the roll reach iNav first (the release is what is measured),
                // with this worker's other tasks, the MSP stream among them, moved
                // to the other worker meanwhile.
                tokio::task::block_in_place(|| {
                    common::poll_until(Duration::from_secs(1), || {
                        roll_log.lock().unwrap().iter().any(|(_, v)| is_roll(*v))
                    })
                });
                *at.lock().unwrap() = Some(Instant::now());
                panic!("injected commander fault");
            }
        })),
        faults: faults.clone(),
    };
    let daemon = std::thread::spawn(move || {
        runtime_of(&faults).block_on(serve(
            config,
            endpoint,
            msp_endpoint,
            hooks,
            std::future::pending(),
        ))
    });
    let ended = daemon.join().expect("serve returns instead of unwinding");
    match &ended {
        Ended::Fault(why) => assert!(why.contains("commander"), "{why}"),
        other => panic!("ended without a fault: {other:?}"),
    }
    let panicked_at = panicked_at.lock().unwrap().expect("the commander panicked");
    std::thread::sleep(Duration::from_millis(100));
    assert!(
        mock.msp
            .roll_after(panicked_at - Duration::from_secs(2))
            .is_some(),
        "iNav used the roll before the panic"
    );
    let (centre, used) = mock
        .msp
        .unrolled_after(panicked_at)
        .expect("iNav released the roll after the panic");
    assert_eq!(used, 1500, "AUTO holds the centre");
    eprintln!(
        "measured: commander panic, the centre in use on iNav {:?} after",
        centre - panicked_at
    );
    assert!(
        centre - panicked_at < Duration::from_millis(100),
        "released {:?} after the panic",
        centre - panicked_at
    );
    assert!(
        mock.msp.roll_after(centre).is_none(),
        "iNav used a roll after the release"
    );
}
