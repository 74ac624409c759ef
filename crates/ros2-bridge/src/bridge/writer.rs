//! The publisher thread: serialises and writes a step's messages while the engine computes
//! the next step. Serialisation (CDR) and RustDDS's write (its send buffer, the wake-up of
//! its event loop) were most of the bridge's time on the stepping thread with 100 robots
//! read; here they overlap with the step.
//!
//! Every message of every step is written, in the order [`Bridge::publish`] queued it: the
//! queue holds at most [`QUEUE_STEPS`] steps, and a step that finds it full waits
//! (back-pressure) rather than dropping anything.
//!
//! [`Bridge::publish`]: super::Bridge::publish

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

use ros2_client::Publisher;

use crate::Error;
use crate::msgs::RosType;

/// One message to write, with its publisher.
pub(super) type Job = Box<dyn FnOnce() + Send>;

/// How many steps' messages may wait for the thread before [`Writer::submit`] blocks: two,
/// so the thread always has the next step in hand while the engine computes another, and
/// the latency from a step to the wire stays within two steps' writing.
pub(super) const QUEUE_STEPS: usize = 2;

/// The thread's name (the bench finds its CPU time by it).
pub const THREAD_NAME: &str = "ros2 publisher";

/// A publisher shared with the thread, which reports its first failure (a full send window,
/// a vanished reader) once.
pub(super) struct Sink<T: RosType> {
    topic: String,
    publisher: Publisher<T>,
    failed: AtomicBool,
}

impl<T: RosType> Sink<T> {
    pub(super) fn new(topic: String, publisher: Publisher<T>) -> Arc<Sink<T>> {
        Arc::new(Sink {
            topic,
            publisher,
            failed: AtomicBool::new(false),
        })
    }

    /// The job that writes `message` here.
    pub(super) fn job(self: &Arc<Self>, message: T) -> Job {
        let sink = self.clone();
        Box::new(move || sink.write(message))
    }

    fn write(&self, message: T) {
        if let Err(e) = self.publisher.publish(message)
            && !self.failed.swap(true, Ordering::Relaxed)
        {
            tracing::warn!(
                "{}: a message was not sent ({e:?}); further failures are not logged",
                self.topic
            );
        }
    }

    pub(super) fn guid(&self) -> ros2_client::dds::rustdds::GUID {
        self.publisher.guid()
    }
}

/// The sending end of the queue and the thread; dropping it writes what is queued and joins.
pub(super) struct Writer {
    queue: Option<SyncSender<Vec<Job>>>,
    thread: Option<JoinHandle<()>>,
}

impl Writer {
    /// Starts the thread.
    pub(super) fn start() -> Result<Writer, Error> {
        let (queue, jobs) = sync_channel::<Vec<Job>>(QUEUE_STEPS);
        let thread = std::thread::Builder::new()
            .name(THREAD_NAME.into())
            .spawn(move || write_all(jobs))
            .map_err(|e| Error::Dds(format!("starting the publisher thread: {e}")))?;
        Ok(Writer {
            queue: Some(queue),
            thread: Some(thread),
        })
    }

    /// Queues a step's messages, waiting while [`QUEUE_STEPS`] steps are queued already. If
    /// the thread is gone (it panicked), they are written here instead.
    pub(super) fn submit(&mut self, jobs: Vec<Job>) {
        if jobs.is_empty() {
            return;
        }
        let jobs = match &self.queue {
            Some(queue) => match queue.send(jobs) {
                Ok(()) => return,
                Err(back) => {
                    tracing::error!("the publisher thread has stopped: publishing on this thread");
                    self.queue = None;
                    back.0
                }
            },
            None => jobs,
        };
        for job in jobs {
            job();
        }
    }
}

fn write_all(jobs: Receiver<Vec<Job>>) {
    for step in jobs {
        for job in step {
            job();
        }
    }
}

impl Drop for Writer {
    fn drop(&mut self) {
        // closing the queue ends the thread once it has written what was queued
        self.queue = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;
    use std::time::{Duration, Instant};

    use super::*;

    /// Jobs run in the order queued, across steps, and all of them before the writer is
    /// dropped; a step finding [`QUEUE_STEPS`] steps queued waits for the thread.
    #[test]
    fn every_job_runs_in_order_with_back_pressure() {
        let log = Arc::new(Mutex::new(Vec::new()));
        let gate = Arc::new(Mutex::new(()));
        let mut writer = Writer::start().unwrap();
        let held = gate.lock().unwrap();
        let (l, g) = (log.clone(), gate.clone());
        let job = move |step: usize, k: usize| -> Job {
            let (log, gate) = (l.clone(), g.clone());
            Box::new(move || {
                drop(gate.lock().unwrap());
                log.lock().unwrap().push((step, k));
            })
        };
        // the thread takes step 0 and blocks in its first job; two more fill the queue
        for step in 0..QUEUE_STEPS + 1 {
            writer.submit((0..3).map(|k| job(step, k)).collect());
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let blocked = std::thread::spawn(move || {
            writer.submit((0..3).map(|k| job(QUEUE_STEPS + 1, k)).collect());
            tx.send(()).unwrap();
            writer
        });
        assert!(
            rx.recv_timeout(Duration::from_millis(300)).is_err(),
            "a full queue makes the next step wait"
        );
        drop(held);
        rx.recv_timeout(Duration::from_secs(10))
            .expect("the step is queued once the thread moves on");
        let start = Instant::now();
        drop(blocked.join().unwrap());
        assert!(start.elapsed() < Duration::from_secs(10));
        let got = log.lock().unwrap().clone();
        let want: Vec<_> = (0..QUEUE_STEPS + 2)
            .flat_map(|s| (0..3).map(move |k| (s, k)))
            .collect();
        assert_eq!(got, want, "every job, in order, before the drop returns");
    }
}
