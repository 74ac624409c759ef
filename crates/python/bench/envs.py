#!/usr/bin/env python3
"""Environment steps per second of `playerstage.envs`, side by side, printed one line each:

- one diff-drive robot with a 180-ray laser among three boxes in a walled 8 m square (the
  world below), the built-in goal task, random actions, episodes of 500 steps;
- a single `StageEnv`; `VectorStageEnv` with 1, 8 and 64 copies; Gymnasium's `SyncVectorEnv`
  of 8 and 64 `StageEnv`s; and IR-SIM (`ir-sim` on PyPI) on the same task: one diff-drive
  robot, a 180-beam 2D lidar of the same range, the same boxes and walls, no display.

IR-SIM is not a dependency of the package or its tests: give the Python that has it with
`--irsim-python` (e.g. a separate venv: `python3 -m venv /tmp/irsim && /tmp/irsim/bin/pip
install ir-sim`); this script runs its IR-SIM part there, in a subprocess. Vector figures count
every copy's steps (a vector step of 64 copies is 64 environment steps). Scaling: 64 copies
run in subprocesses whose simulation pool has 1 thread and then one per core
(`RAYON_NUM_THREADS`), in turn, `--repeat` times each (the best of each kept), for
VectorStageEnv(64) and for the bare simulation (`step_worlds` of the vector env's 64 worlds as
it left them, what the copies' steps cost without Python); the figure is the measured
wall-clock speed-up over the core count. Wall-clock speed-ups mean little on a machine busy
with other work, so the last line also breaks a vector step's CPU time down on one thread: the
bare steps, the rest, and what ran on the calling thread (the serial part: Python, argument
handling, resets' Python side; the pool's threads do the simulation, the readings and the
scoring), with the speed-up Amdahl's law allows with that serial part, and with all of the
step beyond the bare steps counted serial (a looser bound).

    target/python-venv/bin/python crates/python/bench/envs.py \
        --irsim-python /tmp/irsim/bin/python [--seconds 3] [--repeat 3]
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# One diff-drive robot, a 180-sample laser over 180 degrees reaching 4 m, three boxes, walls:
# the tests' world (worlds/boxes.world).
WORLD = Path(__file__).resolve().parents[3] / "worlds" / "boxes.world"

# The same scene for IR-SIM (world 8 m square from -4 to 4 shifted to 0..8; 0.1 s steps).
IRSIM_YAML = """
world:
  height: 8
  width: 8
  step_time: 0.1
  sample_time: 0.1
  offset: [0, 0]
  collision_mode: 'stop'

robot:
  - kinematics: {name: 'diff'}
    shape: {name: 'circle', radius: 0.2}
    state: [4, 4, 0]
    goal: [7, 7, 0]
    vel_max: [0.8, 1.0]
    sensors:
      - type: 'lidar2d'
        range_min: 0
        range_max: 4
        angle_range: 3.14159
        number: 180

obstacle:
  - shape: {name: 'rectangle', length: 0.5, width: 0.5}
    state: [6, 4, 0]
  - shape: {name: 'rectangle', length: 0.5, width: 0.5}
    state: [2.5, 5.5, 0]
  - shape: {name: 'rectangle', length: 0.5, width: 0.5}
    state: [4, 2, 0]
  - shape: {name: 'linestring', vertices: [[0, 0], [8, 0], [8, 8], [0, 8], [0, 0]]}
    kinematics: {name: 'static'}
