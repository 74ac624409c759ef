"""Parameter sweeps of Stage worlds: a plan (TOML, or ``Plan`` from Python) expanded into one
run per parameter point and seed, run on this machine's cores or a Ray cluster, resumable,
every run's result reproducible to the bit (its world digest).

``playerstage sweep PLAN.toml -o OUT`` is the command line; from Python::

    from playerstage.sweep import Plan, Store, executors

    plan = Plan(world="arena.world.tmpl", duration=20, seeds=3,
                params={"range": [1.0, 2.5], "speed": [0.3, 0.6]})
    store = Store("out")
    executors.local(executors.pending(plan.runs(), store), store)
    store.summarize()
"""

from .plan import Plan, PlanError, RunSpec, load_plan
from .run import current_run, execute
from .store import Store

__all__ = ["Plan", "PlanError", "RunSpec", "load_plan", "execute", "current_run", "Store"]
