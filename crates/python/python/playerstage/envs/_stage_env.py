"""`StageEnv`: one position model of a Stage worldfile as a Gymnasium environment."""

from __future__ import annotations

import math
import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import gymnasium
import numpy as np
from gymnasium import spaces

from .. import World

#: A user task: called after every environment step with the world and the robot's name,
#: returns ``(reward, terminated, info)``.
Task = Callable[[World, str], Tuple[float, bool, Dict[str, Any]]]

_RESET_OPTIONS = frozenset({"random_start", "start", "goal"})


class StageEnv(gymnasium.Env):
    """One position model (``robot``) of the worldfile ``world``, simulated in-process.

    **Action** — a ``Box`` (float64) of body-frame speed commands, bounded by the model's
    ``velocity_bounds`` (``[xmin xmax ymin ymax zmin zmax amin amax]``, m/s and rad/s, as the
    worldfile resolves them): ``(forward, turn)`` for ``diff`` and ``car`` drives (for ``car``
    the second value is the steering angle, as Stage reads it), ``(x, y, turn)`` for ``omni``.
    Actions outside the box are clipped to it (Stage would clamp them too). Each action is
    applied for ``frame_skip`` simulation steps of the world's ``interval_sim``.

    **Observation** — a ``Dict`` (or, with ``flatten=True``, the ``Box`` that
    :func:`gymnasium.spaces.flatten_space` makes of it):

    - ``"rangers"``: a ``Dict`` with one ``Box`` (float32, metres, ``[0, range_max]``) per
      ranger in the robot's tree, keyed by the ranger's model name, laid out as
      ``World.ranger(name)["ranges"]`` (one transducer: all its samples; several, e.g. a sonar
      ring: one reading each). A ranger that has not updated yet reads ``range_max``
      everywhere (nothing seen); readings are clipped to the bounds.
    - ``"odometry"``: ``Box`` (float32, 6) of ``px, py, pa, vx, vy, va``, the position model's
      data as Player's position2d has it (its odometry frame; ``gps`` localization: the true
      pose).
    - ``"stall"``: ``Discrete(2)``, 1 when the robot's last move was blocked.
    - ``"goal"`` (task ``"goal"`` only): ``Box`` (float32, 2), the goal's position in the
      robot's frame (x ahead, y to the left; from the true pose, not odometry).

    **Task** — reward, termination and the step's ``info``:

    - ``"goal"`` (default): reach the goal position. Each step's reward is the decrease of the
      robot's distance to the goal, minus ``stall_penalty`` when the robot stalls, plus
      ``goal_reward`` when it ends within ``goal_tolerance`` metres of the goal, which
      terminates the episode; a stall terminates it too when ``terminate_on_stall``. ``info``
      has ``distance``, ``stall`` and ``reached``. The goal is ``options["goal"]``, else the
      constructor's ``goal``, else drawn in free space from the episode's seed.
    - ``None``: reward 0, never terminated (sensing and motion only).
    - a callable ``task(world, robot) -> (reward, terminated, info)`` (see :data:`Task`),
      called after every step with the :class:`playerstage.World` and the robot's name.

    Episodes are truncated when the world reaches its ``quit_time`` and after
    ``max_episode_steps`` actions when given (``gymnasium.make`` adds its own ``TimeLimit``,
    1000 steps unless told otherwise).

    **Reset** — ``reset(seed=..., options=...)`` loads the worldfile afresh with
    ``world_seed``, so every model's pose, velocity, stall, carried object and the simulator's
    random state are as loaded, bit for bit. Then the robot is placed: at ``options["start"]``
    (``(x, y, a)``, world frame) if given, else at a pose drawn in free space when
    ``options["random_start"]`` (default: the constructor's ``random_start``) is true, else
    where the file puts it; then the goal is chosen; then the world takes one step with the
    robot at rest, so that every sensor has a reading. Drawn poses come from the env's
    ``np_random`` (seeded by ``reset(seed=...)``), uniformly over the box around every model's
    blocks (``World.extent()``); a pose is free when the robot's tree there overlaps no block
    of another model (``World.overlaps``, any ``obstacle_return``), and a drawn goal is more
    than ``2 * goal_tolerance`` from the start; after ``max_draws`` draws without one, reset
    raises ``RuntimeError``. The same seed and options therefore give the
    same episode, bit for bit. The robot must be a top-level model (poses are set in its
    parent's frame).
    """

    #: ``"rgb_array"``: :meth:`render` draws the world offscreen. Each env's ``render_fps`` is
    #: the simulated rate of its actions, ``1 / (interval_sim * frame_skip)``.
    metadata: Dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": None}

    def __init__(
        self,
        world: Union[str, "os.PathLike[str]"],
        robot: str,
        *,
        world_seed: int = 0,
        frame_skip: int = 1,
        task: Union[str, Task, None] = "goal",
        goal: Optional[Sequence[float]] = None,
        goal_tolerance: float = 0.3,
        goal_reward: float = 1.0,
        stall_penalty: float = 1.0,
        terminate_on_stall: bool = False,
        random_start: bool = False,
        flatten: bool = False,
        max_episode_steps: Optional[int] = None,
        max_draws: int = 10000,
        render_mode: Optional[str] = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode {render_mode!r}: StageEnv renders {self.metadata['render_modes']}"
                " ('human', in the world window, is not supported yet)"
            )
        if int(frame_skip) != frame_skip or frame_skip < 1:
            raise ValueError(f"frame_skip {frame_skip!r}: not a whole number >= 1")
        if max_episode_steps is not None and (
            int(max_episode_steps) != max_episode_steps or max_episode_steps < 1
        ):
            raise ValueError(f"max_episode_steps {max_episode_steps!r}: not a whole number >= 1")
        if int(max_draws) != max_draws or max_draws < 1:
            raise ValueError(f"max_draws {max_draws!r}: not a whole number >= 1")
        if isinstance(task, str):
            if task != "goal":
                raise ValueError(f"task {task!r}: the built-in tasks are 'goal' (or None)")
        elif task is not None and not callable(task):
            raise TypeError(f"task {task!r}: not 'goal', None or a callable")
        if not (goal_tolerance > 0 and math.isfinite(goal_tolerance)):
            raise ValueError(f"goal_tolerance {goal_tolerance!r}: not a positive length")
        self.render_mode = render_mode
        self._path = os.fspath(world)
        self._robot = robot
        self._world_seed = int(world_seed)
        self._frame_skip = int(frame_skip)
        self._task = task
        self._goal_default = _pose2(goal, "goal") if goal is not None else None
        self._goal_tolerance = float(goal_tolerance)
        self._goal_reward = float(goal_reward)
        self._stall_penalty = float(stall_penalty)
        self._terminate_on_stall = bool(terminate_on_stall)
        self._random_start = bool(random_start)
        self._flatten = bool(flatten)
        self._max_episode_steps = max_episode_steps
        self._max_draws = int(max_draws)

        self._load()
        self.metadata = {
            **self.metadata,
            "render_fps": 1.0 / (self._world.interval * int(frame_skip)),
        }
        drive, bounds = self._world.position_config(robot)
        self._drive: str = drive
        self._rangers: List[Tuple[str, int, float]] = self._world.rangers(robot)
        self._extent: Optional[List[float]] = self._world.extent()

        if drive == "omni":
            low, high = [bounds[0], bounds[2], bounds[6]], [bounds[1], bounds[3], bounds[7]]
        else:
            low, high = [bounds[0], bounds[6]], [bounds[1], bounds[7]]
        self.action_space = spaces.Box(
            np.array(low, dtype=np.float64), np.array(high, dtype=np.float64), dtype=np.float64
        )

        inf = np.float32(np.inf)
        ranger_spaces = {
            name: spaces.Box(np.float32(0.0), np.float32(rmax), shape=(n,), dtype=np.float32)
            for name, n, rmax in self._rangers
        }
        parts: Dict[str, spaces.Space] = {
            "rangers": spaces.Dict(ranger_spaces),
            "odometry": spaces.Box(-inf, inf, shape=(6,), dtype=np.float32),
            "stall": spaces.Discrete(2),
        }
        if task == "goal":
            parts["goal"] = spaces.Box(-inf, inf, shape=(2,), dtype=np.float32)
        self._dict_space = spaces.Dict(parts)
        self.observation_space = (
            spaces.flatten_space(self._dict_space) if self._flatten else self._dict_space
        )

        self._goal: Optional[Tuple[float, float]] = None
        self._distance = 0.0
        self._steps = 0

    # -- public state -------------------------------------------------------------------

    @property
    def world(self) -> World:
        """The :class:`playerstage.World` of the current episode (a new one at each reset)."""
        return self._world

    @property
    def robot(self) -> str:
        """The robot's model name."""
        return self._robot

    @property
    def drive(self) -> str:
        """The robot's drive: ``"diff"``, ``"omni"`` or ``"car"``."""
        return self._drive

    @property
    def goal(self) -> Optional[Tuple[float, float]]:
        """The goal position ``(x, y)`` (world frame) of the ``"goal"`` task, else None."""
        return self._goal

    # -- Gymnasium API ------------------------------------------------------------------

    def reset(
        self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None
    ) -> Tuple[Any, Dict[str, Any]]:
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = set(options) - _RESET_OPTIONS
        if unknown:
            raise ValueError(
                f"unknown reset option(s) {sorted(unknown)}; known: {sorted(_RESET_OPTIONS)}"
            )
        self._load()
        w, robot = self._native, self._robot

        start = options.get("start")
        if start is not None:
            x, y, a = _pose3(start, "start")
            w.set_pose(robot, x, y, a)
        elif options.get("random_start", self._random_start):
            self._place_free()
        start_pose = w.global_pose(robot)

        self._goal = None
        if self._task == "goal":
            goal = options.get("goal")
            if goal is not None:
                self._goal = _pose2(goal, "goal")
            elif self._goal_default is not None:
                self._goal = self._goal_default
            else:
                self._goal = self._draw_goal(start_pose)

        w.step(1)
        self._steps = 0
        info: Dict[str, Any] = {"start": tuple(start_pose)}
        if self._goal is not None:
            self._distance = self._goal_distance()
            info.update(goal=self._goal, distance=self._distance)
        return self._observe(), info

    def step(self, action: Any) -> Tuple[Any, float, bool, bool, Dict[str, Any]]:
        act = np.asarray(action, dtype=np.float64)
        if act.shape != self.action_space.shape:
            raise ValueError(
                f"action of shape {act.shape}: the action space is {self.action_space}"
            )
        act = np.clip(act, self.action_space.low, self.action_space.high)
        w, robot = self._native, self._robot
        if self._drive == "omni":
            w.set_velocity(robot, float(act[0]), float(act[1]), float(act[2]))
        else:
            w.set_velocity(robot, float(act[0]), 0.0, float(act[1]))
        running = w.step(self._frame_skip)
        self._steps += 1

        reward, terminated, info = self._evaluate()
        truncated = not running or (
            self._max_episode_steps is not None and self._steps >= self._max_episode_steps
        )
        return self._observe(), reward, terminated, bool(truncated), info

    def render(self) -> Optional[np.ndarray]:
        """With ``render_mode="rgb_array"``: the whole world drawn top-down as the world window
        draws it (the worldfile's ``window`` settings; its ``size``, 400x300 by default, is the
        image's), fitted to every model's blocks: an ``(H, W, 3)`` uint8 array. Drawn by the
        viewer's offscreen renderer on any wgpu adapter, Mesa's software Vulkan (lavapipe)
        included, so it works headless; without any adapter it raises ``RuntimeError`` ("no
        graphics adapter ..."). None when the env was made without a ``render_mode``."""
        if self.render_mode is None:
            return None
        width, height, rgb = self._native.render()
        return np.frombuffer(rgb, dtype=np.uint8).reshape(height, width, 3).copy()

    # -- internals ----------------------------------------------------------------------

    def _load(self) -> None:
        """Loads the worldfile afresh: the world exactly as the file and `world_seed` make it."""
        self._world = World(self._path, self._world_seed)
        # the native world under it: its dicts and lists are what observations are built from
        self._native = self._world._w

    def _evaluate(self) -> Tuple[float, bool, Dict[str, Any]]:
        """The task's reward, termination and info after a step."""
        if self._task is None:
            return 0.0, False, {}
        if callable(self._task):
            out = self._task(self._world, self._robot)
            if not (isinstance(out, tuple) and len(out) == 3 and isinstance(out[2], dict)):
                raise TypeError(
                    f"task {self._task!r} returned {out!r}: expected (reward, terminated, info)"
                )
            reward, terminated, info = out
            return float(reward), bool(terminated), info
        stall = bool(self._native.position(self._robot)["stall"])
        distance = self._goal_distance()
        reward = self._distance - distance
        self._distance = distance
        if stall:
            reward -= self._stall_penalty
        reached = distance <= self._goal_tolerance
        if reached:
            reward += self._goal_reward
        terminated = reached or (stall and self._terminate_on_stall)
        return float(reward), terminated, {"distance": distance, "stall": stall, "reached": reached}

    def _goal_distance(self) -> float:
        assert self._goal is not None
        x, y, _ = self._native.global_pose(self._robot)
        return math.hypot(self._goal[0] - x, self._goal[1] - y)

    def _observe(self) -> Any:
        w = self._native
        rangers = {}
        for name, n, rmax in self._rangers:
            ranges = np.asarray(w.ranger(name)["ranges"], dtype=np.float32)
            if ranges.shape != (n,):
                ranges = np.full(n, rmax, dtype=np.float32)
            rangers[name] = np.clip(ranges, np.float32(0.0), np.float32(rmax))
        p = w.position(self._robot)
        if p is None:
            odometry, stall = np.zeros(6, dtype=np.float32), 0
        else:
            keys = ("px", "py", "pa", "vx", "vy", "va")
            odometry = np.array([p[k] for k in keys], dtype=np.float32)
            stall = int(p["stall"])
        obs: Dict[str, Any] = {"rangers": rangers, "odometry": odometry, "stall": stall}
        if self._goal is not None:
            x, y, a = w.global_pose(self._robot)
            dx, dy = self._goal[0] - x, self._goal[1] - y
            c, s = math.cos(a), math.sin(a)
            obs["goal"] = np.array([c * dx + s * dy, -s * dx + c * dy], dtype=np.float32)
        if self._flatten:
            return spaces.flatten(self._dict_space, obs)
        return obs

    def _draw_pose(self) -> Tuple[float, float, float]:
        """A pose drawn uniformly over the world's extent with any heading."""
        if self._extent is None:
            raise RuntimeError(f"{self._path}: no blocks, so no extent to draw poses in")
        x0, y0, x1, y1 = self._extent
        rng = self.np_random
        return (
            float(rng.uniform(x0, x1)),
            float(rng.uniform(y0, y1)),
            float(rng.uniform(-math.pi, math.pi)),
        )

    def _place_free(self, accept: Callable[[float, float], bool] = lambda x, y: True) -> None:
        """Moves the robot to the first drawn pose where it overlaps nothing and `accept`."""
        w, robot = self._native, self._robot
        for _ in range(self._max_draws):
            x, y, a = self._draw_pose()
            if not accept(x, y):
                continue
            w.set_pose(robot, x, y, a)
            if not w.overlaps(robot):
                return
        raise RuntimeError(
            f"{self._path}: no free pose for `{robot}` in {self._max_draws} draws"
        )

    def _draw_goal(self, start: Sequence[float]) -> Tuple[float, float]:
        """A goal position where the robot would fit, away from `start`; the robot stays put."""
        w, robot = self._native, self._robot
        here = w.pose(robot)
        far = 2.0 * self._goal_tolerance
        self._place_free(lambda x, y: math.hypot(x - start[0], y - start[1]) > far)
        gx, gy, _ = w.global_pose(robot)
        w.set_pose(robot, *here)
        return (gx, gy)


def _pose2(value: Sequence[float], what: str) -> Tuple[float, float]:
    """`(x, y)` of a goal given as `(x, y)` or `(x, y, a)`; a clear error otherwise."""
    v = [float(c) for c in value]
    if len(v) not in (2, 3) or not all(math.isfinite(c) for c in v):
        raise ValueError(f"{what} {value!r}: expected finite (x, y) or (x, y, a)")
    return (v[0], v[1])


def _pose3(value: Sequence[float], what: str) -> Tuple[float, float, float]:
    v = [float(c) for c in value]
    if len(v) != 3 or not all(math.isfinite(c) for c in v):
        raise ValueError(f"{what} {value!r}: expected finite (x, y, a)")
    return (v[0], v[1], v[2])
