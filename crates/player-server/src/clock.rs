//! Time: the server clock every timestamp comes from, and the schedule drivers are stepped on.
//!
//! Each driver has its own step (Stage: `interval_sim`). The schedule keeps, per driver, the
//! server-time instant of its next update and runs them in time order. In real time that
//! instant is waited for on the wall clock (scaled by a speed-up factor); as fast as possible
//! it is not waited for at all, and the core only answers pending client messages between
//! steps. Either way a driver is stepped in its own step, so simulated time advances by exactly
//! one step per update whatever the pace.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Step of a driver that names none: upstream's main loop runs at least every 10 ms.
pub const DEFAULT_STEP: Duration = Duration::from_millis(10);

/// How fast the schedule runs against the wall clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pace {
    /// Each step waits for its wall-clock time, divided by `speedup` (1 = real time, as
    /// Player/Stage with a GUI runs).
    RealTime {
        /// Server seconds per wall second (> 0).
        speedup: f64,
    },
    /// No waiting: step as fast as the drivers compute, answering clients between steps.
    AsFastAsPossible,
}

impl Default for Pace {
    fn default() -> Self {
        Pace::RealTime { speedup: 1.0 }
    }
}

/// The server clock, shared by the core (which sets it) and the connection writers (which
/// stamp SYNCH messages with it).
///
/// Wall-clock seconds since the Unix epoch, as upstream's default `WallclockTime`, until a
/// driver supplies simulated time (Stage replaces Player's clock); from then on the last value
/// that driver reported.
#[derive(Clone, Debug, Default)]
pub struct ServerClock {
    inner: Arc<ClockCell>,
}

#[derive(Debug, Default)]
struct ClockCell {
    simulated: AtomicBool,
    seconds: AtomicU64,
}

impl ServerClock {
    /// A wall clock.
    pub fn new() -> ServerClock {
        ServerClock::default()
    }

    /// Seconds now.
    pub fn now(&self) -> f64 {
        if self.inner.simulated.load(Ordering::Acquire) {
            f64::from_bits(self.inner.seconds.load(Ordering::Acquire))
        } else {
            wall_seconds()
        }
    }

    /// Switches to (or advances) simulated time.
    pub fn set_simulated(&self, seconds: f64) {
        self.inner
            .seconds
            .store(seconds.to_bits(), Ordering::Release);
        self.inner.simulated.store(true, Ordering::Release);
    }

    /// True once a driver supplies the time.
    pub fn is_simulated(&self) -> bool {
        self.inner.simulated.load(Ordering::Acquire)
    }
}

/// Seconds since the Unix epoch.
pub fn wall_seconds() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// Per-driver timing state.
#[derive(Clone, Debug)]
struct Slot {
    step: Duration,
    /// Server time (since start) of the next update.
    next: Duration,
    active: bool,
}

/// When the core should next step something.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Due {
    /// Something is due already.
    Now,
    /// Wait until this wall instant (or a client message).
    At(Instant),
    /// Nothing active: wait for client messages only.
    Never,
}

/// The stepping schedule of a server's drivers.
#[derive(Clone, Debug)]
pub struct Schedule {
    pace: Pace,
    start: Instant,
    /// Server time reached by the schedule (the time of the last step run).
    reached: Duration,
    /// The instant of the first pass: every driver's step grid starts there.
    origin: Option<Duration>,
    slots: Vec<Slot>,
}

/// A real-time schedule more than this many steps behind skips ahead instead of bursting.
const MAX_LAG_STEPS: u32 = 10;

impl Schedule {
    /// A schedule starting now with one slot per driver step, all inactive.
    pub fn new(pace: Pace, steps: impl IntoIterator<Item = Duration>) -> Schedule {
        Schedule {
            pace,
            start: Instant::now(),
            reached: Duration::ZERO,
            origin: None,
            slots: steps
                .into_iter()
                .map(|step| Slot {
                    step: step.max(Duration::from_micros(1)),
                    next: Duration::ZERO,
                    active: false,
                })
                .collect(),
        }
    }

    /// The pace.
    pub fn pace(&self) -> Pace {
        self.pace
    }

