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
from typing import Any, Dict, List, Optional, Sequence

from .plan import RunSpec
from .run import execute

#: How many times a run may be in flight when a worker process dies before it is recorded as
#: failed (the others in flight with it are requeued).
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


def local(specs: Sequence[RunSpec], store, jobs: Optional[int] = None, progress=None,
          context: str = "forkserver") -> Dict[str, int]:
    """Runs ``specs`` on a pool of ``jobs`` worker processes (default: one per core), each
    result stored as it arrives. Ctrl-C (KeyboardInterrupt) ends the workers at once and is
    re-raised; every run finished before it is stored. A worker that dies (a crash in native
    code, the OOM killer) takes its runs with it: they are requeued on a new pool, and a run
    in flight at ``CRASHES_ALLOWED`` such deaths is recorded as failed. Returns counts
    ``{"done", "failed"}``."""
    jobs = jobs or os.cpu_count() or 1
    todo = list(specs)
    crashes: Dict[str, int] = {}
    counts = {"done": 0, "failed": 0}
    while todo:
        ctx = multiprocessing.get_context(context)
        pool = cf.ProcessPoolExecutor(max_workers=min(jobs, len(todo)), mp_context=ctx,
                                      initializer=_worker_init)
        try:
            futures = {pool.submit(execute, s): s for s in todo}
            todo = []
            for fut in cf.as_completed(futures):
                spec = futures[fut]
                try:
                    result = fut.result()
                except cf.process.BrokenProcessPool:
                    # running() was true for the runs handed to a worker: the suspects
                    continue
                _finish(result, store, progress, counts)
            for fut, spec in futures.items():
                if fut.done() and fut.exception() is not None:
                    todo.append(spec)
            if todo:
                for spec in todo:
                    crashes[spec.run_id] = crashes.get(spec.run_id, 0) + 1
                dead = [s for s in todo if crashes[s.run_id] >= CRASHES_ALLOWED]
                for s in dead:
                    _finish(crashed_result(s, f"the worker process died while running it "
                                              f"({CRASHES_ALLOWED} times)"),
                            store, progress, counts)
                todo = [s for s in todo if crashes[s.run_id] < CRASHES_ALLOWED]
        except BaseException:
            _stop(pool)
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    return counts


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
