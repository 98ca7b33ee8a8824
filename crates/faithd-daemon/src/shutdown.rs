//! One shutdown for a whole run, handed to every task and thread it starts.
//!
//! The daemon asks once ([`Shutdown::request`]); each part hears it where it waits
//! (a task in its `select!`, a thread in [`Stop::wait_timeout`] instead of a sleep),
//! reaches its own safe state (the camera stops its transfer and closes the device,
//! a link closes its port) and drops its [`Stop`]. [`Shutdown::stopped`] returns
//! once every `Stop` is gone: the completion guard of tokio's mini-redis, with a
//! blocking side for the threads that wait in a device library rather than in tokio.

use std::future::Future;
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::Duration;

use tokio::sync::{mpsc, watch};

/// The side that asks the run to stop and then waits for every part to be done.
pub struct Shutdown {
    signal: Arc<Signal>,
    alive: Option<mpsc::Sender<()>>,
    all_done: mpsc::Receiver<()>,
}

/// A part's end of the shutdown: it hears the request, and dropping it says that
/// the part has stopped.
#[derive(Clone)]
pub struct Stop {
    signal: Arc<Signal>,
    _alive: mpsc::Sender<()>,
}

/// The request, readable from a thread (the condition variable) and from a task
/// (the watch).
struct Signal {
    requested: Mutex<bool>,
    wake: Condvar,
    watch: watch::Sender<bool>,
}

impl Default for Shutdown {
    fn default() -> Self {
        Self::new()
    }
}

impl Shutdown {
    pub fn new() -> Self {
        let (alive, all_done) = mpsc::channel(1);
        Self {
            signal: Arc::new(Signal {
                requested: Mutex::new(false),
                wake: Condvar::new(),
                watch: watch::Sender::new(false),
            }),
            alive: Some(alive),
            all_done,
        }
    }

    /// A handle for one task or thread.
    pub fn handle(&self) -> Stop {
        Stop {
            signal: self.signal.clone(),
            _alive: self
                .alive
                .clone()
                .expect("handles are made before the wait"),
        }
    }

    /// Asks every part to stop; they hear it at once, wherever they wait.
    pub fn request(&self) {
        let mut requested = self
            .signal
            .requested
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        *requested = true;
        self.signal.wake.notify_all();
        self.signal.watch.send_replace(true);
    }

    /// Waits until every [`Stop`] handed out has been dropped; `false` when some
    /// part still holds one after `within`.
    pub async fn stopped(mut self, within: Duration) -> bool {
        self.alive = None;
        tokio::time::timeout(within, self.all_done.recv())
            .await
            .is_ok()
    }
}

impl Stop {
    pub fn is_requested(&self) -> bool {
        *self.signal.watch.borrow()
    }

    /// For a thread: waits up to `timeout`, and returns `true` as soon as a stop is
    /// requested (the thread's sleep, which a stop cuts short).
    pub fn wait_timeout(&self, timeout: Duration) -> bool {
        let requested = self
            .signal
            .requested
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        let (requested, _) = self
            .signal
            .wake
            .wait_timeout_while(requested, timeout, |requested| !*requested)
            .unwrap_or_else(PoisonError::into_inner);
        *requested
    }

    /// For a task: completes when a stop is requested.
    pub async fn requested(&self) {
        let mut watch = self.signal.watch.subscribe();
        // The sender lives in `self.signal`, so the wait cannot fail.
        let _ = watch.wait_for(|requested| *requested).await;
    }

    /// Runs `work` until it completes (`Some`) or a stop is requested (`None`, and
    /// `work` is dropped where it waits: what it holds, a port, closes).
    pub async fn until<F: Future>(&self, work: F) -> Option<F::Output> {
        tokio::select! {
            biased;
            () = self.requested() => None,
            output = work => Some(output),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn a_request_wakes_a_waiting_thread_and_a_task_and_completes_when_both_are_gone() {
        let shutdown = Shutdown::new();
        let (thread_stop, task_stop) = (shutdown.handle(), shutdown.handle());
        let thread = std::thread::spawn(move || {
            let woke = thread_stop.wait_timeout(Duration::from_secs(60));
            (woke, thread_stop.is_requested())
        });
        let task = tokio::spawn(async move {
            task_stop
                .until(std::future::pending::<()>())
                .await
                .is_none()
        });
        std::thread::sleep(Duration::from_millis(20));
        assert!(!thread.is_finished(), "nothing asked it to stop yet");
        shutdown.request();
        assert!(shutdown.stopped(Duration::from_secs(5)).await);
        assert_eq!(thread.join().unwrap(), (true, true));
        assert!(task.await.unwrap(), "the task's work was cut short");
    }

    #[tokio::test]
    async fn a_part_that_keeps_its_handle_is_reported_as_not_stopped() {
        let shutdown = Shutdown::new();
        let kept = shutdown.handle();
        assert!(!kept.wait_timeout(Duration::from_millis(1)));
        shutdown.request();
        assert!(kept.wait_timeout(Duration::ZERO), "already requested");
        assert!(!shutdown.stopped(Duration::from_millis(50)).await);
        drop(kept);
    }
}
