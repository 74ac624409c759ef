"""playerstage.sweep running: one run's result, the local executor's output layout and
summaries, reproducibility, failed runs, interrupt and resume, the `playerstage` command."""

import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from playerstage.sweep import Plan, Store, execute, load_plan
from playerstage.sweep import executors

TEMPLATE = """\
interval_sim 100
define bot position (
  size [0.4 0.4 0.4] drive "diff"
  ranger ( sensor ( range [0 {{range}}] fov 90 samples 5 ) )
)
model ( name "wall" pose [3 0 0 0] size [0.2 4 1] )
bot ( name "r0" pose [0 0 0 0] )
bot ( name "r1" pose [0 1.5 0 0] )
"""

# r0 drives at `speed` towards the wall (stalls against it), r1 stands; `fail` makes a run
# raise in its metric; every metric call leaves a line in markers/ so tests count executions.
HELPERS = """\
import os
from playerstage.sweep import current_run

def drive(world, t):
    world.set_velocity("r0", current_run().params["speed"])

def probe(world):
    run = current_run()
    with open(os.path.join(os.path.dirname(__file__), "markers", run.run_id), "a") as f:
        f.write(f"{world.steps}\\n")
    if run.params.get("fail"):
        raise RuntimeError("this point fails on purpose")
    return {"r0_x": world.pose("r0").x, "label": "p" + str(run.seed)}
"""

PLAN = """\
world = "arena.world.tmpl"
duration = {duration}
seeds = 2
controller = "helpers.py:drive"
python_params = ["speed", "fail"]
[params]
range = [1.0, 2.0]
speed = [0.5, 1.0]
fail = {fail}
[metrics]
custom = ["helpers.py:probe"]
every = {every}
"""


def make(tmp_path: Path, duration=3, fail="[false]", every=10) -> Path:
    (tmp_path / "arena.world.tmpl").write_text(TEMPLATE)
    (tmp_path / "helpers.py").write_text(HELPERS)
    (tmp_path / "markers").mkdir(exist_ok=True)
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN.format(duration=duration, fail=fail, every=every))
    return plan


