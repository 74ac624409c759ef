"""Benchmark of `playerstage sweep`'s Ray executor (issue 39), beside the local executor.

    target/python-venv/bin/python crates/python/bench/sweep_ray.py \
        [--runs 60] [--robots 100] [--steps 6000] [--node-cpus 1] [--no-ray-local]

The sweep of ``bench/sweep.py`` (its world: ROBOTS wandering robots, sensor range x seeds,
RUNS runs of STEPS steps) on:

- ``local`` with 1 worker and with one per core (the process pool);
- ``ray`` on a two-node Ray cluster on this machine: a head (``ray start --head``) and a second
  node joined to it (``ray start --address=...``), NODE_CPUS CPUs each, made by the tests'
  ``ray_cluster.py`` (in a private network namespace when run as root; the driver runs there
  too, as a subprocess);
- ``ray`` with a local Ray started for the sweep (no ``--address``), unless ``--no-ray-local``.

Each line gives the whole sweep's wall time (every result stored on the driver, summaries
written) and runs per minute; Ray lines also give the time to connect or start Ray, which is
included; and how full the run slots (workers, Ray CPUs) were: the runs' time inside
``execute()`` over wall time x slots, the sweep machinery's and the machine's other load's
share being the rest. ``--repeat N`` interleaves N rounds of every configuration. At the end:
whether every sweep's summary.csv is byte-identical.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List, Optional

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests" / "python"))

from sweep import template  # noqa: E402 (bench/sweep.py: the same world)

from playerstage.sweep import Plan, Store, executors  # noqa: E402


def make_plan(directory: str, runs: int, robots: int, steps: int) -> Plan:
    """bench/sweep.py's plan: 3 sensor ranges x runs/3 seeds of a `robots`-robot world."""
    ranges = [1.0, 2.0, 3.0]
    with open(os.path.join(directory, "swarm.world.tmpl"), "w") as f:
        f.write(template(robots))
    return Plan(world="swarm.world.tmpl", steps=steps, seeds=max(1, runs // len(ranges)),
                params={"range": ranges}, base_dir=directory)


def drive(address: Optional[str], plan_dir: str, out: str, runs: int, robots: int,
          steps: int) -> Dict[str, float]:
    """The Ray sweep, in this process (the driver): connect/start Ray, run, summarize."""
    import ray

    from playerstage.sweep import ray_executor

    specs = make_plan(plan_dir, runs, robots, steps).runs(check=False)
    t0 = time.perf_counter()
    if address is None:
        ray.init(address="local", include_dashboard=False, logging_level="WARNING")
    else:
        ray.init(address=address, logging_level="WARNING")
    connect = time.perf_counter() - t0
    store = Store(out)
    counts = ray_executor.run(specs, store, address)
    store.summarize([s.run_id for s in specs])
    wall = time.perf_counter() - t0
    ray.shutdown()
    return {"connect": connect, "wall": wall, "runs": len(specs), **counts}


def drive_in(prefix: List[str], address: Optional[str], plan_dir: str, out: str,
             args: argparse.Namespace) -> Dict[str, float]:
    """`drive` in a subprocess (in the cluster's network namespace when `prefix` says so)."""
    argv = prefix + [sys.executable, __file__, "--drive", address or "local", "--plan-dir",
                     plan_dir, "--out", out, "--runs", str(args.runs), "--robots",
                     str(args.robots), "--steps", str(args.steps)]
    # Token auth off: a local Ray would otherwise write ~/.ray/auth_token, which later puts
    # a `ray start --head` on this machine in token mode (see ray_cluster.py).
    env = dict(os.environ, RAY_AUTH_MODE="disabled")
    done = subprocess.run(argv, stdout=subprocess.PIPE, text=True, env=env)
    if done.returncode != 0:
        raise SystemExit(f"the Ray driver failed ({done.returncode})")
    return json.loads(done.stdout.strip().splitlines()[-1])


def busy(out: str) -> float:
    """Seconds the sweep's runs spent inside execute() (their run.json wall times)."""
    return sum(r.get("wall_time") or 0.0 for r in Store(out).results())


def report_differences(summaries: Dict[str, str]) -> None:
    """Whether every sweep's summary.csv is the first one's; if not, which columns differ."""
    (first, ref), *rest = summaries.items()
    differ = [(name, text) for name, text in rest if text != ref]
    print(f"summary.csv identical across all {len(summaries)} sweeps: {not differ}")
    ref_rows = list(csv.reader(io.StringIO(ref)))
    for name, text in differ:
        rows = list(csv.reader(io.StringIO(text)))
        if rows[0] != ref_rows[0]:
            print(f"  {name}: other columns than {first}: {rows[0]} against {ref_rows[0]}")
            continue
        cols = sorted({rows[0][c] for a, b in zip(rows[1:], ref_rows[1:])
                       for c in range(len(a)) if a[c] != b[c]})
        print(f"  {name}: differs from {first} in columns {cols}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--robots", type=int, default=100)
    ap.add_argument("--steps", type=int, default=6000)
    ap.add_argument("--node-cpus", type=int, default=1, help="CPUs of each Ray node")
    ap.add_argument("--no-ray-local", action="store_true", help="skip the local-Ray figure")
    ap.add_argument("--repeat", type=int, default=1,
                    help="rounds of every configuration, interleaved (a busy machine's load "
                         "changes hit them alike); the best round is reported")
    ap.add_argument("--drive", help=argparse.SUPPRESS)
    ap.add_argument("--plan-dir", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.drive:
        address = None if args.drive == "local" else args.drive
        got = drive(address, args.plan_dir, args.out, args.runs, args.robots, args.steps)
        print(json.dumps(got))
        return 0

    import ray_cluster

    with tempfile.TemporaryDirectory(prefix="psbench") as tmp:
        plan = make_plan(tmp, args.runs, args.robots, args.steps)
        specs = plan.runs()
        n = len(specs)
        print(f"{n} runs of {args.robots} robots x {args.steps} steps; {os.cpu_count()} cores, "
              f"load average {os.getloadavg()[0]:.1f}", flush=True)
        cluster_dir = tempfile.mkdtemp(prefix="psray")
        t0 = time.perf_counter()
        try:
            # (start_cluster cleans up its own processes when it fails; the dir is ours)
            cluster = ray_cluster.start_cluster(Path(cluster_dir), args.node_cpus, args.node_cpus)
        except BaseException:
            shutil.rmtree(cluster_dir, ignore_errors=True)
            raise
        try:
            where = f"namespace {cluster.namespace}" if cluster.namespace else "loopback"
            print(f"two-node Ray cluster ({args.node_cpus} CPU(s) each, {where}) started in "
                  f"{time.perf_counter() - t0:.1f} s", flush=True)

            def local(jobs: int):
                def go(out: str):
                    store = Store(out)
                    t = time.perf_counter()
                    executors.local(specs, store, jobs)
                    store.summarize([s.run_id for s in specs])
                    return time.perf_counter() - t, "", jobs
                return go

            def ray_on(prefix: List[str], address: Optional[str], what: str, slots: int):
                def go(out: str):
                    got = drive_in(prefix, address, tmp, out, args)
                    return got["wall"], f" ({what} {got['connect']:.1f} s included)", slots
                return go

            configs = {f"local, {j} worker(s)": local(j) for j in sorted({1, os.cpu_count() or 1})}
            configs["ray, two-node cluster"] = ray_on(cluster.prefix(), cluster.address,
                                                      "connecting", 2 * args.node_cpus)
            if not args.no_ray_local:
                configs["ray, local Ray started for the sweep"] = ray_on(
                    [], None, "starting Ray", os.cpu_count() or 1)
            best: Dict[str, float] = {}
            summaries: Dict[str, str] = {}
            for round_ in range(args.repeat):
                for k, (name, go) in enumerate(configs.items()):
                    out = os.path.join(tmp, f"out-{round_}-{k}")
                    wall, note, slots = go(out)
                    # how full the CPUs given to runs were: time inside execute() / (wall x slots)
                    used = busy(out) / (wall * slots) * 100
                    print(f"{name}: {wall:.1f} s, {n / wall * 60:.1f} runs/min{note}; runs "
                          f"inside execute() {used:.0f}% of {slots} slot(s) x wall; load "
                          f"average {os.getloadavg()[0]:.1f}", flush=True)
                    best[name] = min(best.get(name, wall), wall)
                    summaries[f"{name} (round {round_ + 1})"] = Path(out, "summary.csv").read_text()
                    shutil.rmtree(out)
            if args.repeat > 1:
                for name, wall in best.items():
                    print(f"best of {args.repeat}: {name}: {n / wall * 60:.1f} runs/min")
        finally:
            cluster.close()
            shutil.rmtree(cluster_dir, ignore_errors=True)
        report_differences(summaries)
    return 0


if __name__ == "__main__":
    sys.exit(main())
