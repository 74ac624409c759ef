"""Benchmark of `playerstage sweep`'s local executor (issue 39).

    python crates/python/bench/sweep.py [--runs 60] [--robots 100] [--steps 6000] [--sample 6]

A sweep of RUNS runs (sensor range x seeds) of a ROBOTS-robot world of wandering robots, each
STEPS steps, prints:

- runs per minute on the local executor with 1 worker and with one per core (whole sweep:
  plan expansion and check, process pool, every result written to disk, summaries);
- the sweep machinery's overhead per run against stepping ``World`` alone: first in-process
  (``execute(spec)`` against loading the same worldfile text and stepping it, no tracking,
  no metrics), then for the whole 1-worker sweep (its wall time per run against the bare run).

Runs are interleaved (bare, execute, bare, ...) over SAMPLE specs so that load changes on a
busy machine hit both sides alike; the figures are medians.
"""

import argparse
import os
import statistics
import sys
import tempfile
import time

from playerstage import World
from playerstage.sweep import Plan, Store, execute
from playerstage.sweep import executors


def template(robots: int) -> str:
    side = int(robots ** 0.5 + 0.999)
    half = side * 0.6 + 0.6
    lines = [
        "resolution 0.02",
        "interval_sim 100",
        "define bot position ( size [0.3 0.3 0.2] drive \"diff\" ",
        "  ranger ( sensor ( range [0.02 {{range}}] fov 180 samples 9 ) ) ctrl \"wander\" )",
        f'model ( name "walls" size [{2 * half:.2f} {2 * half:.2f} 0.5] boundary 1 '
        "gui_nose 0 obstacle_return 1 )",
    ]
    for i in range(robots):
        x = -half + 1.2 * (i % side) + 1.2
        y = -half + 1.2 * (i // side) + 1.2
        lines.append(f'bot ( name "r{i}" pose [ {x:.2f} {y:.2f} 0 {(i * 37) % 360} ] )')
    return "\n".join(lines) + "\n"


def bare(spec):
    """Loading the run's worldfile text and stepping it, nothing else: (wall s, CPU s)."""
    t0, c0 = time.perf_counter(), time.process_time()
    w = World(os.path.join(spec.world_dir, spec.world_name), spec.seed, text=spec.world_text)
    w.quit_time = 0
    w.step(spec.steps)
    w.digest()
    return time.perf_counter() - t0, time.process_time() - c0


def timed_execute(spec):
    """``execute(spec)``: (wall s, CPU s)."""
    t0, c0 = time.perf_counter(), time.process_time()
    r = execute(spec)
    assert r["error"] is None, r["error"]
    return time.perf_counter() - t0, time.process_time() - c0


def sweep(specs, jobs: int, out: str) -> float:
    store = Store(out)
    t0 = time.perf_counter()
    executors.local(specs, store, jobs)
    store.summarize([s.run_id for s in specs])
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--robots", type=int, default=100)
    ap.add_argument("--steps", type=int, default=6000)
    ap.add_argument("--sample", type=int, default=6, help="runs timed bare vs execute")
    ap.add_argument("--jobs", type=int, nargs="*", default=None,
                    help="worker counts to time (default: 1 and one per core)")
    args = ap.parse_args()
    ranges = [1.0, 2.0, 3.0]
    seeds = max(1, args.runs // len(ranges))
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "swarm.world.tmpl"), "w") as f:
            f.write(template(args.robots))
        plan = Plan(world="swarm.world.tmpl", steps=args.steps, seeds=seeds,
                    params={"range": ranges}, base_dir=tmp)
        t0 = time.perf_counter()
        specs = plan.runs()
        plan_s = time.perf_counter() - t0
        print(f"{len(specs)} runs of {args.robots} robots x {args.steps} steps "
              f"(plan expanded and checked in {plan_s:.2f} s); {os.cpu_count()} cores, load "
              f"average {os.getloadavg()[0]:.1f}")
        sample = specs[:: max(1, len(specs) // args.sample)][: args.sample]
        b, e = [], []
        bare(sample[0])  # warm up (first load of the module, the thread pool)
        for s in sample:
            b.append(bare(s))
            e.append(timed_execute(s))
        bm, em = (statistics.median(x[0] for x in b), statistics.median(x[0] for x in e))
        bc, ec = (statistics.median(x[1] for x in b), statistics.median(x[1] for x in e))
        print(f"one run, bare World: {bm:.3f} s; execute(): {em:.3f} s; overhead "
              f"{(em - bm) / bm * 100:+.1f}% (wall, median of {len(sample)})")
        print(f"one run, bare World: {bc:.3f} s; execute(): {ec:.3f} s; overhead "
              f"{(ec - bc) / bc * 100:+.1f}% (CPU time of this process, all its threads)")
        # the fixed cost per run of the whole machinery (pool round trip, result written to
        # disk), measured on runs of one step so the simulation does not drown it
        tiny = Plan(world="swarm.world.tmpl", steps=1, seeds=20, params={"range": [2.0]},
                    base_dir=tmp).runs()
        wall1 = sweep(tiny, 1, os.path.join(tmp, "out-tiny"))
        tb = statistics.median(bare(s)[0] for s in tiny[:5])
        fixed = wall1 / len(tiny) - tb
        print(f"fixed cost per run of a 1-worker sweep (1-step runs): {fixed * 1000:.1f} ms "
              f"beyond loading the world ({tb * 1000:.1f} ms): {fixed / bm * 100:.1f}% of "
              f"one {args.steps}-step run")
        results = {}
        for jobs in args.jobs if args.jobs is not None else sorted({1, os.cpu_count() or 1}):
            wall = sweep(specs, jobs, os.path.join(tmp, f"out-{jobs}"))
            results[jobs] = wall
            print(f"local, {jobs} worker(s): {wall:.1f} s, {len(specs) / wall * 60:.1f} runs/min")
        if 1 in results:
            # the pool and the store around execute(): the sweep's wall time against the sum
            # of its runs' own execute() times (run.json's wall_time), measured in the same
            # minutes, so the machine's changing load hits both alike
            inner = sum(r["wall_time"] for r in Store(os.path.join(tmp, "out-1")).results(
                [s.run_id for s in specs]))
            print(f"1-worker sweep: {results[1]:.1f} s for {inner:.1f} s inside execute(): pool "
                  f"and store add {(results[1] - inner) / inner * 100:+.1f}% "
                  f"({(results[1] - inner) / len(specs) * 1000:.0f} ms per run)")
        summaries = set()
        for j in results:
            with open(os.path.join(tmp, f"out-{j}", "summary.csv"), "rb") as f:
                summaries.add(f.read())
        if len(results) > 1:
            print(f"summary.csv identical across worker counts: {len(summaries) == 1}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
