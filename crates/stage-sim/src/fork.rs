//! Values that belong to the process that made them, so that a forked child never uses its
//! parent's.
//!
//! `fork` copies a process's memory but only the calling thread. Anything that owns threads (a
//! worker pool, a graphics driver's device) is then, in the child, memory whose threads do not
//! exist: work handed to it waits forever. Python's `multiprocessing`, Gymnasium's
//! `AsyncVectorEnv` and Stable-Baselines3's `SubprocVecEnv` start their workers that way on
//! Linux, often after the parent has stepped or rendered a world.

use std::marker::PhantomData;
use std::sync::atomic::{AtomicPtr, Ordering};

/// A lazily made value, one per process: made on first use, and made again on first use in a
/// child forked after the parent made its own.
///
/// Each process's value is leaked on purpose: a child must neither use its parent's (its
/// threads are gone) nor drop it (that would signal those threads through locks another parent
/// thread may have held at the fork). One value per fork generation is kept, no more.
pub struct PerProcess<T: 'static> {
    current: AtomicPtr<Made<T>>,
    /// Shares and sends as a `&T` would.
    _owns: PhantomData<T>,
}

/// A value and the process that made it.
struct Made<T> {
    pid: u32,
    value: T,
}

impl<T: 'static> PerProcess<T> {
    /// Nothing made yet (for a `static`).
    pub const fn new() -> Self {
        PerProcess {
            current: AtomicPtr::new(std::ptr::null_mut()),
            _owns: PhantomData,
        }
    }

    /// This process's value, made by `make` if this process has none yet. Should two threads
    /// race to make the first one, one value wins and the other is dropped unused.
    pub fn get_or_make(&'static self, make: impl FnOnce() -> T) -> &'static T {
        let pid = std::process::id();
        let seen = self.current.load(Ordering::Acquire);
        // SAFETY: every pointer stored here comes from Box::into_raw and is never freed.
        if let Some(current) = unsafe { seen.as_ref() }
            && current.pid == pid
        {
            return &current.value;
        }
        let made = Box::into_raw(Box::new(Made { pid, value: make() }));
        match self
            .current
            .compare_exchange(seen, made, Ordering::AcqRel, Ordering::Acquire)
        {
            // SAFETY: just made from a Box, and from now on never freed
            Ok(_) => unsafe { &(*made).value },
            Err(now) => {
                // SAFETY: `made` was never published, so this is its only owner
                drop(unsafe { Box::from_raw(made) });
                // SAFETY: as above; another thread of this process stored it just now
                &unsafe { &*now }.value
            }
        }
    }
}

impl<T: 'static> Default for PerProcess<T> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_value_per_process_made_once() {
        static VALUE: PerProcess<Vec<u32>> = PerProcess::new();
        let a = VALUE.get_or_make(|| vec![1, 2]);
        let b = VALUE.get_or_make(|| unreachable!("made already"));
        assert!(std::ptr::eq(a, b));
        assert_eq!(b, &[1, 2]);
    }
}