    /// Server time elapsed on the wall clock (real time) or reached by stepping (fast).
    fn server_elapsed(&self) -> Duration {
        match self.pace {
            Pace::RealTime { speedup } => self.start.elapsed().mul_f64(speedup),
            Pace::AsFastAsPossible => self.reached,
        }
    }

    /// Starts or stops stepping driver `slot`. A driver that starts is first due at the next
    /// instant of its step's grid (multiples of its step since the first pass; missed
    /// steps are not replayed), so that drivers with the same step run in the same pass, in
    /// cfg order: upstream updates every driver in each turn of its loop before writing to
    /// clients, and the blocks of one Stage world all publish right after the step that made
    /// their data. Started at whatever instant its first subscription came, a robot's block
    /// would publish in a pass of its own, and a PULL round could close between two robots.
    pub fn set_active(&mut self, slot: usize, active: bool) {
        let now = self.server_elapsed();
        let first = match self.origin {
            // Not in a pass already run: as fast as possible, `now` is that pass's instant.
            Some(origin) => {
                let after = now.max(self.reached + Duration::from_nanos(1));
                origin + grid_at_or_after(after.saturating_sub(origin), self.slots[slot].step)
            }
            // The first pass: now (it starts the grid).
            None => now,
        };
        let s = &mut self.slots[slot];
        if active && !s.active {
            s.next = s.next.max(first);
        }
        s.active = active;
    }

    fn earliest(&self) -> Option<Duration> {
        self.slots.iter().filter(|s| s.active).map(|s| s.next).min()
    }

    /// What to do next.
    pub fn due(&self) -> Due {
        let Some(next) = self.earliest() else {
            return Due::Never;
        };
        match self.pace {
            Pace::AsFastAsPossible => Due::Now,
            Pace::RealTime { speedup } => {
                let at = self.start + next.div_f64(speedup);
                if at <= Instant::now() {
                    Due::Now
                } else {
                    Due::At(at)
                }
            }
        }
    }

    /// The drivers due at the earliest pending instant, advancing their next time by one step.
    /// Empty when nothing is due yet.
    pub fn take_due(&mut self) -> Vec<usize> {
        if self.due() != Due::Now {
            return Vec::new();
        }
        let Some(t) = self.earliest() else {
            return Vec::new();
        };
        self.reached = self.reached.max(t);
        self.origin.get_or_insert(t);
        let now = self.server_elapsed();
        let mut due = Vec::new();
        for (i, s) in self.slots.iter_mut().enumerate() {
            if s.active && s.next == t {
                due.push(i);
                s.next += s.step;
                if matches!(self.pace, Pace::RealTime { .. })
                    && s.next + s.step * MAX_LAG_STEPS < now
                {
                    let origin = self.origin.unwrap_or_default();
                    let ahead = origin + grid_at_or_after(now.saturating_sub(origin), s.step);
                    tracing::warn!(
                        "driver steps take longer than real time; skipping ahead {:.3} s",
                        (ahead - s.next).as_secs_f64()
                    );
                    s.next = ahead;
                }
            }
        }
        due
    }
}

