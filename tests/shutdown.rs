//! `serve` returns only after every task and thread it started has ended: the
//! release is written and confirmed, the recorder closed, the link and the notifier
//! cancelled, the pipeline stopped and the camera thread gone. (Its own test binary:
//! a fault reported by another test would end this daemon at once.)

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use common::autopilot::{Controls, MockAutopilot};
use faithd::clock::DaemonClock;
use faithd::daemon::{Ended, Execution, Hooks, serve};
use faithd::source::{SourceConfig, sim::run_sim};

/// Sets its flag when dropped: when the thread that owns it has ended.
struct SetOnDrop(Arc<AtomicBool>);

impl Drop for SetOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::SeqCst);
    }
}

#[test]
fn a_requested_stop_joins_every_thread_before_serve_returns() {
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
            source: Box::new(move |clock, batches| {
                let _ended = SetOnDrop(flag);
                run_sim(source_config, camera, clock, batches);
            }),
        },
        observer: None,
    };
    let ended = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
        .block_on(serve(config, endpoint, msp_endpoint, hooks, async {
            tokio::time::sleep(Duration::from_millis(1500)).await;
            "the test"
        }));
    assert_eq!(ended, Ended::Requested("the test"));
    assert!(
        camera_ended.load(Ordering::SeqCst),
        "the camera thread outlived serve"
    );
    // The release reached the port: the last frame faithd wrote is the centre.
    let frames = mock.msp.frames.lock().unwrap().clone();
    assert_eq!(frames.last().map(|(_, ch)| ch[0]), Some(1500));
}
