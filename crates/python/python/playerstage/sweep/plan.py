"""A sweep's plan: which world, which parameter points, which seeds, how long, what to measure.

A plan is a TOML file (``load_plan(path)``) or the same keys given to ``Plan(...)`` from
Python. ``Plan.runs()`` expands it into one ``RunSpec`` per (parameter point, seed), each with
its worldfile already filled in, and checks the whole plan first: every error (an unknown key
or parameter, a placeholder left unset, a worldfile that does not load at some point of the
grid, a callable that cannot be imported) is a ``PlanError`` before anything runs, naming the
plan's line, the placeholder or the point.
"""

import fnmatch
import hashlib
import importlib
import importlib.util
import itertools
import json
import math
import os
import re
import sys
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

from . import worldtext

#: Per-robot built-in metrics: the final pose (``x``, ``y``, ``a``), distance travelled (m),
#: time stalled (simulated s) and collisions (stall flag going from clear to set).
ROBOT_METRICS = ("pose", "distance", "stalled", "collisions")
#: World built-in metrics: the determinism digest, simulated seconds, wall-clock seconds.
WORLD_METRICS = ("digest", "sim_time", "wall_time")
#: The plan's top-level keys, and the keys of its ``[metrics]`` table.
PLAN_KEYS = (
    "name", "world", "duration", "steps", "seeds", "params", "points", "set", "derive",
    "controller", "controllers", "metrics", "python_params", "python_path",
)
METRICS_KEYS = ("robots", "robot", "world", "custom", "every")
#: summary.csv's columns besides the parameters and custom metrics (no parameter may be one).
SUMMARY_COLUMNS = ("run_id", "seed", "digest", "error", "steps", "sim_time", "robots_tracked") + tuple(
    f"{m}_{agg}" for m in ("distance", "stalled", "collisions") for agg in ("mean", "total"))


class PlanError(ValueError):
    """A plan that cannot run as written; the message says where (plan line, template
    placeholder, grid point)."""


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep, everything a worker needs, as plain picklable data.

    ``run_id`` is derived from ``params`` and ``seed`` only (readable, filesystem-safe, with a
    hash), so the same point and seed has the same id in every sweep of the plan: what resume
    keys on. ``config_hash`` covers everything else that decides the result (the filled
    worldfile, the run length, controller and metrics), so results made under another
    configuration are not mistaken for this run's.
    """

    run_id: str
    params: Dict[str, Any]
    seed: int
    world_text: str
    world_name: str
    world_dir: str
    steps: Optional[int]
    duration: Optional[float]
    controller: Optional[str]
    metrics: Dict[str, Any]
    python_path: Tuple[str, ...]
    config_hash: str
    point: int


def _toml():
    try:
        import tomllib  # Python 3.11+

        return tomllib
    except ImportError:
        try:
            import tomli  # the same parser, for Python 3.9 and 3.10

            return tomli
        except ImportError:
            raise PlanError(
                "reading a TOML plan needs Python 3.11+ or the `tomli` package "
                "(pip install tomli)"
            ) from None


def load_plan(path: Union[str, os.PathLike]) -> "Plan":
    """Reads a TOML plan; relative paths in it are relative to its directory."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except OSError as e:
        raise PlanError(f"{path}: cannot read the plan: {e.strerror or e}") from None
    text = raw.decode("utf-8", errors="replace")
    toml = _toml()
    try:
        data = toml.loads(text)
    except toml.TOMLDecodeError as e:
        raise PlanError(f"{path}: not valid TOML: {e}") from None
    locator = _Locator(path, text)
    unknown = [k for k in data if k not in PLAN_KEYS]
    if unknown:
        k = unknown[0]
        raise PlanError(
            f"{locator.where(None, k)}: unknown key `{k}` (known: {', '.join(PLAN_KEYS)})"
        )
    kwargs = {k: data[k] for k in PLAN_KEYS if k in data}
    kwargs["base_dir"] = os.path.dirname(os.path.abspath(path))
    plan = Plan(**kwargs)
    plan._locator = locator
    return plan


