//! A driver's own thread (a planner, a particle filter, a log replay) whose panic is not lost:
//! the core catches panics in driver callbacks only, so a thread the driver spawned would
//! otherwise die unnoticed and leave its devices silently stuck. [`WorkerThread`] wakes the
//! driver when the thread ends, and [`WorkerThread::check`], called at the start of the
//! driver's callbacks, raises the thread's panic there, where the core reports it (naming the
//! driver, its cfg line and devices), NACKs and unsubscribes its clients and serves on.

use std::any::Any;
use std::panic::resume_unwind;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

use crate::driver::DriverWaker;

/// A thread a driver spawned, joined (and its panic raised) by [`WorkerThread::check`].
#[derive(Debug)]
pub struct WorkerThread {
    name: String,
    handle: Option<JoinHandle<()>>,
    /// Set by the thread as it ends, before it wakes the driver: the wake can reach `check`
    /// while the thread is still unwinding (not yet `is_finished`), and `check` must then
    /// wait the moment it takes rather than miss the end, which no later wake would report.
    ending: Arc<AtomicBool>,
}

/// Marks the thread as ending and wakes the driver when dropped: at the thread's end, also
/// when it unwinds from a panic, so the core calls the driver's `wake` (and with it
/// [`WorkerThread::check`]) at once.
struct WakeOnExit {
    waker: Option<DriverWaker>,
    ending: Arc<AtomicBool>,
}

impl Drop for WakeOnExit {
    fn drop(&mut self) {
        self.ending.store(true, Ordering::Release);
        if let Some(w) = &self.waker {
            w.wake();
        }
    }
}

impl WorkerThread {
    /// Spawns `body` on a thread called `name`; when it ends (returns or panics), `waker`
    /// (the driver's, from [`crate::Context::waker`]) asks the core to call the driver's
    /// `wake`.
    pub fn spawn(
        name: &str,
        waker: Option<DriverWaker>,
        body: impl FnOnce() + Send + 'static,
    ) -> std::io::Result<WorkerThread> {
        let ending = Arc::new(AtomicBool::new(false));
        let on_exit = WakeOnExit {
            waker,
            ending: Arc::clone(&ending),
        };
        let handle = std::thread::Builder::new()
            .name(name.to_string())
            .spawn(move || {
                let _wake = on_exit;
                body();
            })?;
        Ok(WorkerThread {
            name: name.to_string(),
            handle: Some(handle),
            ending,
        })
    }

    /// Raises the thread's panic in the calling driver callback, once the thread has ended
    /// by panicking: the core then takes the driver out of service as for a panic of its
    /// own, with the message `its worker thread "NAME" panicked: MSG`. A thread still running,
    /// or one that returned, is not an error.
    pub fn check(&mut self) {
        let ended = self.ending.load(Ordering::Acquire)
            || self.handle.as_ref().is_some_and(JoinHandle::is_finished);
        if !ended {
            return;
        }
        // Joining a thread that has marked its end waits only for its last unwinding steps.
        if let Some(Err(payload)) = self.handle.take().map(JoinHandle::join) {
            resume_unwind(Box::new(format!(
                "its worker thread \"{}\" panicked: {}",
                self.name,
                panic_text(payload.as_ref())
            )));
        }
    }

    /// Whether the thread has ended (returned or panicked).
    pub fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(JoinHandle::is_finished)
    }

    /// Waits for the thread to end (after the driver told it to stop); a panic is logged, not
    /// raised: the driver is being stopped anyway.
    pub fn join(mut self) {
        if let Some(Err(payload)) = self.handle.take().map(JoinHandle::join) {
            tracing::error!(
                "worker thread \"{}\" had panicked: {}",
                self.name,
                panic_text(payload.as_ref())
            );
        }
    }
}

/// The message a panic was raised with (`panic!` with a literal or a format), for the log.
pub(crate) fn panic_text(payload: &(dyn Any + Send)) -> &str {
    payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("(a panic without a message)")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::panic::{AssertUnwindSafe, catch_unwind};
    use std::time::{Duration, Instant};

    fn wait_finished(w: &WorkerThread) {
        let start = Instant::now();
        while !w.is_finished() {
            assert!(
                start.elapsed() < Duration::from_secs(5),
                "the thread never ended"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_worker_panic_is_raised_in_the_caller_of_check() {
        let mut w = WorkerThread::spawn("planner", None, || panic!("bad cell 7")).unwrap();
        wait_finished(&w);
        let caught = catch_unwind(AssertUnwindSafe(|| w.check())).unwrap_err();
        assert_eq!(
            panic_text(caught.as_ref()),
            "its worker thread \"planner\" panicked: bad cell 7"
        );
        // raised once; the thread is gone after
        w.check();
    }

    #[test]
    fn a_check_after_the_end_is_marked_waits_for_the_unwinding_thread() {
        // The waker's moment: the thread has marked its end (as `WakeOnExit` does) but is still
        // unwinding, so `is_finished` is false; here the unwinding is stretched to 200 ms.
        let mut w = WorkerThread::spawn("replay", None, || {
            std::thread::sleep(Duration::from_millis(200));
            panic!("bad line 3")
        })
        .unwrap();
        w.ending.store(true, Ordering::Release);
        assert!(!w.is_finished());
        let caught = catch_unwind(AssertUnwindSafe(|| w.check())).unwrap_err();
        assert_eq!(
            panic_text(caught.as_ref()),
            "its worker thread \"replay\" panicked: bad line 3"
        );
    }

    #[test]
    fn a_running_or_returned_worker_is_not_an_error() {
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let mut w = WorkerThread::spawn("filter", None, move || {
            let _ = rx.recv();
        })
        .unwrap();
        w.check();
        drop(tx);
        wait_finished(&w);
        w.check();
        w.join();
    }
}