/// The first multiple of `step` at or after `t` (a driver's step grid).
fn grid_at_or_after(t: Duration, step: Duration) -> Duration {
    let step_ns = step.as_nanos().max(1);
    let n = t.as_nanos().div_ceil(step_ns);
    let ns = n.saturating_mul(step_ns);
    Duration::from_nanos(u64::try_from(ns).unwrap_or(u64::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_switches_to_simulated_time() {
        let c = ServerClock::new();
        assert!(c.now() > 1.0e9, "wall clock since the epoch");
        let shared = c.clone();
        shared.set_simulated(2.5);
        assert!(c.is_simulated());
        assert_eq!(c.now(), 2.5);
    }

    #[test]
    fn fast_schedule_interleaves_steps_in_time_order() {
        let mut s = Schedule::new(
            Pace::AsFastAsPossible,
            [Duration::from_millis(100), Duration::from_millis(30)],
        );
        assert_eq!(s.due(), Due::Never);
        s.set_active(0, true);
        s.set_active(1, true);
        let mut order = Vec::new();
        for _ in 0..8 {
            order.push(s.take_due());
        }
        // t=0: both; 30, 60, 90: driver 1; 100: driver 0; 120, 150, 180: driver 1.
        assert_eq!(
            order,
            [
                vec![0, 1],
                vec![1],
                vec![1],
                vec![1],
                vec![0],
                vec![1],
                vec![1],
                vec![1]
            ]
        );
        s.set_active(1, false);
        assert_eq!(s.take_due(), [0]);
        s.set_active(0, false);
        assert_eq!(s.due(), Due::Never);
        assert!(s.take_due().is_empty());
    }

    #[test]
    fn real_time_schedule_waits_for_the_wall_clock() {
        let mut s = Schedule::new(Pace::RealTime { speedup: 1.0 }, [Duration::from_millis(40)]);
        s.set_active(0, true);
        assert_eq!(s.take_due(), [0]);
        match s.due() {
            Due::At(at) => {
                let wait = at.saturating_duration_since(Instant::now());
                assert!(wait > Duration::from_millis(20) && wait <= Duration::from_millis(40));
            }
            other => panic!("{other:?}"),
        }
        assert!(s.take_due().is_empty());
        std::thread::sleep(Duration::from_millis(45));
        assert_eq!(s.take_due(), [0]);
    }

    #[test]
    fn speedup_shortens_the_wait() {
        let mut s = Schedule::new(
            Pace::RealTime { speedup: 10.0 },
            [Duration::from_millis(100)],
        );
        s.set_active(0, true);
        s.take_due();
        match s.due() {
            Due::At(at) => {
                assert!(at.saturating_duration_since(Instant::now()) <= Duration::from_millis(10))
            }
            Due::Now => {}
            Due::Never => panic!("active driver"),
        }
    }

    #[test]
    fn reactivated_driver_does_not_replay_missed_steps() {
        let mut s = Schedule::new(Pace::RealTime { speedup: 1.0 }, [Duration::from_millis(5)]);
        s.set_active(0, true);
        assert_eq!(s.take_due(), [0]);
        s.set_active(0, false);
        std::thread::sleep(Duration::from_millis(30));
        s.set_active(0, true);
        wait_due(&s);
        assert_eq!(s.take_due(), [0]);
        assert!(matches!(s.due(), Due::At(_)), "one step, not six");
    }

    /// Waits (at most a second) until something is due.
    fn wait_due(s: &Schedule) {
        let start = Instant::now();
        while s.due() != Due::Now {
            assert!(start.elapsed() < Duration::from_secs(1), "never due");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn drivers_with_one_step_started_apart_run_in_the_same_pass() {
        let step = Duration::from_millis(40);
        let mut s = Schedule::new(Pace::RealTime { speedup: 1.0 }, [step, step, step]);
        s.set_active(0, true);
        assert_eq!(s.take_due(), [0]);
        // Subscribed 7 ms into the step: first due with driver 0, at 40 ms.
        std::thread::sleep(Duration::from_millis(7));
        s.set_active(2, true);
        s.set_active(1, true);
        assert!(
            matches!(s.due(), Due::At(_)),
            "not before the step's instant"
        );
        wait_due(&s);
        assert_eq!(s.take_due(), [0, 1, 2], "one pass, in slot order");
        // As fast as possible too: a driver started between passes joins the next one.
        let mut f = Schedule::new(Pace::AsFastAsPossible, [step, step]);
        f.set_active(0, true);
        assert_eq!(f.take_due(), [0]);
        f.set_active(1, true);
        assert_eq!(f.take_due(), [0, 1]);
    }

    #[test]
    fn the_step_grid_rounds_up_to_a_multiple() {
        let ms = Duration::from_millis;
        assert_eq!(grid_at_or_after(ms(0), ms(100)), ms(0));
        assert_eq!(grid_at_or_after(ms(1), ms(100)), ms(100));
        assert_eq!(grid_at_or_after(ms(200), ms(100)), ms(200));
        assert_eq!(grid_at_or_after(ms(201), ms(100)), ms(300));
    }
}