"""

EPISODE = 500


def rate(step, seconds, clock=time.perf_counter):
    """Calls of `step()` per second of `clock` over about `seconds` of it (after a short
    warm-up)."""
    for _ in range(20):
        step()
    n, t0 = 0, clock()
    while True:
        for _ in range(50):
            step()
        n += 50
        dt = clock() - t0
        if dt >= seconds:
            return n / dt


def random_actions(space, count=256):
    """`count` random actions of `space`, drawn before timing (a policy's cost is not the
    environment's) and taken in turn."""
    import itertools

    import numpy as np

    rng = np.random.default_rng(0)
    return itertools.cycle([rng.uniform(space.low, space.high) for _ in range(count)])


def bench_single(world, seconds):
    from playerstage.envs import StageEnv

    env = StageEnv(world, "r0", max_episode_steps=EPISODE)
    env.reset(seed=0)
    actions = random_actions(env.action_space)

    def step():
        _, _, term, trunc, _ = env.step(next(actions))
        if term or trunc:
            env.reset()

    return rate(step, seconds)


def bench_vector(make, n, seconds, clock=time.perf_counter):
    vec = make(n)
    vec.reset(seed=0)
    actions = random_actions(vec.action_space)

    def step():
        vec.step(next(actions))

    r = rate(step, seconds, clock) * n
    vec.close()
    return r


def bench_irsim(seconds):
    """Run inside the Python that has ir-sim: steps/s of one robot with its lidar, no display."""
    import irsim
    import numpy as np

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "bench.yaml"
        path.write_text(IRSIM_YAML)
        env = irsim.make(str(path), headless=True, log_level="ERROR")
    rng = np.random.default_rng(0)
    steps = [0]

    def step():
        action = np.array([[rng.uniform(-0.5, 0.8)], [rng.uniform(-1.0, 1.0)]])
        env.step(action)
        env.get_lidar_scan()
        steps[0] += 1
        if env.done() or steps[0] % EPISODE == 0:
            env.reset()

    r = rate(step, seconds)
    scan = env.get_lidar_scan()
    assert len(scan["ranges"]) == 180, scan
    return r


def bench_threads(world, n, seconds, clock=time.perf_counter):
    """VectorStageEnv(n) env steps/s and bare step_worlds world steps/s, on this process's
    pool (its size set by RAYON_NUM_THREADS before the first step), per second of `clock`."""
    from playerstage import _native
    from playerstage.envs import VectorStageEnv

    made = []

    def make(n):
        made.append(VectorStageEnv(n, world, "r0", max_episode_steps=EPISODE))
        return made[-1]

    env_rate = bench_vector(make, n, seconds, clock)
    # the same worlds as the vector env left them, stepped on with their last commands: the
    # simulation's share of its steps (robots that hit walls cost more than free ones)
    worlds = made[-1]._natives
    sim_rate = rate(lambda: _native.step_worlds(worlds, 1), seconds, clock) * n
    return env_rate, sim_rate


def main():
    ap = argparse.ArgumentParser(description="playerstage.envs steps per second")
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument(
        "--repeat",
        type=int,
        default=3,
        help="thread-scaling runs per pool size, alternating; the best of each is kept",
    )
    ap.add_argument(
        "--irsim-python", help="a Python with ir-sim installed (else IR-SIM is skipped)"
    )
    ap.add_argument("--irsim-worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--threads-worker", help=argparse.SUPPRESS)
    o = ap.parse_args()
    if o.irsim_worker:
        print(bench_irsim(o.seconds))
        return
    if o.threads_worker:
        print(*bench_threads(o.threads_worker, 64, o.seconds))
        if o.repeat == 0 and os.environ.get("RAYON_NUM_THREADS") == "1":
            # CPU time on one thread: what a busy machine distorts least; the process's, then
            # the calling thread's alone (the pool's threads step, read and score the copies)
            print(*bench_threads(o.threads_worker, 64, o.seconds, time.process_time))
            # (a step's calling-thread share is small: a quarter of the time gives as many steps)
            print(*bench_threads(o.threads_worker, 64, o.seconds / 4, time.thread_time))
        return

    import gymnasium
    from playerstage.envs import StageEnv, VectorStageEnv

    cores = len(os.sched_getaffinity(0))
    out = {}
    with tempfile.TemporaryDirectory() as d:
        world = Path(d) / "bench.world"
        world.write_text(WORLD.read_text())
        kw = dict(max_episode_steps=EPISODE)
        out["StageEnv"] = bench_single(world, o.seconds)
        for n in (1, 8, 64):
            out[f"VectorStageEnv({n})"] = bench_vector(
                lambda n: VectorStageEnv(n, world, "r0", **kw), n, o.seconds
            )
        for n in (8, 64):
            out[f"SyncVectorEnv({n})"] = bench_vector(
                lambda n: gymnasium.vector.SyncVectorEnv(
                    [lambda: StageEnv(world, "r0", **kw)] * n
                ),
                n,
                o.seconds,
            )
        def worker(t, cpu_too):
            """The thread-scaling worker's lines with a pool of `t` threads (with the CPU
            time runs when `cpu_too`, `--repeat 0` telling the worker so)."""
            run = subprocess.run(
                [sys.executable, __file__, "--threads-worker", str(world)]
                + ["--seconds", str(o.seconds), "--repeat", "0" if cpu_too else "1"],
                capture_output=True,
                text=True,
                env={**os.environ, "RAYON_NUM_THREADS": str(t)},
            )
            if run.returncode != 0:
                sys.exit(f"thread scaling run failed:\n{run.stderr}")
            return [[float(x) for x in line.split()] for line in run.stdout.strip().splitlines()]

        # wall clock: 1 thread and one per core in turn, `repeat` times each, the best of each
        # kept (other work on the machine only ever slows a run down)
        threads = {1: [0.0, 0.0], cores: [0.0, 0.0]}
        for _ in range(max(o.repeat, 1)):
            for t in (1, cores):
                threads[t] = [max(a, b) for a, b in zip(threads[t], worker(t, False)[0])]
        lines = worker(1, True)
        cpu, calling = lines[1], lines[2][0]
    if o.irsim_python:
        run = subprocess.run(
            [o.irsim_python, __file__, "--irsim-worker", "--seconds", str(o.seconds)],
            capture_output=True,
            text=True,
        )
        if run.returncode != 0:
            sys.exit(f"IR-SIM run failed:\n{run.stderr}")
        out["IR-SIM"] = float(run.stdout.strip().splitlines()[-1])

    print(f"environment steps/s, 1 robot with a 180-ray laser ({cores} cores):")
    for name, r in out.items():
        line = f"  {name:<20} {r:>12,.0f}"
        if "IR-SIM" in out and name != "IR-SIM":
            line += f"   {r / out['IR-SIM']:6.1f}x IR-SIM"
        print(line)
    whats = ("VectorStageEnv(64) env steps/s", "bare step_worlds(64) world steps/s")
    for k, what in enumerate(whats):
        one, all_ = threads[1][k], threads[cores][k]
        print(
            f"  {what}: {one:,.0f} on 1 thread, {all_:,.0f} on {cores}: "
            f"{all_ / one:.2f}x ({100 * all_ / one / cores:.0f}% of linear)"
        )
    # on a busy machine the bare simulation itself falls short of linear: how much of its
    # speed-up the environment keeps tells the environment's share apart from the machine's
    env_up, sim_up = (threads[cores][k] / threads[1][k] for k in (0, 1))
    print(
        f"  VectorStageEnv(64)'s speed-up is {100 * env_up / sim_up:.0f}% of the bare "
        f"simulation's in the same runs"
    )
    # Amdahl from CPU time on one thread. What ran on the calling thread is the serial part
    # (the pool's threads did the rest): it bounds the speed-up on `cores` cores. Counting all
    # of a vector step beyond the bare steps serial (the readings and scoring too, which run
    # on the pool) gives a looser bound.
    step_us, sim_us, serial_us = 64e6 / cpu[0], 64e6 / cpu[1], 64e6 / calling
    rest = max(step_us - sim_us, 0.0) / step_us
    serial = min(serial_us / step_us, 1.0)

    def amdahl(s):
        b = 1 / (s + (1 - s) / cores)
        return f"{b:.2f}x ({100 * b / cores:.0f}% of linear)"

    print(
        f"  one 64-copy vector step, 1 thread, CPU time: {step_us:,.0f} us, of which bare "
        f"steps {sim_us:,.0f} us, on the calling thread (serial) {serial_us:,.0f} us "
        f"({100 * serial:.0f}%): Amdahl bounds {cores} cores to {amdahl(serial)}; counting "
        f"all beyond the bare steps ({100 * rest:.0f}%) serial: {amdahl(rest)}"
    )


if __name__ == "__main__":
    main()
