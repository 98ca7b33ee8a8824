//! Who keeps the systemd watchdog fed: every task a roll's safety depends on.
//!
//! The pipeline shows it is alive by finishing cycles; the link, the MSP stream and
//! the commander beat a [`Heartbeat`] at least every [`BEAT_PERIOD`], even while they
//! wait for a port to come back, and every operation they await is bounded in time
//! (writes, opens, replies). So a task that stops beating is stuck or gone, and the
//! daemon stops feeding the watchdog: systemd kills and restarts it, and the
//! restarted daemon's first frame is the centre.
//!
//! A panic anywhere ends the daemon on purpose ([`install_panic_hook`]): the roll is
//! released and the exit status is non-zero, so systemd restarts it too.
//!
//! Faults belong to one run of the daemon ([`Faults`], a handle passed to every task
//! and thread like the shutdown signal): two runs in one process (the flights of
//! `faithd sim`, parallel tests) never end each other.

use std::cell::RefCell;
use std::sync::Arc;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicI64, Ordering};
use std::time::Duration;

use crate::clock::DaemonClock;

/// How often a supervised task beats, at least.
pub const BEAT_PERIOD: Duration = Duration::from_millis(100);

/// A supervised task that has not beaten for this long is stuck. Under half of the
/// unit's `WatchdogSec=2`, so systemd acts within two seconds of the stall.
pub const STALL_LIMIT_US: i64 = 1_000_000;

/// The time a task last showed it was alive.
#[derive(Clone, Debug)]
pub struct Heartbeat {
    last_us: Arc<AtomicI64>,
    clock: DaemonClock,
}

impl Heartbeat {
    pub fn beat(&self) {
        self.last_us.store(self.clock.now_us(), Ordering::Release);
    }

    /// Sleeps for `duration`, beating meanwhile: a task waiting to reconnect is alive.
    pub async fn sleep(&self, duration: Duration) {
        let until = tokio::time::Instant::now() + duration;
        loop {
            self.beat();
            let now = tokio::time::Instant::now();
            if now >= until {
                return;
            }
            tokio::time::sleep((until - now).min(BEAT_PERIOD)).await;
        }
    }
}

/// The supervised tasks and their heartbeats.
#[derive(Clone, Debug)]
pub struct Supervisor {
    clock: DaemonClock,
    tasks: Vec<(&'static str, Arc<AtomicI64>)>,
}

impl Supervisor {
    pub fn new(clock: DaemonClock) -> Self {
        Self {
            clock,
            tasks: Vec::new(),
        }
    }

    /// Registers a task; it counts as alive from now.
    pub fn register(&mut self, name: &'static str) -> Heartbeat {
        let last_us = Arc::new(AtomicI64::new(self.clock.now_us()));
        self.tasks.push((name, last_us.clone()));
        Heartbeat {
            last_us,
            clock: self.clock,
        }
    }

    /// The first task that has not beaten within `STALL_LIMIT_US`, and for how long.
    pub fn stalled(&self, now_us: i64) -> Option<(&'static str, i64)> {
        self.tasks.iter().find_map(|(name, last)| {
            let age_us = now_us - last.load(Ordering::Acquire);
            (age_us > STALL_LIMIT_US).then_some((*name, age_us))
        })
    }
}

/// Why the daemon ends against its will.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Fault {
    /// A task panicked or ended: systemd restarts the daemon.
    Crash(String),
    /// Something found at run time contradicts the configuration (a camera of
    /// another size): restarting cannot help, the configuration must change.
    Refused { key: &'static str, reason: String },
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fault::Crash(why) => f.write_str(why),
            Fault::Refused { key, reason } => write!(f, "`{key}`: {reason}"),
        }
    }
}

/// The faults of one run of the daemon: the first one reported ends that run, and no
/// other. Cheap to clone; every clone is the same run's.
#[derive(Clone, Debug)]
pub struct Faults {
    first: Arc<tokio::sync::watch::Sender<Option<Fault>>>,
}

impl Default for Faults {
    fn default() -> Self {
        Self::new()
    }
}

impl Faults {
    pub fn new() -> Self {
        Self {
            first: Arc::new(tokio::sync::watch::channel(None).0),
        }
    }

    /// The multi-threaded runtime a run's tasks go on (two workers, as `faithd run`
    /// has them): every worker enters this handle, so a panic in a task is this
    /// run's fault.
    pub fn runtime(&self) -> std::io::Result<tokio::runtime::Runtime> {
        let faults = self.clone();
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .on_thread_start(move || std::mem::forget(faults.enter()))
            .build()
    }