class _Locator:
    """Finds the line of a key in the plan's TOML text (TOML parsers give none for values)."""

    _HEADER = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")

    def __init__(self, path: str, text: str):
        self.path = path
        self.lines = text.splitlines()

    def line(self, table: Optional[str], key: str, index: int = 0) -> Optional[int]:
        """The line of ``key`` in ``table`` (the ``index``-th ``[[table]]`` for an array of
        tables); else of a dotted or inline definition of the table; else of ``key`` anywhere."""
        q = re.escape(key)
        key_re = re.compile(r"^\s*(?:" + q + r'|"' + q + r'"|\'' + q + r"')\s*=")
        current: Optional[str] = None
        seen = -1
        fallback = None
        for n, line in enumerate(self.lines, 1):
            h = self._HEADER.match(line)
            if h:
                current = h.group(1).strip().strip('"')
                if current == table:
                    seen += 1
                continue
            if key_re.match(line):
                if current == table and (table != "points" or seen == index):
                    return n
                if fallback is None:
                    fallback = n
        if table is not None:
            # a table given inline (`params = { ... }`) or by dotted keys (`params.x = ...`)
            dotted = re.compile(r"^\s*" + re.escape(table) + r"\s*[.=]")
            for n, line in enumerate(self.lines, 1):
                if dotted.match(line):
                    return n
        return fallback

    def where(self, table: Optional[str], key: str, index: int = 0) -> str:
        n = self.line(table, key, index)
        label = f"[{table}] {key}" if table else key
        return f"{self.path}:{n}: {label}" if n else f"{self.path}: {label}"


class _NoFile:
    """Where-messages for a plan built in Python (no file, no lines)."""

    def where(self, table: Optional[str], key: str, index: int = 0) -> str:
        return f"plan: [{table}] {key}" if table else f"plan: {key}"


def resolve_callable(ref: str, python_path: Sequence[str] = ()) -> Callable:
    """``"module:function"`` (importable, ``python_path`` directories searched first) or
    ``"path/to/file.py:function"`` (relative to the first ``python_path`` entry, the plan's
    directory) as the function it names."""
    if not isinstance(ref, str) or ref.count(":") != 1:
        raise ValueError(f"{ref!r}: not `module:function` or `file.py:function`")
    mod_name, func = ref.split(":")
    for d in reversed(list(python_path)):
        if d not in sys.path:
            sys.path.insert(0, d)
    if mod_name.endswith(".py"):
        path = mod_name
        if not os.path.isabs(path) and python_path:
            path = os.path.join(python_path[0], path)
        path = os.path.abspath(path)
        key = "_playerstage_sweep_" + hashlib.sha1(path.encode()).hexdigest()[:12]
        module = sys.modules.get(key)
        if module is None:
            spec = importlib.util.spec_from_file_location(key, path)
            if spec is None or not os.path.isfile(path):
                raise ValueError(f"{ref}: no file {path}")
            module = importlib.util.module_from_spec(spec)
            sys.modules[key] = module
            try:
                spec.loader.exec_module(module)
            except BaseException:
                del sys.modules[key]
                raise
    else:
        module = importlib.import_module(mod_name)
    try:
        fn = getattr(module, func)
    except AttributeError:
        raise ValueError(f"{ref}: module `{mod_name}` has no `{func}`") from None
    if not callable(fn):
        raise ValueError(f"{ref}: `{func}` is not callable")
    return fn


