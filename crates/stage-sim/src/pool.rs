//! Where a simulation loop should run so that its steps use every core cheaply.
//!
//! A step splits its work (sensor updates, long ray fans, controllers) over rayon's pool. Called
//! from a thread outside the pool, every split first hands the work to the pool and then wakes
//! the caller when it is done: about 10 µs each way on a 2-core VM, as long as a whole
//! simple.world step. Run from one of the pool's own threads, the same split is a
//! work-stealing `join` that costs well under a microsecond while the other workers are busy.

/// Runs `body` (typically a loop of [`crate::World::step`]) on a thread of the simulation's
/// thread pool and returns its result; the calling thread waits. Results are the same wherever
/// the steps run: this only changes how cheaply they use the other cores.
pub fn on_sim_threads<R: Send>(body: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| body())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn body_runs_on_a_pool_thread_and_returns_its_value() {
        let (inside, v) = on_sim_threads(|| (rayon::current_thread_index().is_some(), 42));
        assert!(inside);
        assert_eq!(v, 42);
    }
}
