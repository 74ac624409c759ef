//! A process forked after its parent stepped worlds steps worlds too: a new one, and the one it
//! inherited, with the same results as the parent (issue: the child of a process that had used
//! the simulation's thread pool waited forever on the parent's threads, which fork does not
//! copy). The parent checks the child under a timeout, so a regression fails instead of hanging.

use std::io::{Read, Write};
use std::os::fd::FromRawFd;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use stage_sim::{World, on_sim_threads};

/// How long the child may take before it counts as hung (it needs well under a second).
const CHILD_TIMEOUT: Duration = Duration::from_secs(60);

/// A room of 64 wandering robots with 181-ray lasers: enough rays for the step's parallel
/// updates and enough controllers for its parallel controllers, on every thread count.
fn crowd_world(threads: u32) -> PathBuf {
    let mut text = format!(
        "resolution 0.02\ninterval_sim 100\nthreads {threads}\n\
         define bot position (\n  size [0.4 0.4 0.3]\n  drive \"diff\"\n  ctrl \"wander\"\n  \
         ranger ( sensor ( range [0 4] fov 180 samples 181 ) )\n)\n"
    );
    for (name, x, y, sx, sy) in [
        ("north", 0.0, 6.0, 12.2, 0.2),
        ("south", 0.0, -6.0, 12.2, 0.2),
        ("east", 6.0, 0.0, 0.2, 12.2),
        ("west", -6.0, 0.0, 0.2, 12.2),
    ] {
        text += &format!("model ( name \"{name}\" size [{sx} {sy} 1] pose [{x} {y} 0 0] )\n");
    }
    for i in 0..64 {
        let (x, y) = ((i % 8) as f64 * 1.3 - 4.5, (i / 8) as f64 * 1.3 - 4.5);
        text += &format!("bot ( name \"r{i}\" pose [{x} {y} 0 {}] )\n", i * 37 % 360);
    }
    let path = std::env::temp_dir().join(format!(
        "stage-sim-fork-{}-{threads}.world",
        std::process::id()
    ));
    std::fs::write(&path, text).expect("writing the test world");
    path
}

fn stepped(world: &mut World, steps: usize) -> u64 {
    for _ in 0..steps {
        world.step();
    }
    world.state_digest()
}

/// Forks; the child runs `child` and writes what it returns to the parent, which waits for it at
/// most [`CHILD_TIMEOUT`] (killing it then) and returns its output, or why there is none.
fn in_forked_child(child: impl FnOnce() -> Vec<u64>) -> Result<Vec<u64>, String> {
    let mut fds = [0; 2];
    // SAFETY: a plain pipe(2) into a two-int array
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0, "pipe");
    // SAFETY: the child only runs Rust code of this test and leaves through _exit
    let pid = unsafe { libc::fork() };
    assert!(pid >= 0, "fork failed");
    if pid == 0 {
        // SAFETY: the pipe's fds are ours
        let mut out = unsafe { std::fs::File::from_raw_fd(fds[1]) };
        let code = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(child)) {
            Ok(values) => {
                let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
                i32::from(out.write_all(&bytes).is_err())
            }
            Err(_) => 2,
        };
        // SAFETY: leave without running the test harness's exit handlers in the child
        unsafe { libc::_exit(code) };
    }
    // SAFETY: closing the parent's copy of the write end, so that reads end with the child
    unsafe { libc::close(fds[1]) };
    let start = Instant::now();
    let mut status = 0;
    loop {
        // SAFETY: waiting for our own child
        let r = unsafe { libc::waitpid(pid, &mut status, libc::WNOHANG) };
        if r == pid {
            break;
        }
        if start.elapsed() > CHILD_TIMEOUT {
            // SAFETY: killing and reaping our own child
            unsafe {
                libc::kill(pid, libc::SIGKILL);
                libc::waitpid(pid, &mut status, 0);
                libc::close(fds[0]);
            }
            return Err(format!("the forked child hung for {CHILD_TIMEOUT:?}"));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: the read end is ours
    let mut input = unsafe { std::fs::File::from_raw_fd(fds[0]) };
    let mut bytes = Vec::new();
    input
        .read_to_end(&mut bytes)
        .expect("reading the child's answer");
    if !libc::WIFEXITED(status) || libc::WEXITSTATUS(status) != 0 {
        return Err(format!("the forked child failed (wait status {status:#x})"));
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().unwrap()))
        .collect())
}

/// The parent steps a world (directly and through `on_sim_threads`), forks, and both go on:
/// the child steps its inherited copy and a freshly loaded world, the parent its own copy.
/// Same digests everywhere, and the child finishes.
fn child_steps_after_parent_stepped(threads: u32) {
    let path = crowd_world(threads);
    let (mut world, _) = World::load(&path, 3).expect("the test world loads");
    stepped(&mut world, 5);
    on_sim_threads(|| stepped(&mut world, 5));

    let from_child = in_forked_child(|| {
        let inherited = stepped(&mut world, 20);
        let (mut fresh, _) = World::load(&path, 3).expect("the test world loads in the child");
        let fresh = on_sim_threads(|| stepped(&mut fresh, 30));
        vec![inherited, fresh]
    });
    let in_parent = stepped(&mut world, 20);
    std::fs::remove_file(&path).ok();

    let from_child = from_child.unwrap_or_else(|e| panic!("threads {threads}: {e}"));
    assert_eq!(
        from_child,
        vec![in_parent, in_parent],
        "threads {threads}: the child's inherited and fresh worlds end where the parent's does"
    );
}

#[test]
fn a_child_forked_after_stepping_steps_worlds() {
    child_steps_after_parent_stepped(1);
}

#[test]
fn a_child_forked_after_stepping_steps_worlds_of_several_threads() {
    child_steps_after_parent_stepped(4);
}
