"""The Ray executor: one Ray task per run, on a Ray cluster or on a Ray started for the sweep.

``playerstage sweep PLAN --executor ray [--address HOST:PORT]`` calls :func:`run`. Each run is a
task that calls :func:`playerstage.sweep.run.execute` on whichever node Ray picks and returns
its result dict; the driver (the machine running the command) writes every result through the
sweep's :class:`~playerstage.sweep.store.Store` as tasks complete, so the output directory is
on the driver only, and resuming works exactly as with the local executor: runs the store
already holds are not submitted again.

Node loss: a task whose node dies (or whose worker process is killed) is a system failure, which
Ray retries on another node up to ``max_retries`` times. The driver holds one object reference
per run and writes a run's result once, when that reference resolves, so a retried run is
neither lost nor written twice. A run's own failure (a bad world, a controller that raises) is
not an exception here: ``execute`` returns it as a failed result, which is written like any other.
Only when Ray gives up on a task (retries exhausted, the package missing on a node) is nothing
written: the run stays unfinished, is reported as failed, and a rerun of the sweep does it again.

Workers import ``playerstage``: on one machine the driver's environment serves, for a
multi-machine cluster every node needs the same package version installed (``pip install
playerstage`` or the wheel, in the Python that runs ``ray start``), or pass a Ray
``runtime_env`` (e.g. ``{"pip": ["playerstage==X.Y"]}``) to :func:`run`.
"""

from __future__ import annotations

import logging
from typing import Any, Callable, Dict, List, Optional, Sequence

log = logging.getLogger(__name__)

# Ray's own default for tasks; enough for a node or two lost in one sweep.
DEFAULT_MAX_RETRIES = 3
# How long the driver blocks on Ray between checks for Ctrl-C.
_WAIT_SECONDS = 0.5
# Ray's failures that mean "the task did not get to return" rather than a run's result.
_GAVE_UP = "ray gave up on the task"


def _execute_on_worker(spec: Any) -> Dict[str, Any]:
    """The task body: one run in the worker process (imported there by reference)."""
    from playerstage.sweep.run import execute

    return execute(spec)


def _import_ray():
    try:
        import ray
    except ImportError as e:
        raise RuntimeError(
            "the ray executor needs Ray: pip install 'ray>=2' (and the same on every node)"
        ) from e
    return ray


def _window(ray, jobs: Optional[int]) -> int:
    """How many tasks to keep submitted: `jobs`, else twice the cluster's CPUs (so every CPU has
    a next run queued and results stream back instead of arriving all at the end)."""
    if jobs is not None:
        return max(1, jobs)
    cpus = int(ray.cluster_resources().get("CPU", 1))
    return max(2, 2 * cpus)


def run(
    specs: Sequence[Any],
    store: Any,
    address: Optional[str] = None,
    jobs: Optional[int] = None,
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
    *,
    max_retries: int = DEFAULT_MAX_RETRIES,
    runtime_env: Optional[Dict[str, Any]] = None,
) -> Dict[str, int]:
    """Run every spec the store does not hold yet as a Ray task; write results as they arrive.

    ``address``: a running cluster (``HOST:PORT`` of its head, or ``"auto"``); ``None`` starts a
    Ray on this machine for the sweep (``jobs`` CPUs, all when ``None``) and shuts it down after.
    When Ray is already initialised in this process (a caller's own session) that session is
    used and left running. ``jobs`` with a cluster caps the runs in flight. ``progress`` is
    called with each result written (and with a failed result for a run Ray gave up on).

    Returns counts: ``submitted``, ``written``, ``failed`` (written failed runs plus runs Ray
    gave up on), ``skipped`` (already in the store). Ctrl-C cancels the runs in flight and
    raises ``KeyboardInterrupt``; what was written stays written.
    """
    ray = _import_ray()
    todo = [s for s in specs if not store.done(s.run_id)]
    counts = {"submitted": 0, "written": 0, "failed": 0, "skipped": len(specs) - len(todo)}
    if counts["skipped"]:
        log.info("%d of %d runs already done, skipped", counts["skipped"], len(specs))
    if not todo:
        return counts

    started_here = False
    if not ray.is_initialized():
        options: Dict[str, Any] = {
            "include_dashboard": False,
            "logging_level": logging.WARNING,
            "configure_logging": True,
        }
        if runtime_env is not None:
            options["runtime_env"] = runtime_env
        if address is None:
            # "local": a fresh Ray for this sweep, never a cluster found through RAY_ADDRESS.
            ray.init(address="local", num_cpus=jobs, **options)
            log.info("started a local Ray (%s CPUs)", jobs if jobs else "all")
        else:
            ray.init(address=address, **options)
            log.info("connected to the Ray cluster at %s", address)
        started_here = True
    try:
        return _drive(ray, todo, store, jobs, progress, max_retries, counts)
    finally:
        if started_here:
            ray.shutdown()


def _drive(
    ray,
    todo: List[Any],
    store: Any,
    jobs: Optional[int],
    progress: Optional[Callable[[Dict[str, Any]], None]],
    max_retries: int,
    counts: Dict[str, int],
) -> Dict[str, int]:
    task = ray.remote(_execute_on_worker).options(
        num_cpus=1,
        max_retries=max_retries,
        # execute() returns a run's own failure; an exception is Ray's or the environment's
        # (e.g. playerstage missing on a node), and retrying it elsewhere may succeed.
        retry_exceptions=False,
    )
    window = _window(ray, jobs)
    log.info("%d runs to do, up to %d in flight", len(todo), window)
    queue = list(reversed(todo))
    in_flight: Dict[Any, Any] = {}  # object ref -> spec
    written: set = set()
    try:
        while queue or in_flight:
            while queue and len(in_flight) < window:
                spec = queue.pop()
                in_flight[task.remote(spec)] = spec
                counts["submitted"] += 1
            ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=_WAIT_SECONDS)
            for ref in ready:
                spec = in_flight.pop(ref)
                result = _result_of(ray, ref, spec)
                if result is None:
                    counts["failed"] += 1
                    if progress is not None:
                        progress({"run_id": spec.run_id, "status": "failed", "error": _GAVE_UP})
                    continue
                if spec.run_id in written:
                    # One reference per run resolves once; this guards the invariant anyway.
                    log.warning("run %s returned twice; the second result is dropped", spec.run_id)
                    continue
                store.write(result)
                written.add(spec.run_id)
                counts["written"] += 1
                if result.get("status") not in (None, "ok"):
                    counts["failed"] += 1
                if progress is not None:
                    progress(result)
    except KeyboardInterrupt:
        log.warning(
            "interrupted: cancelling %d runs in flight; %d written this time are kept",
            len(in_flight),
            counts["written"],
        )
        for ref in in_flight:
            ray.cancel(ref, force=True)
        raise
    return counts


def _result_of(ray, ref: Any, spec: Any) -> Optional[Dict[str, Any]]:
    """The run's result, or None (logged) when Ray could not get one (retries exhausted)."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayError as e:
        log.error("run %s: %s: %s", spec.run_id, _GAVE_UP, e)
        return None