    /// Ends the run with a fault (the first one reported wins).
    pub fn report(&self, why: Fault) {
        self.first.send_if_modified(|f| {
            if f.is_none() {
                *f = Some(why);
                true
            } else {
                false
            }
        });
    }

    /// The fault reported so far, if any.
    pub fn reported(&self) -> Option<Fault> {
        self.first.borrow().clone()
    }

    /// Resolves with the first fault reported.
    pub async fn wait(&self) -> Fault {
        let mut rx = self.first.subscribe();
        loop {
            if let Some(why) = rx.borrow_and_update().clone() {
                return why;
            }
            if rx.changed().await.is_err() {
                std::future::pending::<()>().await;
            }
        }
    }

    /// Makes this run the one a panic on the calling thread is reported to, until the
    /// guard is dropped (threads the run starts, the runtime's workers, a simulated
    /// flight's one thread).
    pub fn enter(&self) -> FaultScope {
        let previous = CURRENT.with(|c| c.replace(Some(self.clone())));
        FaultScope { previous }
    }
}

/// While alive, panics on this thread are the run's faults ([`Faults::enter`]).
pub struct FaultScope {
    previous: Option<Faults>,
}

impl Drop for FaultScope {
    fn drop(&mut self) {
        let previous = self.previous.take();
        CURRENT.with(|c| *c.borrow_mut() = previous);
    }
}

thread_local! {
    /// The run a panic on this thread belongs to.
    static CURRENT: RefCell<Option<Faults>> = const { RefCell::new(None) };
}

/// Turns a panic in any thread of a run into that run's fault: the panic is printed
/// as usual, then the run's [`Faults::wait`] resolves and the daemon releases the
/// roll and exits non-zero. A half-alive daemon (a dead link or pipeline behind a
/// running process) is what systemd cannot see; a dead one it restarts. A panic on a
/// thread of no run is only printed.
pub fn install_panic_hook() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            // The fault first: printing a backtrace can take a good part of a second,
            // and the release must not wait for it.
            let run = CURRENT.try_with(|c| c.borrow().clone()).ok().flatten();
            if let Some(faults) = run {
                let thread = std::thread::current()
                    .name()
                    .unwrap_or("unnamed thread")
                    .to_string();
                let what = info
                    .payload()
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| info.payload().downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "panic".into());
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                faults.report(Fault::Crash(format!("panic in {thread}: {what}{at}")));
            }
            previous(info);
        }));
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_task_that_stops_beating_is_named_after_the_limit() {
        let clock = DaemonClock::start();
        let mut supervisor = Supervisor::new(clock);
        let link = supervisor.register("link");
        let stream = supervisor.register("MSP stream");
        let now = clock.now_us();
        assert_eq!(supervisor.stalled(now), None);
        link.beat();
        stream.beat();
        let later = clock.now_us() + STALL_LIMIT_US + 1;
        let (name, age_us) = supervisor.stalled(later).expect("both stalled");
        assert_eq!(name, "link");
        assert!(age_us > STALL_LIMIT_US);
        // The link beats again: only the stream is stuck.
        link.last_us.store(later, Ordering::Release);
        assert_eq!(supervisor.stalled(later).map(|s| s.0), Some("MSP stream"));
    }

    #[test]
    fn a_panic_is_the_fault_of_the_run_whose_thread_it_is_on() {
        install_panic_hook();
        let (a, b) = (Faults::new(), Faults::new());
        let thread_of = |faults: Faults, panics: bool| {
            std::thread::spawn(move || {
                let _run = faults.enter();
                if panics {
                    panic!("injected");
                }
            })
        };
        assert!(thread_of(a.clone(), true).join().is_err());
        assert!(thread_of(b.clone(), false).join().is_ok());
        match a.reported() {
            Some(Fault::Crash(why)) => assert!(why.contains("injected"), "{why}"),
            other => panic!("run a: {other:?}"),
        }
        assert_eq!(b.reported(), None, "run b is not ended by run a's panic");
        // The first fault wins; the scope ends with its guard.
        a.report(Fault::Crash("second".into()));
        assert!(matches!(a.reported(), Some(Fault::Crash(why)) if why.contains("injected")));
        {
            let _run = b.enter();
        }
        assert!(std::panic::catch_unwind(|| panic!("no run")).is_err());
        assert_eq!(b.reported(), None);
    }
}
