//! A panic in the commander ends its task alone: the daemon releases the roll through
//! the stream at once and `serve` returns a fault, where the panic used to unwind out
//! of `serve` with the roll still held. (Its own test binary: the panic hook's fault
//! is process-wide, and another test's panic would end this daemon at once.)

mod common;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::autopilot::{Controls, MockAutopilot};
use common::msp::is_roll;
use faithd::clock::DaemonClock;
use faithd::daemon::{Ended, Execution, Hooks, Observation, serve};
use faithd::source::{SourceConfig, sim::run_sim};
use faithd::supervise;

#[test]
fn a_panic_in_the_commander_mid_roll_releases_within_100_ms() {
    // As `faithd run` does.
    supervise::install_panic_hook();
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
    let hooks = Hooks {
        clock: DaemonClock::start(),
        execution: Execution::Threads {
            source: Box::new(move |clock, batches| run_sim(source_config, camera, clock, batches)),
        },
        observer: Some(Box::new(move |o| {
            if let Observation::ManoeuvreStarted { .. } = o {
                // Let the roll reach iNav first: the release is what is measured.
                std::thread::sleep(Duration::from_millis(100));
                *at.lock().unwrap() = Some(Instant::now());
                panic!("injected commander fault");
            }
        })),
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
    let ended = daemon.join().expect("serve returns instead of unwinding");
    match &ended {
        Ended::Fault(why) => assert!(why.contains("commander"), "{why}"),
        other => panic!("ended without a fault: {other:?}"),
    }
    let panicked_at = panicked_at.lock().unwrap().expect("the commander panicked");
    std::thread::sleep(Duration::from_millis(100));
    assert!(
        mock.msp
            .roll_after(panicked_at - Duration::from_millis(150))
            .is_some(),
        "iNav used the roll before the panic"
    );
    let frames = mock.msp.frames.lock().unwrap().clone();
    let centre = frames
        .iter()
        .find(|(t, ch)| *t >= panicked_at && !is_roll(ch[0]))
        .map(|(t, _)| *t)
        .expect("a centre frame after the panic");
    eprintln!(
        "measured: commander panic, centre served by iNav {:?} after",
        centre - panicked_at
    );
    assert!(
        centre - panicked_at < Duration::from_millis(100),
        "released {:?} after the panic",
        centre - panicked_at
    );
    assert!(
        frames.iter().all(|(t, ch)| *t <= centre || !is_roll(ch[0])),
        "a roll frame after the release"
    );
}
