"""playerstage.sweep's Ray executor on a real two-node Ray cluster (``ray_cluster.py``): the
same summary as the local executor, a node killed mid-sweep (its runs retried elsewhere, every
run completed once), and an interrupted sweep resumed.

Every run's controller (``marks.py``, written beside the plan) appends ``start``/``end`` lines
naming the run, the Ray node (the ``ray start`` environment label its worker inherited) and the
worker's pid to a marker file: that is how the tests count executions and see which node ran
what. Its start can sleep, so runs are long enough to be caught in flight.
"""

from __future__ import annotations

import collections
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List

import pytest

from ray_cluster import NODE_LABEL, RayCluster, ray_cluster  # noqa: F401 (the fixture)

TEMPLATE = """\
# two robots in a walled arena; the ranger's range comes from the plan
interval_sim 100
define bot position (
  size [0.4 0.4 0.4] drive "diff"
  ranger ( sensor ( range [0 {{range}}] fov 90 samples 5 ) )
)
model ( name "wall" pose [3 0 0 0] size [0.2 4 1] )
bot ( name "r0" pose [0 0 0 0] )
bot ( name "r1" pose [1 1 0 180] )
"""

# 2 x 2 points x 2 seeds = 8 runs; `speed` is read by the controller only.
PLAN = """\
world = "arena.world.tmpl"
steps = 40
seeds = 2
controller = "marks.py:mark"
python_params = ["speed"]
[params]
range = [1.0, 2.5]
speed = [0.3, 0.6]
[metrics]
custom = ["marks.py:finished"]
"""
RUNS = 8

MARKS = """\
import os
import time

from playerstage.sweep import current_run

MARKS = {marks!r}
DELAY = {delay!r}


def _mark(what):
    with open(MARKS, "a") as f:
        f.write(f"{{what}} {{current_run().run_id}} "
                f"{{os.environ.get({label!r}, 'local')}} {{os.getpid()}}\\n")


def mark(world, t):
    if world.steps == 0:
        _mark("start")
        time.sleep(DELAY)
    speed = current_run().params["speed"]
    world.set_velocity("r0", speed, 0.0, 0.3)
    world.set_velocity("r1", speed, 0.0, -0.3)


def finished(world):
    _mark("end")
    return {{"r0_x": world.pose("r0").x}}
"""


def make_plan(directory: Path, delay: float) -> tuple[Path, Path]:
    """The plan, its template and its marks.py in `directory`; returns (plan, marker file)."""
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "arena.world.tmpl").write_text(TEMPLATE)
    marks = directory / "marks.log"
    set_marks(directory, marks, delay)
    plan = directory / "plan.toml"
    plan.write_text(PLAN)
    return plan, marks


def set_marks(directory: Path, marks: Path, delay: float) -> None:
    """(Re)writes marks.py to append to `marks` and sleep `delay` s when a run starts."""
    text = MARKS.format(marks=str(marks), delay=delay, label=NODE_LABEL)
    (directory / "marks.py").write_text(text)


def sweep_argv(plan: Path, out: Path, *extra: str) -> List[str]:
    return [sys.executable, "-m", "playerstage", "sweep", str(plan), "-o", str(out), *extra]


def read_marks(marks: Path) -> List[tuple[str, str, str, str]]:
    if not marks.exists():
        return []
    return [tuple(line.split()) for line in marks.read_text().splitlines() if line.strip()]


def stored_runs(out: Path) -> set[str]:
    """The runs stored in `out` (the store's temporary directories are dot-names)."""
    return {p.parent.name for p in (out / "runs").glob("*/run.json")
            if not p.parent.name.startswith(".")}


def ends_per_run(marks: Path) -> Dict[str, int]:
    return collections.Counter(run for what, run, _, _ in read_marks(marks) if what == "end")


