"""The driver's side of a sweep: where results go, what is already done, the summaries.

Layout of the output directory ``OUT``::

    OUT/runs/<run-id>/<world>      the filled worldfile the run loaded (e.g. arena.world)
    OUT/runs/<run-id>/run.json     parameters, seed, digest, summary metrics, error, wall time,
                                   host, versions, config hash
    OUT/runs/<run-id>/metrics.csv  step,time,subject,metric,value (subject: a robot, "world"
                                   or "custom")
    OUT/summary.csv                one row per run: the parameters, seed, digest, metrics, error
    OUT/summary.parquet            the same, when pyarrow is importable
    OUT/aggregate.csv              one row per point: runs, failed, then each metric's mean and
                                   std over the point's successful runs

A run's directory is written under a temporary name and renamed into place once complete, so
``run.json`` existing means the run finished; anything else (a sweep killed while writing) is
redone on resume. Only the driver writes here: workers return results, the driver stores them.
"""

import csv
import io
import json
import math
import os
import shutil
import uuid
from typing import Any, Dict, Iterable, List, Optional, Sequence

RUN_FILE = "run.json"
#: Summary columns the same for every run of a point (the plan sets them): not aggregated.
CONSTANT = ("steps", "sim_time", "robots_tracked")
METRICS_FILE = "metrics.csv"
METRICS_HEADER = ["step", "time", "subject", "metric", "value"]


