"""One run of a sweep, in the current process: ``execute(spec) -> result``.

Both executors call ``execute`` on their workers (a local process pool, Ray tasks); the driver
writes what it returns. The result is a plain JSON-able dict, so it crosses process and
machine boundaries as it is. A run's own failure (its world, its controller or metric raising)
is not an exception here: the result carries ``error`` (the traceback) and the sweep goes on.
"""

import contextlib
import functools
import fnmatch
import os
import platform
import socket
import time
import traceback
from datetime import datetime, timezone
from typing import Any, Dict, Iterator, List, Optional, Tuple

from .plan import SUMMARY_COLUMNS, RunSpec, resolve_callable

_CURRENT: Optional[RunSpec] = None

#: summary.csv's built-in columns: custom metrics may not take these names.
RESERVED = SUMMARY_COLUMNS


def current_run() -> Optional[RunSpec]:
    """The ``RunSpec`` being executed in this process (None outside a run): how a controller
    or metric callable reads the run's ``params`` (e.g. a gain listed in ``python_params``)
    and ``seed``."""
    return _CURRENT


@contextlib.contextmanager
def _running(spec: RunSpec) -> Iterator[None]:
    global _CURRENT
    before, _CURRENT = _CURRENT, spec
    try:
        yield
    finally:
        _CURRENT = before


@functools.lru_cache(maxsize=None)
def _versions() -> Tuple[Tuple[str, str], ...]:
    try:
        from importlib.metadata import version

        ps = version("playerstage")
    except Exception:
        ps = "unknown"
    return (("playerstage", ps), ("python", platform.python_version()),
            ("platform", platform.platform()))


def versions() -> Dict[str, str]:
    """What made a result: the package and Python versions, and the platform (looked up once
    per process: the package metadata search costs milliseconds)."""
    return dict(_versions())


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def execute(spec: RunSpec) -> Dict[str, Any]:
    """Runs ``spec`` here and returns its result: ``run_id``, ``params``, ``seed``, ``point``,
    ``digest`` (hex), ``steps``, ``sim_time``, ``summary`` (the metrics that go in
    summary.csv), ``metrics`` (``[step, time, subject, metric, value]`` rows for metrics.csv),
    ``wall_time`` (s), ``host``, ``pid``, ``versions``, ``started``, ``finished``, the filled
    worldfile (``world_name``, ``world_text``), ``config_hash``, and ``error`` (None, or the
    traceback of what failed). Never raises for the run's own failure."""
    t0 = time.perf_counter()
    result: Dict[str, Any] = {
        "run_id": spec.run_id,
        "params": dict(spec.params),
        "seed": spec.seed,
        "point": spec.point,
        "config_hash": spec.config_hash,
        "world_name": spec.world_name,
        "world_text": spec.world_text,
        "digest": None,
        "steps": None,
        "sim_time": None,
        "summary": {},
        "metrics": [],
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "versions": versions(),
        "started": _now(),
        "error": None,
    }
    try:
        with _running(spec):
            _simulate(spec, result, t0)
    except (Exception, SystemExit):  # a callable's sys.exit() fails its run, not the worker
        result["error"] = traceback.format_exc()
    result["wall_time"] = time.perf_counter() - t0
    result["finished"] = _now()
    return result


def _simulate(spec: RunSpec, result: Dict[str, Any], t0: float) -> None:
    from .. import World

    m = spec.metrics
    world = World(os.path.join(spec.world_dir, spec.world_name), spec.seed, text=spec.world_text)
    world.quit_time = 0  # the plan's duration decides when the run ends
    steps = spec.steps if spec.steps is not None else max(1, round(spec.duration / world.interval))
    positions = world.models("position")
    robots: List[str] = []
    for pattern in m["robots"]:
        for name in fnmatch.filter(positions, pattern):
            if name not in robots:
                robots.append(name)
    # the step-by-step tracking costs a little per robot and step: only when asked for
    tracking = any(k in m["robot"] for k in ("distance", "stalled", "collisions"))
    world._w.track(robots if tracking else [])
    controller = resolve_callable(spec.controller, spec.python_path) if spec.controller else None
    custom = [resolve_callable(ref, spec.python_path) for ref in m["custom"]]
    every = m["every"]
    rows: List[list] = []
    last: Dict[str, Any] = {}

    def sample() -> None:
        step, t = world.steps, world.time
        if "sim_time" in m["world"]:
            rows.append([step, t, "world", "sim_time", t])
        if "wall_time" in m["world"]:
            rows.append([step, t, "world", "wall_time", time.perf_counter() - t0])
        if "digest" in m["world"]:
            rows.append([step, t, "world", "digest", f"{world.digest():016x}"])
        if tracking:
            tracked = world._w.tracked()
        else:
            tracked = [(n, world._w.global_pose(n), 0.0, 0.0, 0) for n in robots]
        for name, pose, distance, stalled, collisions in tracked:
            if "pose" in m["robot"]:
                rows.extend([[step, t, name, "x", pose[0]], [step, t, name, "y", pose[1]],
                             [step, t, name, "a", pose[2]]])
            if "distance" in m["robot"]:
                rows.append([step, t, name, "distance", distance])
            if "stalled" in m["robot"]:
                rows.append([step, t, name, "stalled", stalled])
            if "collisions" in m["robot"]:
                rows.append([step, t, name, "collisions", collisions])
        last["tracked"] = tracked
        values: Dict[str, Any] = {}
        for fn, ref in zip(custom, m["custom"]):
            got = fn(world)
            if not isinstance(got, dict):
                raise TypeError(f"metric {ref} returned {type(got).__name__}, not a dict")
            for k, v in got.items():
                if not isinstance(k, str) or k in RESERVED or k in values or k in spec.params:
                    raise ValueError(f"metric {ref}: name {k!r} is a built-in column's, a "
                                     "parameter's or given twice")
                if not (v is None or isinstance(v, (bool, int, float, str))):
                    raise TypeError(f"metric {ref}: {k} = {v!r} is not a number or string")
                values[k] = v
                rows.append([step, t, "custom", k, v])
        last["custom"] = values

    done = 0
    while done < steps:
        chunk = steps - done
        if every:
            chunk = min(chunk, every - done % every)
        if controller is None:
            world.step(chunk)
        else:
            for _ in range(chunk):
                controller(world, world.time)
                world.step(1)
        done += chunk
        if every and done % every == 0 and done < steps:
            sample()
    sample()

    summary: Dict[str, Any] = {"steps": world.steps, "sim_time": world.time,
                               "robots_tracked": len(robots)}
    tracked = last["tracked"]
    for metric, index in (("distance", 2), ("stalled", 3), ("collisions", 4)):
        if metric in m["robot"] and tracked:
            values = [t[index] for t in tracked]
            summary[f"{metric}_mean"] = sum(values) / len(values)
            summary[f"{metric}_total"] = sum(values)
    summary.update(last["custom"])
    result["digest"] = f"{world.digest():016x}"
    result["steps"] = world.steps
    result["sim_time"] = world.time
    result["summary"] = summary
    result["metrics"] = rows