def run_driver(cluster: RayCluster, argv: List[str], log: Path, timeout: float = 90) -> int:
    with open(log, "wb") as out:
        proc = cluster.driver(argv, stdout=out, stderr=subprocess.STDOUT)
        try:
            return proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            tail = log.read_text()[-4000:]
            pytest.fail(f"the sweep driver did not finish in {timeout} s:\n{tail}")


@pytest.fixture(scope="module")
def local_summary(tmp_path_factory) -> str:
    """summary.csv of the plan on the local executor (2 processes), the reference."""
    d = tmp_path_factory.mktemp("local")
    plan, marks = make_plan(d, delay=0.0)
    done = subprocess.run(sweep_argv(plan, d / "out", "-q", "--jobs", "2"), capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert sum(ends_per_run(marks).values()) == RUNS
    return (d / "out" / "summary.csv").read_text()


def test_ray_gives_the_local_summary(ray_cluster, local_summary, tmp_path):
    # Runs long enough (0.4 s) that the head's one CPU cannot take them all: both nodes work.
    plan, marks = make_plan(tmp_path, delay=0.4)
    out = tmp_path / "out"
    log = tmp_path / "driver.log"
    code = run_driver(ray_cluster, sweep_argv(plan, out, "-q", "--executor", "ray", "--address",
                                              ray_cluster.address), log)
    assert code == 0, log.read_text()[-4000:]
    assert (out / "summary.csv").read_text() == local_summary
    lines = local_summary.splitlines()
    assert len(lines) == RUNS + 1 and "digest" in lines[0].split(",")
    # both nodes took part: a cluster, not the driver's machine alone
    nodes = {node for what, _, node, _ in read_marks(marks) if what == "end"}
    assert nodes == {"head", "worker"}, read_marks(marks)
    assert set(ends_per_run(marks).values()) == {1}


def test_interrupted_ray_sweep_resumes_without_redoing_runs(ray_cluster, local_summary, tmp_path):
    plan, first = make_plan(tmp_path, delay=0.5)
    out = tmp_path / "out"
    argv = sweep_argv(plan, out, "-q", "--executor", "ray", "--address", ray_cluster.address)
    log = tmp_path / "driver1.log"
    with open(log, "wb") as f:
        proc = ray_cluster.driver(argv, stdout=f, stderr=subprocess.STDOUT)
        try:
            deadline = time.monotonic() + 60
            # Ctrl-C once some runs are stored and more are still to come.
            while len(stored_runs(out)) < 2:
                assert proc.poll() is None, log.read_text()[-4000:]
                assert time.monotonic() < deadline, log.read_text()[-4000:]
                time.sleep(0.05)
            os.killpg(proc.pid, signal.SIGINT)
            code = proc.wait(timeout=30)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
    assert code == 130, log.read_text()[-4000:]
    stored = stored_runs(out)
    assert 2 <= len(stored) < RUNS, stored
    first_ends = ends_per_run(first)
    assert all(first_ends[r] == 1 for r in stored)

    second = tmp_path / "marks2.log"
    set_marks(tmp_path, second, delay=0.0)
    log2 = tmp_path / "driver2.log"
    code = run_driver(ray_cluster, argv, log2)
    assert code == 0, log2.read_text()[-4000:]
    assert (out / "summary.csv").read_text() == local_summary
    # the resumed sweep ran exactly the runs the first one had not stored, each once
    redone = ends_per_run(second)
    assert set(redone) == stored_runs(out) - stored
    assert set(redone.values()) == {1}
    assert not any(what == "start" and run in stored for what, run, _, _ in read_marks(second))


def processes_using(path: str) -> Dict[int, str]:
    """Live processes whose command line mentions `path` (Ray's daemons name their dirs)."""
    found = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                cmd = Path(f"/proc/{entry}/cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            if path in cmd:
                found[int(entry)] = cmd
    return found


def test_ray_without_address_starts_and_stops_its_own_ray(local_summary, tmp_path):
    plan, marks = make_plan(tmp_path, delay=0.0)
    out = tmp_path / "out"
    # Ray's files (and so its daemons' command lines) under a dir of our own; short, for
    # Ray's unix socket paths.
    ray_tmp = tempfile.mkdtemp(prefix="psrayl")
    try:
        # HOME too: a local Ray writes its auth token to ~/.ray (Ray's default, token mode on)
        env = dict(os.environ, RAY_TMPDIR=ray_tmp, HOME=ray_tmp)
        env.pop("RAY_ADDRESS", None)
        env.pop("RAY_AUTH_MODE", None)
        done = subprocess.run(sweep_argv(plan, out, "-q", "--executor", "ray", "--jobs", "2"),
                              env=env, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr[-4000:]
        assert (out / "summary.csv").read_text() == local_summary
        assert set(ends_per_run(marks).values()) == {1} and len(ends_per_run(marks)) == RUNS
        assert any(n.startswith("session_") for n in os.listdir(Path(ray_tmp, "ray"))), \
            "the sweep's Ray did not use RAY_TMPDIR"
        # ray.shutdown() at the end of the sweep took the Ray it started down with it
        deadline = time.monotonic() + 15
        while processes_using(ray_tmp) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not processes_using(ray_tmp)
    finally:
        # whatever this test's sweep left running (a failure above), by pid
        for pid in processes_using(ray_tmp):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        shutil.rmtree(ray_tmp, ignore_errors=True)


def test_unreachable_cluster_is_refused_before_any_run(tmp_path):
    """An --address where no Ray head answers: exit 2 and one line naming the address, within
    seconds (Ray alone retries for minutes), and no run executed."""
    plan, marks = make_plan(tmp_path, delay=0.0)
    with socket.socket() as s:  # a port nothing listens on (bound, never listening)
        s.bind(("127.0.0.1", 0))
        address = f"127.0.0.1:{s.getsockname()[1]}"
        started = time.monotonic()
        done = subprocess.run(
            sweep_argv(plan, tmp_path / "out", "-q", "--executor", "ray", "--address", address),
            capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr[-4000:]
    assert f"cannot reach the Ray cluster at {address}" in done.stderr
    assert "Traceback" not in done.stderr
    assert time.monotonic() - started < 60
    assert read_marks(marks) == []


# Last in the module: it leaves the cluster with its head alone.
def test_node_killed_mid_sweep_loses_nothing_and_repeats_nothing(
    ray_cluster, local_summary, tmp_path
):
    plan, marks = make_plan(tmp_path, delay=1.5)
    out = tmp_path / "out"
    argv = sweep_argv(plan, out, "-q", "--executor", "ray", "--address", ray_cluster.address)
    worker = next(n for n in ray_cluster.nodes if n.label == "worker")
    log = tmp_path / "driver.log"
    with open(log, "wb") as f:
        proc = ray_cluster.driver(argv, stdout=f, stderr=subprocess.STDOUT)
        try:
            deadline = time.monotonic() + 60
            # A run started on the worker node and not ended: kill the node under it.
            while True:
                marked = read_marks(marks)
                ended = {(run, pid) for what, run, _, pid in marked if what == "end"}
                caught = [(run, pid) for what, run, node, pid in marked
                          if what == "start" and node == "worker" and (run, pid) not in ended]
                if caught:
                    break
                assert proc.poll() is None, log.read_text()[-4000:]
                assert time.monotonic() < deadline, (marked, log.read_text()[-4000:])
                time.sleep(0.02)
            worker.kill()
            code = proc.wait(timeout=90)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
    assert code == 0, log.read_text()[-4000:]
    marked = read_marks(marks)
    # the run caught in flight never ended on the killed node, and ran again on the head
    for run, pid in caught:
        assert ("end", run, "worker", pid) not in marked
        assert any(m[0] == "end" and m[1] == run and m[2] == "head" for m in marked), marked
    # every run completed exactly once, and the results are the local executor's
    ends = ends_per_run(marks)
    assert len(ends) == RUNS and set(ends.values()) == {1}, ends
    assert (out / "summary.csv").read_text() == local_summary