def read_csv(path: Path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


def markers(tmp_path: Path) -> dict:
    d = tmp_path / "markers"
    return {p.name: p.read_text().split() for p in d.iterdir()}


def sweep_cmd(*args):
    """`python -m playerstage sweep ...` (the console script is tested on its own)."""
    return [sys.executable, "-m", "playerstage", "sweep", *map(str, args)]


def test_execute_one_run(tmp_path):
    spec = load_plan(make(tmp_path)).runs()[-1]  # range 2, speed 1.0, seed 2
    result = execute(spec)
    assert result["error"] is None, result["error"]
    json.dumps(result)  # JSON-able as it is
    s = result["summary"]
    assert result["steps"] == 30 and result["sim_time"] == pytest.approx(3.0)
    assert s["robots_tracked"] == 2 and s["label"] == "p2"
    # r0 drives 1 m/s towards the wall at x 2.9 (its half size 0.2): it stops ~2.7 m along
    assert 2.4 < s["r0_x"] < 2.71 and s["distance_total"] == pytest.approx(s["r0_x"], abs=1e-9)
    assert s["collisions_total"] == 1 and s["stalled_total"] > 0
    # metrics.csv rows: every 10 steps, world, both robots and the custom values
    steps = sorted({row[0] for row in result["metrics"]})
    assert steps == [10, 20, 30]
    subjects = {row[2] for row in result["metrics"]}
    assert subjects == {"world", "r0", "r1", "custom"}
    assert markers(tmp_path)[spec.run_id] == ["10", "20", "30"]
    # the same run again: the same digest and summary
    again = execute(spec)
    assert (again["digest"], again["summary"]) == (result["digest"], result["summary"])


def test_execute_records_a_failure_instead_of_raising(tmp_path):
    spec = load_plan(make(tmp_path, fail="[true]")).runs()[0]
    result = execute(spec)
    assert "RuntimeError: this point fails on purpose" in result["error"]
    assert result["digest"] is None and result["run_id"] == spec.run_id


def test_local_sweep_layout_and_summary(tmp_path):
    plan = make(tmp_path)
    out = tmp_path / "out"
    proc = subprocess.run(sweep_cmd(plan, "-o", out, "--jobs", 2), capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    specs = load_plan(plan).runs()
    for s in specs:
        d = out / "runs" / s.run_id
        assert (d / "arena.world").read_text() == s.world_text
        meta = json.loads((d / "run.json").read_text())
        assert meta["params"] == s.params and meta["seed"] == s.seed and meta["error"] is None
        assert {"digest", "host", "versions", "wall_time", "summary"} <= set(meta)
        assert read_csv(d / "metrics.csv")[0] == ["step", "time", "subject", "metric", "value"]
    rows = read_csv(out / "summary.csv")
    assert rows[0][:5] == ["range", "speed", "fail", "seed", "digest"]
    assert rows[0][-1] == "error" and "distance_mean" in rows[0] and "r0_x" in rows[0]
    assert len(rows) == 1 + 8
    by = {(r[0], r[1], r[3]): dict(zip(rows[0], r)) for r in rows[1:]}
    assert [k for k in by][:3] == [("1.0", "0.5", "1"), ("1.0", "0.5", "2"), ("1.0", "1.0", "1")]
    for s in specs:
        meta = json.loads((out / "runs" / s.run_id / "run.json").read_text())
        row = by[(repr(s.params["range"]), repr(s.params["speed"]), str(s.seed))]
        assert row["digest"] == meta["digest"] and row["error"] == ""
    # seeds differ in the digest (the sensors' noise and colours), speeds in the travel
    assert by[("1.0", "0.5", "1")]["digest"] != by[("1.0", "0.5", "2")]["digest"]
    assert float(by[("1.0", "1.0", "1")]["distance_total"]) > float(
        by[("1.0", "0.5", "1")]["distance_total"])
    agg = read_csv(out / "aggregate.csv")
    assert agg[0][:5] == ["range", "speed", "fail", "runs", "failed"]
    assert len(agg) == 1 + 4 and all(r[3] == "2" and r[4] == "0" for r in agg[1:])
    assert (out / "plan.toml").read_text() == plan.read_text()


def test_same_plan_twice_gives_identical_summaries(tmp_path):
    plan = make(tmp_path, duration=1)
    specs = load_plan(plan).runs()
    outs = []
    for name, jobs in (("a", 1), ("b", 2)):
        store = Store(str(tmp_path / name))
        executors.local(specs, store, jobs)
        store.summarize([s.run_id for s in specs])
        outs.append(tmp_path / name)
    for f in ("summary.csv", "aggregate.csv"):
        assert (outs[0] / f).read_bytes() == (outs[1] / f).read_bytes()
    digests = [r[4] for r in read_csv(outs[0] / "summary.csv")[1:]]
    assert len(digests) == 8 and all(len(d) == 16 for d in digests)


def test_failed_run_is_recorded_and_the_sweep_goes_on(tmp_path):
    plan = make(tmp_path, duration=1, fail="[false, true]")
    out = tmp_path / "out"
    proc = subprocess.run(sweep_cmd(plan, "-o", out, "-j", 2), capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert "16 runs, 8 failed" in proc.stderr and "fails on purpose" in proc.stderr
    rows = read_csv(out / "summary.csv")
    head = rows[0]
    failed = [dict(zip(head, r)) for r in rows[1:] if r[2] == "true"]
    ok = [dict(zip(head, r)) for r in rows[1:] if r[2] == "false"]
    assert len(failed) == 8 and len(ok) == 8
    assert all(r["error"] == "RuntimeError: this point fails on purpose" and r["digest"] == ""
               for r in failed)
    assert all(r["error"] == "" and r["digest"] for r in ok)
    # a rerun keeps failed runs (no execution), --retry-failed runs them again
    before = markers(tmp_path)
    again = subprocess.run(sweep_cmd(plan, "-o", out), capture_output=True, text=True,
                           timeout=120)
    assert again.returncode == 1 and markers(tmp_path) == before
    retried = subprocess.run(sweep_cmd(plan, "-o", out, "--retry-failed"), capture_output=True,
                             text=True, timeout=120)
    assert retried.returncode == 1
    after = markers(tmp_path)
    assert sum(len(v) != len(before[k]) for k, v in after.items()) == 8


def _wait_for_runs(out: Path, n: int, proc, timeout=60.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        runs = out / "runs"
        done = [p for p in runs.iterdir() if (p / "run.json").exists()
                and not p.name.startswith(".")] if runs.exists() else []
        if len(done) >= n:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    raise AssertionError(f"fewer than {n} runs stored after {timeout} s")


@pytest.mark.parametrize("how", ["kill", "ctrl-c"])
def test_interrupt_and_resume(tmp_path, how):
    """Stop a sweep part way (SIGKILL of its process group, or Ctrl-C's SIGINT), run the
    same command again: identical final results to an uninterrupted sweep, and no run that
    had been stored is executed again."""
    plan = make(tmp_path, duration=20, every=0)
    out = tmp_path / "out"
    proc = subprocess.Popen(sweep_cmd(plan, "-o", out, "-j", 1), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _wait_for_runs(out, 2, proc)
        os.killpg(proc.pid, signal.SIGKILL if how == "kill" else signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    if how == "ctrl-c":
        assert proc.returncode == 130, err
        assert "interrupted:" in err and "Traceback" not in err, err
    # a directory still under its temporary name is half-written (killed before its rename)
    stored = {p.name for p in (out / "runs").iterdir()
              if (p / "run.json").exists() and not p.name.startswith(".")}
    assert 2 <= len(stored) < 8
    time.sleep(0.5)  # a killed sweep's orphaned worker may still finish its run
    resumed = subprocess.run(sweep_cmd(plan, "-o", out), capture_output=True, text=True,
                             timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    counts = {k: len(v) for k, v in markers(tmp_path).items()}
    assert all(counts[k] == 1 for k in stored), counts
    assert len(counts) == 8
    assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]
    # the reference: the same plan in one go
    ref = Store(str(tmp_path / "ref"))
    specs = load_plan(plan).runs()
    executors.local(specs, ref, 2)
    ref.summarize([s.run_id for s in specs])
    assert (out / "summary.csv").read_bytes() == (tmp_path / "ref" / "summary.csv").read_bytes()


def test_a_half_written_run_is_redone(tmp_path):
    plan = make(tmp_path, duration=1)
    specs = load_plan(plan).runs()
    store = Store(str(tmp_path / "out"))
    executors.local(specs[:2], store, 1)
    # what a sweep killed inside Store.write leaves: a temporary directory, and a run
    # directory without run.json (written by hand)
    (tmp_path / "out" / "runs" / f".tmp-{specs[2].run_id}-dead").mkdir()
    partial = tmp_path / "out" / "runs" / specs[3].run_id
    partial.mkdir()
    (partial / "metrics.csv").write_text("step,time\n")
    assert [store.done(s.run_id) for s in specs[:4]] == [True, True, False, False]
    assert sorted(store.clean_partial()) == sorted([f".tmp-{specs[2].run_id}-dead",
                                                   specs[3].run_id])
    todo = executors.pending(specs, store)
    assert [s.run_id for s in todo] == [s.run_id for s in specs[2:]]


def test_a_changed_plan_does_not_reuse_old_results(tmp_path):
    plan = make(tmp_path, duration=1)
    out = tmp_path / "out"
    assert subprocess.run(sweep_cmd(plan, "-o", out), capture_output=True,
                          timeout=120).returncode == 0
    plan.write_text(plan.read_text().replace("duration = 1", "duration = 2"))
    proc = subprocess.run(sweep_cmd(plan, "-o", out), capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and "holds a result made with another" in proc.stderr


def test_console_script_and_bad_plan_exit_status(tmp_path):
    script = Path(sys.executable).parent / "playerstage"
    assert script.exists(), "the `playerstage` console script is not installed"
    plan = make(tmp_path, duration=1)
    ok = subprocess.run([str(script), "sweep", str(plan), "--check"], capture_output=True,
                        text=True, timeout=60)
    assert ok.returncode == 0 and "ok: 8 runs (4 points x 2 seeds)" in ok.stdout, ok.stderr
    plan.write_text(plan.read_text().replace("range = [1.0, 2.0]", "range = [1.0]\nrnage = [2]"))
    bad = subprocess.run([str(script), "sweep", str(plan), "-o", str(tmp_path / "out")],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2
    assert "plan.toml:8: [params] rnage: unknown parameter" in bad.stderr, bad.stderr
    assert not (tmp_path / "out").exists()
    ray = subprocess.run(sweep_cmd(tmp_path / "nope.toml"), capture_output=True, text=True,
                         timeout=60)
    assert ray.returncode == 2 and "cannot read the plan" in ray.stderr
    addr = subprocess.run(sweep_cmd(plan, "--address", "localhost:6379"), capture_output=True,
                          text=True, timeout=60)
    assert addr.returncode == 2 and "use it with --executor ray" in addr.stderr
    usage = subprocess.run([str(script)], capture_output=True, text=True, timeout=60)
    assert usage.returncode == 2 and "sweep" in usage.stdout


def test_swarm_example(tmp_path):
    """examples/sweeps: the full plan checks (90 runs), the CI-sized one runs."""
    from conftest import REPO

    sweeps = REPO / "examples" / "sweeps"
    full = subprocess.run(sweep_cmd(sweeps / "swarm.toml", "--check"), capture_output=True,
                          text=True, timeout=120)
    assert full.returncode == 0 and "90 runs (9 points x 10 seeds)" in full.stdout, full.stderr
    out = tmp_path / "out"
    proc = subprocess.run(sweep_cmd(sweeps / "swarm-ci.toml", "-o", out, "-q"),
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    rows = read_csv(out / "summary.csv")
    head = rows[0]
    assert head[:4] == ["robots", "range", "seed", "digest"]
    assert {"dispersion", "stalled_share", "collisions_total"} <= set(head)
    rows = [dict(zip(head, r)) for r in rows[1:]]
    assert len(rows) == 8 and all(r["error"] == "" for r in rows)
    assert all(r["robots_tracked"] == r["robots"] for r in rows)
    world = (out / "runs" / os.listdir(out / "runs")[0] / "swarm.world").read_text()
    assert world.count('ctrl "wander"') in (4, 8) and "{{" not in world.split("# ")[-1]


def test_progress_display():
    import io

    from playerstage.sweep.progress import Progress

    stream = io.StringIO()
    p = Progress(4, skipped=1, stream=stream, bar=True)
    assert p.eta() is None
    p.update({"run_id": "a", "error": None})
    p.update({"run_id": "b", "error": "Traceback ...\nValueError: no"})
    p.close()
    text = stream.getvalue()
    assert "[######################........] 3/4 runs (1 from before), 1 failed" in text
    assert "left" in text and text.endswith("\n")
    assert p.remaining == 1 and p.eta() is not None


def test_summary_parquet_with_pyarrow(tmp_path):
    pyarrow_parquet = pytest.importorskip("pyarrow.parquet")
    plan = make(tmp_path, duration=1)
    specs = load_plan(plan).runs()[:2]
    store = Store(str(tmp_path / "out"))
    executors.local(specs, store, 1)
    paths = store.summarize([s.run_id for s in specs])
    table = pyarrow_parquet.read_table(paths["parquet"])
    rows = read_csv(tmp_path / "out" / "summary.csv")
    assert table.column_names == rows[0] and table.num_rows == 2
    assert table.column("digest").to_pylist() == [r[4] for r in rows[1:]]


def test_pose_only_metrics_skip_tracking(tmp_path):
    make(tmp_path)
    plan = Plan(world="arena.world.tmpl", steps=20, params={"range": 1.0},
                metrics={"robot": ["pose"], "world": ["digest"], "robots": ["r0"]},
                controller="helpers.py:drive", python_params=["speed"],
                points=[{"speed": 0.5}], base_dir=str(tmp_path))
    result = execute(plan.runs()[0])
    assert result["error"] is None, result["error"]
    assert {(r[2], r[3]) for r in result["metrics"]} == {
        ("world", "digest"), ("r0", "x"), ("r0", "y"), ("r0", "a")}
    x = [r[4] for r in result["metrics"] if r[3] == "x"][0]
    assert x == pytest.approx(0.5 * 2.0, abs=0.06)  # 0.5 m/s for 2 s
    assert "distance_mean" not in result["summary"] and result["summary"]["robots_tracked"] == 1


def test_a_run_that_kills_its_worker_is_recorded_and_the_others_run(tmp_path):
    make(tmp_path)
    (tmp_path / "crash.py").write_text(textwrap.dedent("""\
        import os
        from playerstage.sweep import current_run

        def drive(world, t):
            if current_run().params["speed"] > 0.7 and current_run().seed == 1:
                os._exit(3)  # the worker dies, as on a native crash
            if current_run().params["speed"] < 0.7 and current_run().seed == 2:
                raise SystemExit(4)  # a failed run, not a dead worker
    """))
    plan = Plan(world="arena.world.tmpl", steps=5, seeds=2, params={"range": 1.0,
                "speed": [0.5, 1.0]}, controller="crash.py:drive", python_params=["speed"],
                base_dir=str(tmp_path))
    specs = plan.runs()
    store = Store(str(tmp_path / "out"))
    counts = executors.local(specs, store, 2)
    assert counts == {"done": 4, "failed": 2}
    bad = [s for s in specs if s.params["speed"] == 1.0 and s.seed == 1][0]
    assert "worker process died" in store.read(bad.run_id)["error"]
    exits = [s for s in specs if s.params["speed"] == 0.5 and s.seed == 2][0]
    assert "SystemExit: 4" in store.read(exits.run_id)["error"]
    assert all(store.read(s.run_id)["error"] is None for s in specs if s not in (bad, exits))
