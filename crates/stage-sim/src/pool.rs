//! Where a simulation loop should run so that its steps use every core cheaply.
//!
//! A step splits its work (sensor updates, long ray fans, controllers) over rayon's pool. Called
//! from a thread outside the pool, every split first hands the work to the pool and then wakes
//! the caller when it is done: about 10 µs each way on a 2-core VM, as long as a whole
//! simple.world step. Run from one of the pool's own threads, the same split is a
//! work-stealing `join` that costs well under a microsecond while the other workers are busy.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use crate::fork::PerProcess;

/// Runs `body` (typically a loop of [`crate::World::step`]) on a thread of the simulation's
/// thread pool ([`sim_pool`]) and returns its result; the calling thread waits. Results are the
/// same wherever the steps run: this only changes how cheaply they use the other cores. Called
/// from a thread of a rayon pool already (a caller's own pool, or inside another
/// `on_sim_threads`), `body` runs right there, on that pool.
pub fn on_sim_threads<R: Send>(body: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        return body();
    }
    sim_pool().install(body)
}

/// The simulation's thread pool of each process ([`sim_pool`]).
static SIM_POOL: PerProcess<rayon::ThreadPool> = PerProcess::new();

/// The pool that steps of this process run on, made on first use with rayon's default size
/// (`RAYON_NUM_THREADS`, else one thread per core).
///
/// Why not rayon's global pool: it is made once per program, so a child forked after its parent
/// stepped a world (Python's `multiprocessing` and Gymnasium's `AsyncVectorEnv` with `fork`)
/// would hand its steps to the parent's threads, which do not exist in the child, and hang.
/// This pool is made anew in each process that uses it ([`PerProcess`]): a forked child's first
/// step makes its own, as fast as a fresh process's, and the parent's pool is left alone.
pub fn sim_pool() -> &'static rayon::ThreadPool {
    SIM_POOL.get_or_make(|| {
        rayon::ThreadPoolBuilder::new()
            .thread_name(|i| format!("stage-sim-{i}"))
            .build()
            .unwrap_or_else(|e| panic!("cannot start the simulation's worker threads: {e}"))
    })
}

/// Spins (`PAUSE`: 10-140 cycles) before the caller starts yielding: 0.05-0.8 ms, many times
/// a block's work and at most a scheduler slice.
const SPINS_BEFORE_YIELDING: u32 = 1 << 14;

/// Calls `work` on consecutive blocks of `grain` indices covering `0..n`, shared out between
/// the calling thread and the pool's other threads: each claims the next unclaimed block (an
/// atomic counter) until none is left. The caller starts at once and helpers join whenever
/// they come free, so a late helper costs nothing and no thread waits for a fixed share that
/// happens to hold the slower items. The caller then spins until every claimed block is done,
/// at most one block's time: a work-stealing join would instead yield the core while waiting
/// and be woken microseconds late (a whole 180-ray fan takes ~10 µs). Each thread's `work` gets
/// that thread's own `state()` (its blocks come in increasing order); `work` must not wait for
/// the caller.
pub(crate) fn share_out<S>(
    n: usize,
    grain: usize,
    state: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, Range<usize>) + Sync,
) {
    let grain = grain.max(1);
    let blocks = n.div_ceil(grain);
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let claim = || {
        let mut mine = state();
        loop {
            let b = next.fetch_add(1, Ordering::Relaxed);
            if b >= blocks {
                break;
            }
            // counted done even if `work` panics, so that the caller stops waiting and the
            // join hands the panic on
            let _counted = CountOnDrop(&done);
            work(&mut mine, b * grain..((b + 1) * grain).min(n));
        }
    };
    // one helper per other pool thread, as far as there are blocks for them
    let helpers = rayon::current_num_threads()
        .saturating_sub(1)
        .min(blocks.saturating_sub(1));
    if helpers == 0 {
        claim();
        return;
    }
    rayon::join(
        || {
            claim();
            // the helpers' last blocks end soon; should one have lost its core meanwhile, stop
            // burning this one after a while
            let mut spins = 0u32;
            while done.load(Ordering::Acquire) < blocks {
                if spins < SPINS_BEFORE_YIELDING {
                    spins += 1;
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
            }
        },
        || more_helpers(helpers - 1, &claim),
    );
}

/// Runs `serial` (a step's ordered part, which one thread must do alone) on the calling thread
/// while one other thread of the pool spins until it is done, instead of falling asleep a few
/// tens of microseconds into it and being woken late for the parallel part that follows.
/// Outside the pool, or in a pool of one, it just runs `serial`.
pub(crate) fn keeping_a_helper_awake<R: Send>(serial: impl FnOnce() -> R + Send) -> R {
    if !has_a_helper() {
        return serial();
    }
    let done = AtomicBool::new(false);
    let (r, ()) = rayon::join(
        || {
            // set even if `serial` panics, so that the helper stops and the join hands the
            // panic on
            let _done = SetOnDrop(&done);
            serial()
        },
        || {
            let mut spins = 0u32;
            while !done.load(Ordering::Acquire) {
                if spins < SPINS_BEFORE_YIELDING {
                    spins += 1;
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
            }
        },
    );
    r
}

/// Runs `main` on this thread and `side` on another thread of the pool at the same time, and
/// returns when both are done; a `side` that splits its work with rayon is finished by both
/// threads once `main` is done. Outside the pool, or in a pool of one, it runs `main` and then
/// `side`.
pub(crate) fn side_by_side(main: impl FnOnce() + Send, side: impl FnOnce() + Send) {
    if !has_a_helper() {
        main();
        side();
        return;
    }
    rayon::join(main, side);
}

/// Whether the caller runs on a thread of a pool that has another thread to help it.
fn has_a_helper() -> bool {
    rayon::current_thread_index().is_some() && rayon::current_num_threads() >= 2
}

/// A rayon pool of `threads` threads, for running a world's parallel paths in a test.
#[cfg(test)]
pub(crate) fn pool_of(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a test pool")
}

/// Sets its flag when dropped.
struct SetOnDrop<'a>(&'a AtomicBool);

impl Drop for SetOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}

