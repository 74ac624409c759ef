"""Executors: who runs a sweep's runs. Each takes the runs still to do, runs them with
``run.execute`` somewhere, and hands every result to ``store.write`` and
``progress.update`` on the driver as it arrives.

``local`` (here) is a process pool over this machine's cores. The Ray executor lives in
``playerstage.sweep.ray_executor`` (``run(specs, store, address, jobs, progress)``), imported
only when asked for.
"""

import concurrent.futures as cf
import multiprocessing
import os
import signal
import tempfile
from typing import Any, Dict, List, Optional, Sequence, Set

from .plan import RunSpec
from .run import execute

#: How many times a run may be running in a worker process that dies before it is recorded as
#: failed (a crash can be the machine's, not the run's: it gets a second chance).
CRASHES_ALLOWED = 2


def pending(specs: Sequence[RunSpec], store, retry_failed: bool = False) -> List[RunSpec]:
    """The runs of ``specs`` not yet stored (or stored failed, with ``retry_failed``)."""
    return [s for s in specs
            if not store.done(s.run_id) or (retry_failed and store.failed(s.run_id))]


def _worker_init() -> None:
    # Ctrl-C goes to the whole process group: the driver stops the sweep and ends the
    # workers itself, so they must not die mid-run with a traceback of their own.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def crashed_result(spec: RunSpec, why: str) -> Dict[str, Any]:
    """The result recorded for a run whose worker process died under it."""
    return {"run_id": spec.run_id, "params": dict(spec.params), "seed": spec.seed,
            "point": spec.point, "config_hash": spec.config_hash, "world_name": spec.world_name,
            "world_text": spec.world_text, "digest": None, "steps": None, "sim_time": None,
            "summary": {}, "metrics": [], "error": why}


def _execute_marked(spec: RunSpec, running_dir: str) -> Dict[str, Any]:
    """``execute(spec)`` in a pool worker, with a file named for the run in ``running_dir``
    while it runs: when the worker dies, what is left there says which runs it took along."""
    mark = os.path.join(running_dir, spec.run_id)
    with open(mark, "w"):
        pass
    try:
        return execute(spec)
    finally:
        os.remove(mark)


def local(specs: Sequence[RunSpec], store, jobs: Optional[int] = None, progress=None,
          context: str = "forkserver") -> Dict[str, int]:
    """Runs ``specs`` on a pool of ``jobs`` worker processes (default: one per core), each
    result stored as it arrives. Ctrl-C (KeyboardInterrupt) ends the workers at once and is
    re-raised; every run finished before it is stored. A worker that dies (a crash in native
    code, ``os._exit``, the OOM killer) breaks the pool: the runs that were running are
    charged with it and everything unfinished is requeued on a new pool. When several runs were
    running, each of them is tried next alone, in a pool of its own, so that the crash is
    charged to the run that causes it and not to a neighbour that happened to share the pool;
    a run charged ``CRASHES_ALLOWED`` times is recorded as failed. Returns counts ``{"done",
    "failed"}``."""
    jobs = jobs or os.cpu_count() or 1
    todo = list(specs)
    crashes: Dict[str, int] = {}
    isolate: Set[str] = set()  # runs to try alone next
    counts = {"done": 0, "failed": 0}
    with tempfile.TemporaryDirectory(prefix="playerstage-sweep-") as running_dir:
        while todo:
            alone = [s for s in todo if s.run_id in isolate]
            batch = alone[:1] if alone else todo
            isolate.difference_update(s.run_id for s in batch)
            rest = [s for s in todo if s is not batch[0]] if alone else []
            broken = _run_pool(batch, min(jobs, len(batch)), context, running_dir, store,
                               progress, counts)
            if broken:
                suspects = set(os.listdir(running_dir))
                for name in suspects:
                    os.remove(os.path.join(running_dir, name))
                for spec in broken:
                    if spec.run_id in suspects:
                        crashes[spec.run_id] = crashes.get(spec.run_id, 0) + 1
                if len(suspects) > 1:
                    isolate.update(suspects)
                for spec in [s for s in broken if crashes.get(s.run_id, 0) >= CRASHES_ALLOWED]:
                    why = (f"the worker process died while running it ({CRASHES_ALLOWED} "
                           "times): a crash in native code or the machine out of memory")
                    _finish(crashed_result(spec, why), store, progress, counts)
                broken = [s for s in broken if crashes.get(s.run_id, 0) < CRASHES_ALLOWED]
            todo = rest + broken
    return counts


def _run_pool(batch: List[RunSpec], workers: int, context: str, running_dir: str, store,
              progress, counts: Dict[str, int]) -> List[RunSpec]:
    """Runs ``batch`` on a new pool of ``workers`` processes, storing each result; returns the
    runs left unfinished because a worker died (the pool broke)."""
    ctx = multiprocessing.get_context(context)
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
    broken: List[RunSpec] = []
    try:
        futures = {pool.submit(_execute_marked, s, running_dir): s for s in batch}
        for fut in cf.as_completed(futures):
            try:
                result = fut.result()
            except cf.process.BrokenProcessPool:
                broken.append(futures[fut])
                continue
            except Exception as e:  # e.g. a result that could not be pickled back
                result = crashed_result(futures[fut], f"the run's result did not come "
                                        f"back from its worker: {type(e).__name__}: {e}")
            _finish(result, store, progress, counts)
    except BaseException:
        _stop(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return broken


def _finish(result, store, progress, counts) -> None:
    store.write(result)
    counts["done"] += 1
    if result.get("error"):
        counts["failed"] += 1
    if progress is not None:
        progress.update(result)


def _stop(pool: cf.ProcessPoolExecutor) -> None:
    """Ends the pool's workers now (their runs in flight are lost and redone on resume)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=5)
