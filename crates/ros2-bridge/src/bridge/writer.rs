//! The publisher thread: serialises and writes a step's messages while the engine computes
//! the next step. Serialisation (CDR) and RustDDS's write (its send buffer, the wake-up of
//! its event loop) were most of the bridge's time on the stepping thread with 100 robots
//! read; here they overlap with the step.
//!
//! Every message of every step is written, in the order [`Bridge::publish`] queued it: the
//! queue holds at most [`QUEUE_STEPS`] steps, and a step that finds it full waits
//! (back-pressure) rather than dropping anything. A step with few messages (at most
//! [`INLINE_MAX`]) is written on the stepping thread when the publisher thread has nothing in
//! hand, which keeps order and spares it the hop to another thread (a wake-up, a fraction of
//! a millisecond on a busy machine, on the step-to-wire latency).
//!
//! [`Bridge::publish`]: super::Bridge::publish

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
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

/// The most messages a step may have to be written on the stepping thread (when the
/// publisher thread is idle): a node reading a vehicle's scan, odom, tf and `/clock` needs
/// a few, a reader of a 100-robot fleet hundreds.
pub(super) const INLINE_MAX: usize = 16;

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
    /// Steps queued and not yet written: 0 means the thread has nothing in hand.
    pending: Arc<AtomicUsize>,
    thread: Option<JoinHandle<()>>,
}

impl Writer {
    /// Starts the thread.
    pub(super) fn start() -> Result<Writer, Error> {
        let (queue, jobs) = sync_channel::<Vec<Job>>(QUEUE_STEPS);
        let pending = Arc::new(AtomicUsize::new(0));
        let done = pending.clone();
        let thread = std::thread::Builder::new()
            .name(THREAD_NAME.into())
            .spawn(move || write_all(jobs, &done))
            .map_err(|e| Error::Dds(format!("starting the publisher thread: {e}")))?;
        Ok(Writer {
            queue: Some(queue),
            pending,
            thread: Some(thread),
        })
    }

    /// Queues a step's messages, waiting while [`QUEUE_STEPS`] steps are queued already; a
    /// step of at most [`INLINE_MAX`] messages is written here if the thread is idle. If the
    /// thread is gone (it panicked), they are written here too.
    pub(super) fn submit(&mut self, jobs: Vec<Job>) {
        if jobs.is_empty() {
            return;
        }
        // only this thread adds work, so an idle thread stays idle while these are written
        let inline = jobs.len() <= INLINE_MAX && self.pending.load(Ordering::Acquire) == 0;
        let jobs = match &self.queue {
            Some(queue) if !inline => {
                self.pending.fetch_add(1, Ordering::AcqRel);
                match queue.send(jobs) {
                    Ok(()) => return,
                    Err(back) => {
                        tracing::error!(
                            "the publisher thread has stopped: publishing on this thread"
                        );
                        self.queue = None;
                        back.0
                    }
                }
            }
            _ => jobs,
        };
        for job in jobs {
            job();
        }
    }
}

fn write_all(jobs: Receiver<Vec<Job>>, pending: &AtomicUsize) {
    for step in jobs {
        for job in step {
            job();
        }
        pending.fetch_sub(1, Ordering::AcqRel);
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

    /// What the jobs ran: `(step, k)` and the thread each ran on.
    type Log = Arc<Mutex<Vec<(usize, usize, std::thread::ThreadId)>>>;

    /// Makes job `k` of `step`: it waits for `gate`, then logs itself.
    fn maker(log: &Log, gate: &Arc<Mutex<()>>) -> impl Fn(usize, usize) -> Job + Send + 'static {
        let (l, g) = (log.clone(), gate.clone());
        move |step, k| {
            let (log, gate) = (l.clone(), g.clone());
            Box::new(move || {
                drop(gate.lock().unwrap());
                log.lock()
                    .unwrap()
                    .push((step, k, std::thread::current().id()));
            })
        }
    }

    /// Jobs run in the order queued, across steps, and all of them before the writer is
    /// dropped; a step finding [`QUEUE_STEPS`] steps queued waits for the thread.
    #[test]
    fn every_job_runs_in_order_with_back_pressure() {
        let log: Log = Arc::default();
        let gate = Arc::new(Mutex::new(()));
        let mut writer = Writer::start().unwrap();
        let held = gate.lock().unwrap();
        let job = maker(&log, &gate);
        // steps too big to be written inline: the thread takes step 0 and blocks in its
        // first job; two more fill the queue
        let n = INLINE_MAX + 1;
        for step in 0..QUEUE_STEPS + 1 {
            writer.submit((0..n).map(|k| job(step, k)).collect());
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let blocked = std::thread::spawn(move || {
            writer.submit((0..n).map(|k| job(QUEUE_STEPS + 1, k)).collect());
            // a small step behind queued ones goes through the queue too (order kept)
            writer.submit(vec![job(QUEUE_STEPS + 2, 0)]);
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
        let got: Vec<_> = log.lock().unwrap().iter().map(|e| (e.0, e.1)).collect();
        let mut want: Vec<_> = (0..QUEUE_STEPS + 2)
            .flat_map(|s| (0..n).map(move |k| (s, k)))
            .collect();
        want.push((QUEUE_STEPS + 2, 0));
        assert_eq!(got, want, "every job, in order, before the drop returns");
    }

    /// A small step is written on the calling thread when the publisher thread is idle, and
    /// on the publisher thread when it is not (after what it has in hand).
    #[test]
    fn a_small_step_is_written_inline_when_the_thread_is_idle() {
        let log: Log = Arc::default();
        let gate = Arc::new(Mutex::new(()));
        let mut writer = Writer::start().unwrap();
        let job = maker(&log, &gate);
        let here = std::thread::current().id();
        writer.submit(vec![job(0, 0), job(0, 1)]);
        assert_eq!(
            log.lock().unwrap().len(),
            2,
            "written before submit returns"
        );
        let held = gate.lock().unwrap();
        writer.submit((0..INLINE_MAX + 1).map(|k| job(1, k)).collect());
        writer.submit(vec![job(2, 0)]);
        drop(held);
        drop(writer);
        let log = log.lock().unwrap();
        assert!(log[..2].iter().all(|e| e.2 == here), "idle: inline");
        assert!(log[2..].iter().all(|e| e.2 != here), "busy: on the thread");
        let order: Vec<_> = log.iter().map(|e| (e.0, e.1)).collect();
        let mut want = vec![(0, 0), (0, 1)];
        want.extend((0..INLINE_MAX + 1).map(|k| (1, k)));
        want.push((2, 0));
        assert_eq!(order, want);
    }
}
