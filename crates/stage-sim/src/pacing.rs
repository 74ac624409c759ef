//! Real-time pacing of a stepping loop, shared by every front door that steps a world on its
//! own (the world window's simulation thread, the ROS 2 bridge's headless loop), so that all
//! follow one rule for `speedup` and for falling behind.

use std::time::{Duration, Instant};

/// How far behind its schedule a paced loop may fall before it gives up catching up: a slow
/// world then runs at its own pace instead of in a burst of back-to-back steps.
const MAX_LAG: Duration = Duration::from_millis(250);

/// Wall time per step at `speedup` times real time for a world stepping `interval_sim_us`;
/// `None` (as fast as possible) when `speedup` is not a positive finite number.
pub fn step_wall(interval_sim_us: u64, speedup: f64) -> Option<Duration> {
    (speedup > 0.0 && speedup.is_finite())
        .then(|| Duration::from_secs_f64(interval_sim_us as f64 * 1e-6 / speedup))
}

/// Keeps a loop at one step per [`step_wall`]: call [`Pacer::wait`] after every step.
#[derive(Clone, Debug)]
pub struct Pacer {
    step_wall: Option<Duration>,
    next: Instant,
}

impl Pacer {
    /// A pacer whose schedule starts now.
    pub fn new(interval_sim_us: u64, speedup: f64) -> Self {
        Pacer {
            step_wall: step_wall(interval_sim_us, speedup),
            next: Instant::now(),
        }
    }

    /// Sleeps until the next step is due; more than [`MAX_LAG`] behind, the schedule restarts
    /// from now. Returns at once when unpaced.
    pub fn wait(&mut self) {
        if let Some(d) = self.step_wall {
            self.next += d;
            let now = Instant::now();
            if self.next > now {
                std::thread::sleep(self.next - now);
            } else if now - self.next > MAX_LAG {
                self.next = now;
            }
        }
    }

    /// Starts the schedule again from now (after a pause, so no steps are owed for it).
    pub fn restart(&mut self) {
        self.next = Instant::now();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_wall_scales_with_speedup_and_is_none_unpaced() {
        assert_eq!(step_wall(100_000, 1.0), Some(Duration::from_millis(100)));
        assert_eq!(step_wall(100_000, 4.0), Some(Duration::from_millis(25)));
        assert_eq!(step_wall(100_000, 0.0), None);
        assert_eq!(step_wall(100_000, -1.0), None);
        assert_eq!(step_wall(100_000, f64::INFINITY), None);
    }

    #[test]
    fn a_paced_loop_keeps_its_schedule() {
        let mut p = Pacer::new(10_000, 1.0); // 10 ms a step
        let start = Instant::now();
        for _ in 0..5 {
            p.wait();
        }
        assert!(start.elapsed() >= Duration::from_millis(50));
    }

    #[test]
    fn far_behind_the_schedule_restarts_instead_of_bursting() {
        let mut p = Pacer::new(10_000, 1.0);
        std::thread::sleep(Duration::from_millis(400)); // 40 steps owed, beyond MAX_LAG
        p.wait();
        // the schedule now starts from the late step: the next wait sleeps about a step
        let t = Instant::now();
        p.wait();
        assert!(t.elapsed() >= Duration::from_millis(5));
    }
}