def _slug(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        return "_".join(_slug(v) for v in value)
    if isinstance(value, float) and value.is_integer():
        value = int(value) if abs(value) < 1e15 else value
    # keep a value's own minus sign (-1 and 1 must not read alike); other characters -> "-"
    return re.sub(r"[^A-Za-z0-9.+-]+", "-", str(value)) or "x"


def run_id(params: Dict[str, Any], seed: int) -> str:
    """The run's id: ``name-value_..._s<seed>_<hash>``, readable, safe as a file name on every
    common filesystem, and unique (the hash covers the exact parameter values and seed)."""
    canonical = json.dumps({"params": params, "seed": seed}, sort_keys=True, default=str)
    digest = hashlib.sha1(canonical.encode()).hexdigest()[:8]
    slug = "_".join(f"{_slug(k)}-{_slug(v)}" for k, v in params.items())
    if len(slug) > 64:
        slug = slug[:64].rstrip("-_.")
    if slug.startswith((".", "-")):
        slug = "p" + slug  # hidden names are the store's temporaries; "-" reads as an option
    return f"{slug}_s{seed}_{digest}" if slug else f"s{seed}_{digest}"


def _point_label(params: Dict[str, Any]) -> str:
    return "{" + ", ".join(f"{k}={v!r}" for k, v in params.items()) + "}"


@dataclass
class Plan:
    """A sweep plan; the keys of the TOML file are its fields (see the package docs).

    ``world``: the worldfile or template (relative to ``base_dir``). ``duration``
    (simulated seconds) or ``steps``. ``seeds``: a count N (seeds 1..N) or a list.
    ``params``: name -> list of values (a grid, every combination) or one value; ``points``: a
    list of explicit points (dicts), combined with the grid when both are given. A parameter
    is a template placeholder ``{{name}}``, a property override ``"model.property"``, or, if
    listed in ``python_params``, only read by your callables (``current_run().params``).
    ``set``: overrides for every run. ``derive``: placeholder -> ``module:function(params,
    seed)`` computing its text. ``controller``: ``module:function(world, t)`` called before
    every step; ``controllers``: model name or glob -> a built-in controller (the engine's
    ``ctrl``, e.g. ``"wander"``). ``metrics``: ``robots`` (globs of position models, default
    all), ``robot`` (built-ins per robot), ``world``, ``custom`` (``module:function(world) ->
    dict``), ``every`` (sample every K steps; 0: at the end only).
    """

    world: str
    duration: Optional[float] = None
    steps: Optional[int] = None
    seeds: Union[int, List[int]] = 1
    params: Dict[str, Any] = field(default_factory=dict)
    points: List[Dict[str, Any]] = field(default_factory=list)
    set: Dict[str, Any] = field(default_factory=dict)
    derive: Dict[str, str] = field(default_factory=dict)
    controller: Optional[str] = None
    controllers: Dict[str, str] = field(default_factory=dict)
    metrics: Dict[str, Any] = field(default_factory=dict)
    python_params: List[str] = field(default_factory=list)
    python_path: List[str] = field(default_factory=list)
    name: Optional[str] = None
    base_dir: str = "."

    def __post_init__(self):
        self._locator = _NoFile()

    # -- checks of the plan's own values -------------------------------------------------

    def _where(self, table: Optional[str], key: str, index: int = 0) -> str:
        return self._locator.where(table, key, index)

    def _fail(self, table: Optional[str], key: str, msg: str, index: int = 0):
        raise PlanError(f"{self._where(table, key, index)}: {msg}")

    def _seeds(self) -> List[int]:
        s = self.seeds
        if isinstance(s, bool) or not isinstance(s, (int, list, tuple)):
            self._fail(None, "seeds", f"{s!r}: a count (seeds 1..N) or a list of integers")
        if isinstance(s, int):
            if s < 1:
                self._fail(None, "seeds", f"{s}: the count must be at least 1")
            return list(range(1, s + 1))
        if not s or any(isinstance(x, bool) or not isinstance(x, int) or x < 0 for x in s):
            self._fail(None, "seeds", f"{s!r}: a non-empty list of integers >= 0")
        if len(set(s)) != len(s):
            self._fail(None, "seeds", f"{s!r}: a seed is listed twice")
        return list(s)

    def _length(self) -> Tuple[Optional[int], Optional[float]]:
        if (self.duration is None) == (self.steps is None):
            self._fail(None, "duration", "give exactly one of `duration` (simulated seconds) "
                       "and `steps`")
        if self.steps is not None:
            if isinstance(self.steps, bool) or not isinstance(self.steps, int) or self.steps < 1:
                self._fail(None, "steps", f"{self.steps!r}: a whole number of steps >= 1")
            return self.steps, None
        d = self.duration
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not (d > 0 and math.isfinite(d)):
            self._fail(None, "duration", f"{d!r}: simulated seconds, a number > 0")
        return None, float(d)

    def _metrics(self) -> Dict[str, Any]:
        m = self.metrics
        if not isinstance(m, dict):
            self._fail(None, "metrics", "a table of robots, robot, world, custom, every")
        for k in m:
            if k not in METRICS_KEYS:
                self._fail("metrics", k, f"unknown key (known: {', '.join(METRICS_KEYS)})")
        robots = m.get("robots", ["*"])
        if isinstance(robots, str):
            robots = [robots]
        robot = m.get("robot", list(ROBOT_METRICS))
        world = m.get("world", list(WORLD_METRICS))
        custom = m.get("custom", [])
        if isinstance(custom, str):
            custom = [custom]
        every = m.get("every", 0)
        for key, vals, allowed in (("robot", robot, ROBOT_METRICS), ("world", world, WORLD_METRICS)):
            if not isinstance(vals, list) or any(v not in allowed for v in vals):
                self._fail("metrics", key, f"{vals!r}: a list of {', '.join(allowed)}")
        if not isinstance(robots, list) or not all(isinstance(r, str) for r in robots):
            self._fail("metrics", "robots", f"{robots!r}: model names or globs")
        if isinstance(every, bool) or not isinstance(every, int) or every < 0:
            self._fail("metrics", "every", f"{every!r}: a whole number of steps >= 0 (0: at the end)")
        for ref in custom:
            self._check_callable("metrics", "custom", ref)
        return {"robots": list(robots), "robot": list(robot), "world": list(world),
                "custom": list(custom), "every": every}

    def _python_path(self) -> List[str]:
        paths = self.python_path
        if isinstance(paths, str):
            paths = [paths]
        base = os.path.abspath(self.base_dir)
        return [base] + [os.path.normpath(os.path.join(base, p)) for p in paths]

    def _check_callable(self, table: Optional[str], key: str, ref: Any) -> Callable:
        try:
            return resolve_callable(ref, self._python_path())
        except Exception as e:  # an import error of the user's module is the plan's error
            self._fail(table, key, f"{ref!r}: cannot load it: {type(e).__name__}: {e}")

    def _points(self) -> List[Dict[str, Any]]:
        if not isinstance(self.params, dict):
            self._fail(None, "params", "a table of name = [values] (or one value)")
        axes = []
        for k, v in self.params.items():
            values = list(v) if isinstance(v, list) else [v]
            if not values:
                self._fail("params", k, "an empty list: the grid would have no point")
            axes.append((k, values))
        grid = [dict(zip([k for k, _ in axes], combo))
                for combo in itertools.product(*[vals for _, vals in axes])]
        if not isinstance(self.points, list) or not all(isinstance(p, dict) for p in self.points):
            self._fail(None, "points", "a list of tables (one per point)")
        if not self.points:
            return grid
        out = []
        for i, p in enumerate(self.points):
            clash = [k for k in p if k in self.params]
            if clash:
                self._fail("points", clash[0], "given both in [params] and in a point", i)
            for g in grid:
                out.append({**p, **g})
        return out

    # -- expansion ------------------------------------------------------------------------

    def runs(self, check: bool = True) -> List[RunSpec]:
        """Every run of the plan, points in grid order (the last parameter varying fastest)
        and seeds innermost. With ``check`` (the default) each distinct filled worldfile is
        loaded once, so a point whose world does not load is refused here, before any run."""
        if not isinstance(self.world, str) or not self.world:
            self._fail(None, "world", "the worldfile or template to run (a path)")
        steps, duration = self._length()
        seeds = self._seeds()
        metrics = self._metrics()
        python_path = self._python_path()
        template_path = os.path.abspath(os.path.join(self.base_dir, self.world))
        try:
            with open(template_path, encoding="utf-8") as f:
                template = f.read()
        except OSError as e:
            self._fail(None, "world", f"cannot read {template_path}: {e.strerror or e}")
        try:
            holes = worldtext.placeholders(template)
        except worldtext.TemplateError as e:
            raise PlanError(f"{template_path}:{e.line}: {e}") from None
        world_name = os.path.basename(template_path)
        if world_name.endswith(".tmpl"):
            world_name = world_name[: -len(".tmpl")]
        world_dir = os.path.dirname(template_path)

        if not isinstance(self.python_params, list):
            self._fail(None, "python_params", "a list of parameter names")
        if not isinstance(self.derive, dict):
            self._fail(None, "derive", "a table of placeholder = \"module:function\"")
        derive = {}
        for k, ref in self.derive.items():
            if k in self.params or any(k in p for p in self.points):
                self._fail("derive", k, "is also a parameter: a placeholder gets one value")
            if k not in holes:
                self._fail("derive", k, f"no {{{{{k}}}}} placeholder in {world_name}")
            derive[k] = self._check_callable("derive", k, ref)
        controller = None
        if self.controller is not None:
            self._check_callable(None, "controller", self.controller)
            controller = self.controller
        if not isinstance(self.controllers, dict):
            self._fail(None, "controllers", "a table of model (or glob) = \"controller\"")
        for k, v in self.controllers.items():
            if not isinstance(v, str) or not v.strip():
                self._fail("controllers", k, f"{v!r}: a built-in controller's name, e.g. \"wander\"")
        fixed = []
        if not isinstance(self.set, dict):
            self._fail(None, "set", "a table of \"model.property\" = value")
        for k, v in self.set.items():
            if "." not in k:
                self._fail("set", k, "an override is \"model.property\"")
            fixed.append((k, v))

        points = self._points()
        # every parameter must do something
        names = []
        for p in points:
            for k in p:
                if k not in names:
                    names.append(k)
        for k in names:
            table, index = self._param_table(k)
            if k == "seed":
                self._fail(table, k, "`seed` is the run's seed (set by `seeds`), not a parameter",
                           index)
            if k in SUMMARY_COLUMNS:
                self._fail(table, k, f"`{k}` is a built-in column of summary.csv: give the "
                           "parameter another name", index)
            if "." in k:
                model, _, prop = k.rpartition(".")
                if not model or not prop:
                    self._fail(table, k, "an override is \"model.property\"", index)
            elif k not in holes and k not in self.python_params:
                self._fail(table, k, f"unknown parameter: {world_name} has no {{{{{k}}}}} "
                           "placeholder and it is not a \"model.property\" override (a parameter "
                           "only your Python code reads goes in `python_params`)", index)
        for k in self.python_params:
            if k not in names:
                self._fail(None, "python_params", f"`{k}` is not a parameter of the plan")
        for hole, line in holes.items():
            if hole == "seed" or hole in derive:
                continue
            missing = [p for p in points if hole not in p]
            if missing:
                which = ("no point of the plan" if len(missing) == len(points)
                         else f"point {_point_label(missing[0])}")
                raise PlanError(f"{template_path}:{line}: placeholder {{{{{hole}}}}} is left "
                                f"unset: {which} gives it a value (add it to [params])")

        specs = []
        texts: Dict[str, Tuple[Dict[str, Any], int]] = {}
        for index, p in enumerate(points):
            for seed in seeds:
                values: Dict[str, Any] = {k: v for k, v in p.items() if "." not in k}
                values["seed"] = seed
                where = f"point {_point_label(p)} seed {seed}"
                for k, fn in derive.items():
                    try:
                        values[k] = fn(dict(p), seed)
                    except Exception as e:
                        raise PlanError(f"{self._where('derive', k)}: {where}: "
                                        f"{type(e).__name__}: {e}") from None
                try:
                    text = worldtext.fill(template, values)
                    overrides = [(*k.rsplit(".", 1), v) for k, v in fixed]
                    overrides += [(*k.rsplit(".", 1), v) for k, v in p.items() if "." in k]
                    for pattern, ctrl in self.controllers.items():
                        matched = worldtext.glob_models(text, pattern)
                        if not matched:
                            self._fail("controllers", pattern, f"{where}: no model named "
                                       f"`{pattern}` in {world_name}")
                        overrides += [(m, "ctrl", ctrl) for m in matched]
                    text = worldtext.set_properties(text, overrides)
                except worldtext.TemplateError as e:
                    at = f"{template_path}:{e.line}" if e.line else template_path
                    raise PlanError(f"{at}: {where}: {e}") from None
                texts.setdefault(text, (p, seed))
                config = json.dumps({"world": text, "steps": steps, "duration": duration,
                                     "controller": controller, "metrics": metrics},
                                    sort_keys=True)
                specs.append(RunSpec(
                    run_id=run_id(p, seed), params=dict(p), seed=seed, world_text=text,
                    world_name=world_name, world_dir=world_dir, steps=steps, duration=duration,
                    controller=controller, metrics=metrics, python_path=tuple(python_path),
                    config_hash=hashlib.sha1(config.encode()).hexdigest()[:16], point=index,
                ))
        if check:
            self._check_worlds(texts, world_dir, world_name, metrics)
        return specs

    def _param_table(self, k: str) -> Tuple[str, int]:
        if k in self.params:
            return "params", 0
        for i, p in enumerate(self.points):
            if k in p:
                return "points", i
        return "params", 0

    def _check_worlds(self, texts, world_dir, world_name, metrics) -> None:
        from .. import _native

        path = os.path.join(world_dir, world_name)
        for text, (p, seed) in texts.items():
            where = f"point {_point_label(p)} seed {seed}"
            try:
                w = _native.World(path, seed, text=text)
            except Exception as e:
                raise PlanError(f"{where}: the worldfile does not load: {e}") from None
            if self.controllers:
                bad = [w for w in w.warnings() if w.startswith("controller ")]
                if bad:
                    raise PlanError(f"{self._where('controllers', next(iter(self.controllers)))}:"
                                    f" {where}: {bad[0]}")
            positions = [n for n, t in w.models() if t == "position"]
            for pattern in metrics["robots"]:
                if not fnmatch.filter(positions, pattern):
                    raise PlanError(f"{self._where('metrics', 'robots')}: {where}: no position "
                                    f"model matches `{pattern}`")