/// Adds one to its counter when dropped (a block's work ended, returning or unwinding).
struct CountOnDrop<'a>(&'a AtomicUsize);

impl Drop for CountOnDrop<'_> {
    fn drop(&mut self) {
        self.0.fetch_add(1, Ordering::Release);
    }
}

/// Runs `claim` here and on `k` more pool threads.
fn more_helpers(k: usize, claim: &(impl Fn() + Sync)) {
    if k == 0 {
        claim();
    } else {
        rayon::join(claim, || more_helpers(k - 1, claim));
    }
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

    /// A panic in any thread's block reaches the caller instead of leaving it waiting.
    #[test]
    fn a_panicking_block_is_handed_on() {
        let pool = pool_of(4);
        for bad in [0, 37, 99] {
            let got = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                pool.install(|| {
                    share_out(
                        100,
                        1,
                        || (),
                        |_, r| {
                            // slow enough that the helpers take some blocks
                            std::thread::sleep(std::time::Duration::from_micros(50));
                            assert!(r.start != bad, "block {bad}");
                        },
                    )
                })
            }));
            assert!(got.is_err(), "block {bad}");
        }
    }

    /// On a pool of two the side work runs while the main work does (the main work here waits,
    /// boundedly, for a flag only the side work sets); outside a pool both run, main first.
    #[test]
    fn side_work_runs_beside_the_main_work() {
        let pool = pool_of(2);
        let side_ran = AtomicBool::new(false);
        let seen = pool.install(|| {
            let mut seen = false;
            side_by_side(
                || {
                    let start = std::time::Instant::now();
                    while start.elapsed() < std::time::Duration::from_secs(10) {
                        if side_ran.load(Ordering::Acquire) {
                            seen = true;
                            break;
                        }
                        std::hint::spin_loop();
                    }
                },
                || side_ran.store(true, Ordering::Release),
            );
            seen
        });
        assert!(seen, "the side work did not run during the main work");
        let order = std::sync::Mutex::new(Vec::new());
        side_by_side(
            || order.lock().unwrap().push("main"),
            || order.lock().unwrap().push("side"),
        );
        assert_eq!(*order.lock().unwrap(), ["main", "side"]);
    }

    /// The serial part's result comes back, and a panic in it reaches the caller instead of
    /// leaving the spinning helper (and the join waiting for it) running for ever.
    #[test]
    fn a_serial_part_returns_or_hands_its_panic_on() {
        let pool = pool_of(2);
        assert_eq!(pool.install(|| keeping_a_helper_awake(|| 6 * 7)), 42);
        let got = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pool.install(|| keeping_a_helper_awake(|| -> u32 { panic!("serial") }))
        }));
        assert!(got.is_err());
        // outside any pool it simply runs
        assert_eq!(keeping_a_helper_awake(|| 1), 1);
    }

    #[test]
    fn every_index_is_worked_once() {
        use std::sync::atomic::AtomicU32;
        for (n, grain) in [(0, 4), (1, 4), (180, 8), (181, 8), (7, 1), (5, 0)] {
            let seen: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(0)).collect();
            on_sim_threads(|| {
                share_out(
                    n,
                    grain,
                    || 0,
                    |last, r| {
                        assert!(r.len() <= grain.max(1) && !r.is_empty());
                        // each thread's blocks come in increasing order
                        assert!(r.start >= *last);
                        *last = r.end;
                        r.for_each(|i| {
                            seen[i].fetch_add(1, Ordering::Relaxed);
                        })
                    },
                )
            });
            assert!(seen.iter().all(|c| c.load(Ordering::Relaxed) == 1), "n {n}");
        }
    }
}