def _cell(v: Any) -> str:
    """A CSV cell: numbers in their shortest exact form, lists as JSON, None empty."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v)
    return str(v)


def _write_csv(path: str, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow([_cell(v) for v in r])
    _atomic_write(path, buf.getvalue())


def _atomic_write(path: str, data: str) -> None:
    tmp = f"{path}.tmp-{os.getpid()}"
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class Store:
    """The results of one output directory (``Store(out_dir)``)."""

    def __init__(self, out_dir: str):
        self.out = os.path.abspath(out_dir)
        self.runs_dir = os.path.join(self.out, "runs")
        os.makedirs(self.runs_dir, exist_ok=True)

    def run_dir(self, run_id: str) -> str:
        return os.path.join(self.runs_dir, run_id)

    def done(self, run_id: str) -> bool:
        """Whether the run's result is stored (finished, successfully or with its error)."""
        return os.path.isfile(os.path.join(self.run_dir(run_id), RUN_FILE))

    def read(self, run_id: str) -> Optional[Dict[str, Any]]:
        """The stored ``run.json`` of a run, or None when it has none (or it is unreadable)."""
        try:
            with open(os.path.join(self.run_dir(run_id), RUN_FILE), encoding="utf-8") as f:
                return json.load(f)
        except (OSError, ValueError):
            return None

    def failed(self, run_id: str) -> bool:
        """Whether the run is stored with an error."""
        r = self.read(run_id)
        return bool(r and r.get("error"))

    def clean_partial(self) -> List[str]:
        """Removes what a killed sweep left half-written (temporary run directories and run
        directories without ``run.json``); returns their names."""
        gone = []
        for name in sorted(os.listdir(self.runs_dir)):
            path = os.path.join(self.runs_dir, name)
            if name.startswith(".") or (os.path.isdir(path) and not self.done(name)):
                shutil.rmtree(path, ignore_errors=True) if os.path.isdir(path) else os.remove(path)
                gone.append(name)
        return gone

    def write(self, result: Dict[str, Any]) -> str:
        """Stores one run's result (as ``execute`` returns it) atomically: its directory
        appears complete or not at all. A stored result of the same run (a failed run being
        retried) is replaced. Returns the run's directory."""
        run_id = result["run_id"]
        if not run_id or os.sep in run_id or run_id.startswith("."):
            raise ValueError(f"run id {run_id!r} is not a plain directory name")
        final = self.run_dir(run_id)
        tmp = os.path.join(self.runs_dir, f".tmp-{run_id}-{uuid.uuid4().hex[:8]}")
        os.makedirs(tmp)
        try:
            if result.get("world_text") is not None and result.get("world_name"):
                with open(os.path.join(tmp, result["world_name"]), "w", encoding="utf-8") as f:
                    f.write(result["world_text"])
            _write_csv(os.path.join(tmp, METRICS_FILE), METRICS_HEADER, result.get("metrics") or [])
            meta = {k: v for k, v in result.items() if k not in ("world_text", "metrics")}
            with open(os.path.join(tmp, RUN_FILE), "w", encoding="utf-8") as f:
                json.dump(meta, f, indent=1)
                f.flush()
                os.fsync(f.fileno())
            if os.path.exists(final):
                old = os.path.join(self.runs_dir, f".old-{run_id}-{uuid.uuid4().hex[:8]}")
                os.rename(final, old)
                os.rename(tmp, final)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.rename(tmp, final)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return final

    def results(self, run_ids: Optional[Sequence[str]] = None) -> List[Dict[str, Any]]:
        """The stored ``run.json`` of ``run_ids`` (those stored, in that order), or of every
        stored run (by name) when None."""
        if run_ids is None:
            run_ids = sorted(n for n in os.listdir(self.runs_dir) if not n.startswith("."))
        out = []
        for rid in run_ids:
            r = self.read(rid)
            if r is not None:
                out.append(r)
        return out

    def summarize(self, run_ids: Optional[Sequence[str]] = None) -> Dict[str, str]:
        """Writes ``summary.csv`` (and ``summary.parquet`` with pyarrow) and ``aggregate.csv``
        from the stored runs (``run_ids`` in that order, default every stored run); returns the
        paths written by kind. Only what a run computes goes in them (no wall time or host), so
        the same plan gives the same files wherever and however often it ran."""
        results = self.results(run_ids)
        params: List[str] = []
        metrics: List[str] = []
        for r in results:
            for k in r.get("params", {}):
                if k not in params:
                    params.append(k)
            for k in r.get("summary", {}):
                if k not in metrics:
                    metrics.append(k)
        header = params + ["seed", "digest"] + metrics + ["error"]
        rows = []
        for r in results:
            p, s = r.get("params", {}), r.get("summary", {})
            err = r.get("error")
            rows.append([p.get(k) for k in params] + [r.get("seed"), r.get("digest")]
                        + [s.get(k) for k in metrics]
                        + [err.strip().splitlines()[-1] if err else None])
        paths = {"summary": os.path.join(self.out, "summary.csv"),
                 "aggregate": os.path.join(self.out, "aggregate.csv")}
        _write_csv(paths["summary"], header, rows)
        parquet = self._parquet(header, rows)
        if parquet:
            paths["parquet"] = parquet
        _write_csv(paths["aggregate"], *self._aggregate(results, params, metrics))
        return paths

    def _parquet(self, header: List[str], rows: List[list]) -> Optional[str]:
        try:
            import pyarrow
            import pyarrow.parquet
        except ImportError:
            return None
        columns = {}
        for i, name in enumerate(header):
            col = [r[i] for r in rows]
            kinds = {type(v) for v in col if v is not None}
            if kinds and not kinds <= {int, float, str, bool}:
                col = [None if v is None else json.dumps(v) for v in col]
            elif kinds == {int, float}:
                col = [None if v is None else float(v) for v in col]
            elif len(kinds) > 1:
                col = [None if v is None else str(v) for v in col]
            columns[name] = col
        path = os.path.join(self.out, "summary.parquet")
        tmp = f"{path}.tmp-{os.getpid()}"
        pyarrow.parquet.write_table(pyarrow.table(columns), tmp)
        os.replace(tmp, path)
        return path

    @staticmethod
    def _aggregate(results, params, metrics):
        """Per point (same parameter values): how many runs succeeded and failed, and each
        numeric metric's mean and sample standard deviation over the successful ones."""
        groups: Dict[str, List[Dict[str, Any]]] = {}
        order: List[str] = []
        for r in results:
            key = json.dumps([r.get("params", {}).get(k) for k in params])
            if key not in groups:
                groups[key] = []
                order.append(key)
            groups[key].append(r)
        numeric = [m for m in metrics if m not in CONSTANT
                   and all(isinstance(r.get("summary", {}).get(m), (int, float))
                          and not isinstance(r.get("summary", {}).get(m), bool)
                          for r in results if not r.get("error") and m in r.get("summary", {}))
                   and any(m in r.get("summary", {}) for r in results)]
        header = params + ["runs", "failed"]
        for m in numeric:
            header += [f"{m}_mean", f"{m}_std"]
        rows = []
        for key in order:
            runs = groups[key]
            ok = [r for r in runs if not r.get("error")]
            row = json.loads(key) + [len(ok), len(runs) - len(ok)]
            for m in numeric:
                vals = [float(r["summary"][m]) for r in ok if m in r.get("summary", {})]
                mean = math.fsum(vals) / len(vals) if vals else None
                std = (math.sqrt(math.fsum((v - mean) ** 2 for v in vals) / (len(vals) - 1))
                       if len(vals) > 1 else None)
                row += [mean, std]
            rows.append(row)
        return header, rows
