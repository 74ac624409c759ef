"""The Ray executor: one Ray task per run, on a Ray cluster or on a Ray started for the sweep.

``playerstage sweep PLAN --executor ray [--address HOST:PORT]`` calls :func:`run` with the runs
still to do. Each run is a task that calls :func:`playerstage.sweep.run.execute` on whichever
node Ray picks and returns its result dict; the driver (the process running the command) writes
every result through the sweep's :class:`~playerstage.sweep.store.Store` as tasks complete. So
the output directory lives on the driver's machine only, and resuming is the local executor's:
a run the store holds is not handed to :func:`run` again.

Node loss: a task whose node dies (or whose worker process is killed) is a system failure, which
Ray retries on another node up to ``max_retries`` times. The driver holds one object reference
per run and stores a run's result once, when that reference resolves, so a run in flight on a
lost node is neither lost nor stored twice. A run's own failure (a bad world, a controller that
raises) is not an exception here: ``execute`` returns it as a result with its ``error``. When
Ray gives up on a task (retries used up, the task unable to start) the run is stored as failed
with Ray's error, as the local executor stores a run whose worker died; ``--retry-failed``
runs it again.

Workers import ``playerstage``: on one machine the driver's environment serves; on a
multi-machine cluster every node needs the same package version installed (``pip install
playerstage`` or the wheel, in the Python that runs ``ray start``), or pass a Ray
``runtime_env`` (e.g. ``{"pip": ["playerstage==X.Y"]}``) to :func:`run`. A run carries its
filled worldfile's text, but what that worldfile includes or loads (``include``, bitmaps) and
the plan's Python callables are read on the node from the driver's paths: keep the plan's
directory on a shared filesystem (or at the same path on every node).
"""

from __future__ import annotations

import logging
import socket
from typing import Any, Dict, List, Optional, Sequence, Set

from .executors import _finish, crashed_result
from .plan import RunSpec
from .progress import Progress
from .store import Store

log = logging.getLogger(__name__)

# Ray's own default for tasks; enough for a node or two lost in one sweep.
DEFAULT_MAX_RETRIES = 3
# How long the driver blocks on Ray between checks for Ctrl-C.
_WAIT_SECONDS = 0.5


def _execute_on_worker(spec: RunSpec) -> Dict[str, Any]:
    """The task body: one run in the worker process (imported there by reference)."""
    from playerstage.sweep.run import execute

    return execute(spec)


# How long the driver tries to reach a cluster's head before refusing the sweep.
_CONNECT_SECONDS = 10.0


class RayUnavailable(RuntimeError):
    """The sweep cannot start on Ray: Ray is not installed, or the cluster's head does not answer
    at the given address. The CLI reports it in one line and exits 2, before any run starts (Ray
    itself would retry an unreachable head for minutes)."""


def _check_reachable(address: str) -> None:
    """Refuses an address whose head does not accept a TCP connection within a few seconds.
    Only plain ``HOST:PORT`` is checked; ``auto`` and ``ray://`` addresses go to Ray as given."""
    if address == "auto" or "://" in address:
        return
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise RayUnavailable(f"--address {address!r} is not HOST:PORT (the head's GCS port)")
    try:
        socket.create_connection((host, int(port)), timeout=_CONNECT_SECONDS).close()
    except OSError as e:
        raise RayUnavailable(f"cannot reach the Ray cluster at {address}: {e}") from e


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as e:
        raise RayUnavailable(
            "the ray executor needs Ray: pip install 'ray>=2' (and the same on every node)"
        ) from e
    return ray


def _window(ray: Any, jobs: Optional[int]) -> int:
    """How many tasks to keep submitted: `jobs`, else twice the cluster's CPUs (so every CPU has
    a next run queued and results stream back instead of arriving all at the end)."""
    if jobs is not None:
        return max(1, jobs)
    cpus = int(ray.cluster_resources().get("CPU", 1))
    return max(2, 2 * cpus)


