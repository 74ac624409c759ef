"""``playerstage sweep PLAN.toml [-o OUT] [--executor local|ray] [--jobs N] [--address ADDR]``.

Checks the whole plan first (a bad plan exits 2 before any run), skips the runs already stored
in OUT (resume), runs the rest, and writes the summaries. Exit status: 0 when every run
succeeded, 1 when some failed (recorded in OUT, the others ran), 2 for a bad plan or
command line, 130 on Ctrl-C (finished runs kept; run the same command again to resume).
"""

import argparse
import logging
import os
import shutil
import sys
from typing import List, Optional

from .plan import PlanError, load_plan

log = logging.getLogger("playerstage.sweep")


def parser(prog: str = "playerstage sweep") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=prog,
        description="Run a parameter sweep of a Stage world: every parameter point of PLAN "
                    "times every seed, resumable, results in OUT.")
    p.add_argument("plan", help="the plan (TOML)")
    p.add_argument("-o", "--out", help="output directory (default: PLAN's name + '.out' in "
                                       "the current directory)")
    p.add_argument("--executor", choices=["local", "ray"], default="local",
                   help="local: a process pool on this machine (default); ray: one Ray task "
                        "per run")
    p.add_argument("-j", "--jobs", type=int, default=None,
                   help="worker processes (local; default: one per core) or concurrent tasks "
                        "(ray)")
    p.add_argument("--address", default=None,
                   help="Ray cluster address (ray; default: a local Ray started for the sweep)")
    p.add_argument("--retry-failed", action="store_true",
                   help="run again the runs stored with an error")
    p.add_argument("--check", action="store_true",
                   help="check the plan (every point's world loads) and exit without running")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    return p


def main(argv: Optional[List[str]] = None, prog: str = "playerstage sweep") -> int:
    args = parser(prog).parse_args(argv)
    if not logging.getLogger().handlers:
        logging.basicConfig(level=logging.WARNING if args.quiet else logging.INFO,
                            format="%(name)s: %(message)s", stream=sys.stderr)
    if args.address is not None and args.executor != "ray":
        print(f"{prog}: error: --address is the Ray cluster's: use it with --executor ray",
              file=sys.stderr)
        return 2
    if args.jobs is not None and args.jobs < 1:
        print(f"{prog}: error: --jobs {args.jobs}: at least 1", file=sys.stderr)
        return 2
    try:
        plan = load_plan(args.plan)
        specs = plan.runs()
    except PlanError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    if args.check:
        points = len({s.point for s in specs})
        print(f"{args.plan}: ok: {len(specs)} runs ({points} points x "
              f"{len(specs) // max(points, 1)} seeds)")
        return 0
    out = args.out or os.path.splitext(os.path.basename(args.plan))[0] + ".out"

    from .executors import local, pending
    from .progress import Progress
    from .store import Store

    store = Store(out)
    gone = store.clean_partial()
    if gone:
        log.info("removed %d half-written run(s) of an earlier sweep: they run again", len(gone))
    for s in specs:
        stored = store.read(s.run_id)
        if stored is not None and stored.get("config_hash") != s.config_hash:
            print(f"{prog}: error: {store.run_dir(s.run_id)} holds a result made with another "
                  "world, length, controller or metrics than this plan gives it: use a new "
                  "output directory (-o) or remove that one", file=sys.stderr)
            return 2
    try:
        shutil.copyfile(args.plan, os.path.join(store.out, "plan.toml"))
    except OSError as e:
        log.warning("could not copy the plan into %s: %s", store.out, e)
    todo = pending(specs, store, args.retry_failed)
    progress = Progress(len(specs), skipped=len(specs) - len(todo),
                        bar=False if args.quiet else None)
    log.info("sweep: %d runs, %d to do, output in %s", len(specs), len(todo), store.out)
    try:
        if args.executor == "ray":
            try:
                from . import ray_executor
            except ImportError as e:
                if e.name and e.name.endswith("ray_executor"):
                    print(f"{prog}: error: the ray executor is not installed", file=sys.stderr)
                    return 2
                raise
            try:
                ray_executor.run(todo, store, args.address, args.jobs, progress)
            except ray_executor.RayUnavailable as e:
                progress.close()
                print(f"{prog}: error: {e}", file=sys.stderr)
                return 2
        else:
            local(todo, store, args.jobs, progress)
    except KeyboardInterrupt:
        progress.close()
        store.summarize([s.run_id for s in specs])
        stored = sum(store.done(s.run_id) for s in specs)
        print(f"{prog}: interrupted: {stored} of {len(specs)} runs stored in {store.out}; run "
              "the same command again to do the rest", file=sys.stderr)
        return 130
    progress.close()
    paths = store.summarize([s.run_id for s in specs])
    failed = sum(store.failed(s.run_id) for s in specs)
    print(f"{paths['summary']}: {len(specs)} runs, {failed} failed", file=sys.stderr)
    return 1 if failed else 0
