//! Which tests may share the two cores. The integration tests are one binary (as
//! cargo's own testsuite), so libtest runs any two of them side by side. Most measure
//! real time against iNav's schedule (telemetry every 40 ms, a roll stale after 100 ms);
//! a few load every core on purpose (a determinism check "under any load", the soak,
//! many simulated flights). Those two kinds never run at once: a timed test waits
//! while a heavy one runs and the other way round, while tests of one kind still run
//! beside each other as they did when each file was its own binary.

use std::sync::{Condvar, Mutex};

#[derive(Default)]
struct Running {
    timed: usize,
    heavy: usize,
}

static RUNNING: Mutex<Running> = Mutex::new(Running { timed: 0, heavy: 0 });
static CHANGED: Condvar = Condvar::new();

#[derive(Clone, Copy)]
enum Kind {
    Timed,
    Heavy,
}

/// Held for as long as a test is running as its kind.
#[must_use = "the test runs as its kind only while this is held"]
pub struct Slot(Kind);

/// A test that measures real time: waits until no heavy test runs.
pub fn timed() -> Slot {
    enter(Kind::Timed)
}

/// A test that loads every core: waits until no timed test runs.
pub fn heavy() -> Slot {
    enter(Kind::Heavy)
}

fn enter(kind: Kind) -> Slot {
    // A test that panicked while holding the lock leaves counts that are still right.
    let mut running = RUNNING.lock().unwrap_or_else(|e| e.into_inner());
    loop {
        let blocked = match kind {
            Kind::Timed => running.heavy > 0,
            Kind::Heavy => running.timed > 0,
        };
        if !blocked {
            break;
        }
        running = CHANGED.wait(running).unwrap_or_else(|e| e.into_inner());
    }
    match kind {
        Kind::Timed => running.timed += 1,
        Kind::Heavy => running.heavy += 1,
    }
    Slot(kind)
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut running = RUNNING.lock().unwrap_or_else(|e| e.into_inner());
        match self.0 {
            Kind::Timed => running.timed -= 1,
            Kind::Heavy => running.heavy -= 1,
        }
        CHANGED.notify_all();
    }
}