def run(
    specs: Sequence[RunSpec],
    store: Store,
    address: Optional[str] = None,
    jobs: Optional[int] = None,
    progress: Optional[Progress] = None,
    *,
    max_retries: int = DEFAULT_MAX_RETRIES,
    runtime_env: Optional[Dict[str, Any]] = None,
) -> Dict[str, int]:
    """Runs ``specs`` (the runs still to do: ``executors.pending``) as Ray tasks, each result
    stored and passed to ``progress.update`` on this process as it arrives.

    ``address``: a running cluster (``HOST:PORT`` of its head, or ``"auto"``); ``None`` starts a
    Ray on this machine for the sweep (``jobs`` CPUs, all when ``None``) and shuts it down after.
    When Ray is already initialised in this process (a caller's own session) that session is
    used and left running. With a cluster, ``jobs`` caps the runs in flight (default: twice the
    cluster's CPUs). ``max_retries``: how often a run whose node or worker process died is
    started again elsewhere; after that it is stored as failed, like a local run whose worker
    died (``--retry-failed`` runs it again). ``runtime_env``: Ray's, for the tasks (e.g. a
    ``pip`` list for nodes without playerstage installed).

    Returns counts ``{"done", "failed"}`` as the local executor does. Ctrl-C stops the runs in
    flight and raises ``KeyboardInterrupt``; every result stored before it stays stored.
    """
    ray = _import_ray()
    counts = {"done": 0, "failed": 0}
    if not specs:
        return counts
    started_here = False
    if not ray.is_initialized():
        options: Dict[str, Any] = {"logging_level": logging.WARNING}
        if runtime_env is not None:
            options["runtime_env"] = runtime_env
        if address is None:
            # "local": a fresh Ray for this sweep, never a cluster found through RAY_ADDRESS.
            ray.init(address="local", num_cpus=jobs, include_dashboard=False, **options)
            log.info("started a local Ray for the sweep (%s CPUs)", jobs or "all")
        else:
            _check_reachable(address)
            ray.init(address=address, **options)
            log.info("connected to the Ray cluster at %s", address)
        started_here = True
    in_flight: Dict[Any, RunSpec] = {}  # object ref -> its run
    try:
        _drive(ray, list(specs), store, jobs, progress, max_retries, counts, in_flight)
    except KeyboardInterrupt:
        log.warning(
            "interrupted: stopping %d runs in flight (%d stored this time are kept)",
            len(in_flight),
            counts["done"],
        )
        if not started_here:
            # The caller's session goes on: stop our tasks in it. A running task gets a
            # KeyboardInterrupt at its next Python line. (Not force=True: Ray 2.60's driver can
            # abort when a force-cancelled task's reply is already on its way.)
            for ref in in_flight:
                ray.cancel(ref)
        # Ending our own session ends its job, and Ray stops the job's tasks on every node.
        raise
    finally:
        if started_here:
            ray.shutdown()
    return counts


def _drive(
    ray: Any,
    todo: List[RunSpec],
    store: Store,
    jobs: Optional[int],
    progress: Optional[Progress],
    max_retries: int,
    counts: Dict[str, int],
    in_flight: Dict[Any, RunSpec],
) -> None:
    """Keeps up to a window of runs submitted and stores each result as it arrives; the
    refs still running are left in ``in_flight`` (the caller's, for an interrupt)."""
    task = ray.remote(_execute_on_worker).options(
        num_cpus=1,
        max_retries=max_retries,
        # execute() returns a run's own failure as its result: an exception out of the task is
        # Ray's or the node's (e.g. playerstage missing there), not something to retry.
        retry_exceptions=False,
    )
    window = _window(ray, jobs)
    log.info("%d runs to do, up to %d in flight", len(todo), window)
    queue = list(reversed(todo))
    written: Set[str] = set()
    while queue or in_flight:
        while queue and len(in_flight) < window:
            spec = queue.pop()
            in_flight[task.remote(spec)] = spec
        ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=_WAIT_SECONDS)
        for ref in ready:
            spec = in_flight.pop(ref)
            if spec.run_id in written:
                # One reference per run resolves once; a run listed twice is run once.
                log.warning("run %s listed twice: stored once", spec.run_id)
                continue
            _finish(_result_of(ray, ref, spec), store, progress, counts)
            written.add(spec.run_id)


def _result_of(ray: Any, ref: Any, spec: RunSpec) -> Dict[str, Any]:
    """The run's result, or a failed one naming Ray's error when Ray could not get one (the
    task's retries used up by dying nodes or workers, or the task not starting at all)."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayError as e:
        log.error("run %s: Ray gave up on it: %s", spec.run_id, e)
        return crashed_result(spec, f"Ray gave up on the run's task: {type(e).__name__}: {e}")
