"""`StageEnv`: one position model of a Stage worldfile as a Gymnasium environment."""

from __future__ import annotations

import math
import os
import time
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import gymnasium
import numpy as np
from gymnasium import spaces

from .. import World, _native

#: A user task: called after every environment step with the world and the robot's name,
#: returns ``(reward, terminated, info)``.
Task = Callable[[World, str], Tuple[float, bool, Dict[str, Any]]]

_RESET_OPTIONS = frozenset({"random_start", "start", "goal"})

#: The tasks named by a string.
_BUILTIN_TASKS = ("goal", "explore")


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
    - ``"explore"``: see new free space. Each step's reward is the free area (m^2) the
      robot's rangers show for the first time this episode, in a world-frame grid of
      ``explore_cell``-metre cells (default 0.1 m), minus ``stall_penalty`` on a stall (which
      terminates the episode when ``terminate_on_stall``). A reading marks the cells along its
      ray, sampled every half cell from its transducer up to the range read (the whole reach
      when nothing was nearer), as seen; the ray leaves the transducer where it sits on the
      robot (each sonar of a ring from its own ``pose``) at the transducer's heading plus the
      reading's bearing (``World.ranger_rays``). ``explore_rangers`` names the rangers used (default: all of the robot's).
      What the start pose shows is mapped at reset without reward. ``info`` has ``new_area``,
      ``explored`` (total area seen, m^2; also in reset's info) and ``stall``. The grid
      covers the world's extent at load plus the rangers' reach; deterministic like the
      world.
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

    #: ``"rgb_array"``: :meth:`render` draws the world offscreen. ``"human"``: the world
    #: window shows the world after every reset and step, paced to ``render_fps``. Each env's
    #: ``render_fps`` is the simulated rate of its actions, ``1 / (interval_sim *
    #: frame_skip)``.
    metadata: Dict[str, Any] = {"render_modes": ["rgb_array", "human"], "render_fps": None}

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
        explore_cell: float = 0.1,
        explore_rangers: Optional[Sequence[str]] = None,
        render_mode: Optional[str] = None,
    ) -> None:
        _check_render_mode(render_mode, self.metadata["render_modes"], "StageEnv")
        _check_common(
            frame_skip, max_episode_steps, max_draws, task, goal_tolerance, explore_cell
        )
        self.render_mode = render_mode
        self._path = os.fspath(world)
        self._robot = robot
        self._world_seed = int(world_seed)
        self._frame_skip = int(frame_skip)
        self._task = task
        self._goal_default = _pose2(goal, "goal") if goal is not None else None
        self._goal_tolerance = float(goal_tolerance)
        self._random_start = bool(random_start)
        self._max_episode_steps = max_episode_steps
        self._max_draws = int(max_draws)

        self._load()
        self.metadata = {
            **self.metadata,
            "render_fps": 1.0 / (self._world.interval * int(frame_skip)),
        }
        self._agent = _Robot(
            self._world,
            robot,
            task=task,
            flatten=bool(flatten),
            goal_tolerance=self._goal_tolerance,
            goal_reward=float(goal_reward),
            stall_penalty=float(stall_penalty),
            terminate_on_stall=bool(terminate_on_stall),
            explore_cell=float(explore_cell),
            explore_rangers=explore_rangers,
        )
        self._extent: Optional[List[float]] = self._world.extent()
        self.action_space = self._agent.action_space
        self.observation_space = self._agent.observation_space
        self._steps = 0
        self._last_frame = -math.inf  # when the last "human" frame was shown (monotonic s)
        # what _place chose for _begin: the start pose and the goal
        self._placed: Tuple[Sequence[float], Optional[Tuple[float, float]]] = ((0.0,) * 3, None)

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
        return self._agent.drive

    @property
    def goal(self) -> Optional[Tuple[float, float]]:
        """The goal position ``(x, y)`` (world frame) of the ``"goal"`` task, else None."""
        return self._agent.goal

    # -- Gymnasium API ------------------------------------------------------------------

    def reset(
        self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None
    ) -> Tuple[Any, Dict[str, Any]]:
        options = self._reset_options(seed, options)
        self._load()
        self._place(options)
        self._native.step(1)
        out = self._begin()
        if self.render_mode == "human":
            self._show()
        return out

    def _reset_options(
        self, seed: Optional[int], options: Optional[Dict[str, Any]]
    ) -> Dict[str, Any]:
        """A reset's first part: the seed taken, the options checked (returned as a dict)."""
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = set(options) - _RESET_OPTIONS
        if unknown:
            raise ValueError(
                f"unknown reset option(s) {sorted(unknown)}; known: {sorted(_RESET_OPTIONS)}"
            )
        return options

    def _place(self, options: Dict[str, Any]) -> None:
        """A reset's part once the world is loaded afresh: the robot placed, the goal chosen
        (kept for :meth:`_begin`, which runs after the world's first step)."""
        w, robot = self._native, self._robot
        start = options.get("start")
        if start is not None:
            x, y, a = _pose3(start, "start")
            w.set_pose(robot, x, y, a)
        elif options.get("random_start", self._random_start):
            _place_free(w, robot, self.np_random, self._extent, self._max_draws, self._path)
        start_pose = w.global_pose(robot)

        goal: Optional[Tuple[float, float]] = None
        if self._task == "goal":
            if options.get("goal") is not None:
                goal = _pose2(options["goal"], "goal")
            elif self._goal_default is not None:
                goal = self._goal_default
            else:
                goal = _draw_goal(
                    w, robot, self.np_random, self._extent, self._max_draws, self._path,
                    start_pose, self._goal_tolerance,
                )
        self._placed = (start_pose, goal)

    def _begin(self) -> Tuple[Any, Dict[str, Any]]:
        """A reset's last part, after the world's first step: the task begun, the first
        observation and the reset's info."""
        start_pose, goal = self._placed
        self._steps = 0
        info: Dict[str, Any] = {"start": tuple(start_pose)}
        info.update(self._agent.begin(self._world, goal))
        return self._agent.observe(self._native), info

    def step(self, action: Any) -> Tuple[Any, float, bool, bool, Dict[str, Any]]:
        # one native call commands, steps and reads the robot (as VectorStageEnv's copies are)
        running, reading = self._agent.read(
            self._native, self._agent.command(action), self._frame_skip
        )
        out = self._stepped(running, reading)
        if self.render_mode == "human":
            self._show()
        return out

    def render(self) -> Optional[np.ndarray]:
        """With ``render_mode="rgb_array"``: the whole world drawn top-down as the world window
        draws it (the worldfile's ``window`` settings; its ``size``, 400x300 by default, is the
        image's), fitted to every model's blocks: an ``(H, W, 3)`` uint8 array. Drawn by the
        viewer's offscreen renderer on any wgpu adapter, Mesa's software Vulkan (lavapipe)
        included, so it works headless; without any adapter it raises ``RuntimeError`` ("no
        graphics adapter ..."). None when the env was made without a ``render_mode``.

        With ``render_mode="human"``: shows the world in the world window and returns None.
        The env does so itself after every :meth:`reset` and :meth:`step` (Gymnasium's
        convention), waiting as needed so that frames come at most ``render_fps`` a second,
        the world's own pace. The window (the viewer's, egui/wgpu, on its own thread) opens at
        the first frame with the worldfile ``window``'s size and shows the whole world and the
        simulated time; :meth:`close` closes it. One window per process: envs in human mode
        share it. Without a display the constructor raises ``RuntimeError``; a window that
        cannot open raises ``RuntimeError`` naming the cause."""
        return _render(self.render_mode, self._native, self._show)

    def close(self) -> None:
        """Closes the world window in ``"human"`` mode (nothing else holds resources)."""
        if self.render_mode == "human":
            _native.close_window()
        super().close()

    def _show(self) -> None:
        """One ``"human"`` frame: waits until ``1 / render_fps`` has passed since the last one,
        then hands the world to the window."""
        self._last_frame = _show_frame(
            self._native,
            f"{os.path.basename(self._path)}: {self._robot}",
            self.metadata["render_fps"],
            self._last_frame,
        )

    # -- internals ----------------------------------------------------------------------

    def _stepped(
        self, running: bool, reading: Optional["_Reading"] = None
    ) -> Tuple[Any, float, bool, bool, Dict[str, Any]]:
        """The rest of :meth:`step` once the world took its steps (`running`: it has not
        reached ``quit_time``; `reading`: the robot read right after them, when at hand);
        :class:`VectorStageEnv` calls it after stepping every copy."""
        self._steps += 1
        agent = self._agent
        reward, terminated, info = agent.evaluate(self._world, reading)
        truncated = not running or (
            self._max_episode_steps is not None and self._steps >= self._max_episode_steps
        )
        if callable(agent.task):
            reading = None  # a user task may have moved things: read again
        return agent.observe(self._native, reading), reward, terminated, bool(truncated), info

    def _load(self, native: Any = None) -> None:
        """Loads the worldfile afresh: the world exactly as the file and `world_seed` make it
        (`native`: such a load already made, by ``_native.load_worlds``)."""
        if native is None:
            self._world = World(self._path, self._world_seed)
        else:
            # the same World a load makes, around a native world loaded elsewhere
            self._world = World.__new__(World)
            self._world._w = native
        # the native world under it: its dicts and lists are what observations are built from
        self._native = self._world._w


class _Robot:
    """One position model's side of an environment: its action and observation spaces, how an
    action becomes its command, its observation, and its task's state and rewards.

    :class:`StageEnv` has one; :func:`playerstage.envs.parallel_env` one per agent, all on the
    same world. ``world`` is the :class:`playerstage.World` the spaces are read from (any load
    of the file: the spaces do not change between episodes).
    """

    def __init__(
        self,
        world: World,
        robot: str,
        *,
        task: Union[str, Task, None],
        flatten: bool,
        goal_tolerance: float,
        goal_reward: float,
        stall_penalty: float,
        terminate_on_stall: bool,
        explore_cell: float,
        explore_rangers: Optional[Sequence[str]],
    ) -> None:
        native = world._w
        drive, bounds = native.position_config(robot)
        self.robot = robot
        self.drive: str = drive
        self.task = task
        self.flatten = flatten
        self.goal_tolerance = goal_tolerance
        self.goal_reward = goal_reward
        self.stall_penalty = stall_penalty
        self.terminate_on_stall = terminate_on_stall
        self.rangers: List[Tuple[str, int, float]] = native.rangers(robot)

        if drive == "omni":
            low, high = [bounds[0], bounds[2], bounds[6]], [bounds[1], bounds[3], bounds[7]]
        else:
            low, high = [bounds[0], bounds[6]], [bounds[1], bounds[7]]
        self.action_space = spaces.Box(
            np.array(low, dtype=np.float64), np.array(high, dtype=np.float64), dtype=np.float64
        )
        # the box's bounds as floats: clipping a short action is cheaper in plain Python
        self._bounds = (self.action_space.low.tolist(), self.action_space.high.tolist())

        inf = np.float32(np.inf)
        ranger_spaces = {
            name: spaces.Box(np.float32(0.0), np.float32(rmax), shape=(n,), dtype=np.float32)
            for name, n, rmax in self.rangers
        }
        parts: Dict[str, spaces.Space] = {
            "rangers": spaces.Dict(ranger_spaces),
            "odometry": spaces.Box(-inf, inf, shape=(6,), dtype=np.float32),
            "stall": spaces.Discrete(2),
        }
        if task == "goal":
            parts["goal"] = spaces.Box(-inf, inf, shape=(2,), dtype=np.float32)
        self.dict_space = spaces.Dict(parts)
        self.observation_space = (
            spaces.flatten_space(self.dict_space) if flatten else self.dict_space
        )

        self.goal: Optional[Tuple[float, float]] = None
        self.distance = 0.0
        self.explored: Optional[_ExploreMap] = None
        self._explore_rangers: List[Tuple[str, float]] = []
        self._explore_cell = explore_cell
        self._extent = world.extent()
        if task == "explore":
            reach = {name: rmax for name, _, rmax in self.rangers}
            names = list(reach) if explore_rangers is None else list(explore_rangers)
            unknown = [n for n in names if n not in reach]
            if unknown:
                raise ValueError(
                    f"explore_rangers {unknown}: not rangers of `{robot}` (those are "
                    f"{sorted(reach)})"
                )
            if not names:
                raise ValueError(f"task 'explore': `{robot}` has no ranger to see with")
            if self._extent is None:
                raise ValueError("task 'explore': the world has no blocks, so no area to map")
            self._explore_rangers = [(n, reach[n]) for n in names]

    def command(self, action: Any) -> List[float]:
        """The velocity command ``[vx, vy, va]`` of `action` (checked against the space,
        clipped to it)."""
        act = np.asarray(action, dtype=np.float64)
        if act.shape != self.action_space.shape:
            raise ValueError(
                f"action of shape {act.shape} for `{self.robot}`: the action space is "
                f"{self.action_space}"
            )
        v = [_clip(x, lo, hi) for x, lo, hi in zip(act.tolist(), *self._bounds)]
        return v if self.drive == "omni" else [v[0], 0.0, v[1]]

    def act(self, native: Any, action: Any) -> None:
        """Commands the robot's speeds from `action` (see :meth:`command`)."""
        native.set_velocity(self.robot, *self.command(action))

    def read(
        self, native: Any, velocity: Optional[List[float]] = None, steps: int = 0
    ) -> Tuple[bool, "_Reading"]:
        """Commands `velocity` (if given), steps the world `steps` times and reads the robot,
        in one native call (``step_observe``, as :class:`VectorStageEnv` does for all its
        copies): whether the world still runs, and the reading."""
        goal = None if self.goal is None else [list(self.goal)]
        running, scans, state = _native.step_observe(
            [native],
            self.robot,
            None if velocity is None else [velocity],
            steps,
            self.rangers,
            goal,
        )
        rangers, state = _readings(self.rangers, scans, state, 1, goal is not None)
        return running[0], _Reading({k: v[0] for k, v in rangers.items()}, state[0])

    def begin(self, world: World, goal: Optional[Tuple[float, float]]) -> Dict[str, Any]:
        """Starts an episode's task once the robot is placed and the world took its first
        step; returns what the task adds to reset's info."""
        native = world._w
        self.goal = goal if self.task == "goal" else None
        info: Dict[str, Any] = {}
        if self.goal is not None:
            self.distance = self.read(native)[1].distance
            info.update(goal=self.goal, distance=self.distance)
        if self.task == "explore":
            assert self._extent is not None
            # the map lives natively beside the world; it maps the start's view (no reward)
            self.explored = _ExploreMap(
                native, self.robot, self._explore_rangers, self._extent, self._explore_cell
            )
            info["explored"] = self.explored.area
        return info

    def evaluate(
        self, world: World, reading: Optional["_Reading"] = None
    ) -> Tuple[float, bool, Dict[str, Any]]:
        """The task's reward, termination and info after a step (`reading`: the robot read
        after it, else read here when the task needs it)."""
        if self.task is None:
            return 0.0, False, {}
        if callable(self.task):
            out = self.task(world, self.robot)
            if not (isinstance(out, tuple) and len(out) == 3 and isinstance(out[2], dict)):
                raise TypeError(
                    f"task {self.task!r} returned {out!r}: expected (reward, terminated, info)"
                )
            reward, terminated, info = out
            return float(reward), bool(terminated), info
        native = world._w
        if reading is None:
            reading = self.read(native)[1]
        stall = bool(reading.stall)
        if self.task == "explore":
            assert self.explored is not None
            new = self.explored.see()
            reward = new - (self.stall_penalty if stall else 0.0)
            terminated = stall and self.terminate_on_stall
            info = {"new_area": new, "explored": self.explored.area, "stall": stall}
            return float(reward), terminated, info
        distance = reading.distance
        # the formula's one definition, native: VectorStageEnv's copies compute it there too
        reward, reached, terminated = _native.goal_reward(
            self.distance, distance, stall, self.goal_tolerance, self.goal_reward,
            self.stall_penalty, self.terminate_on_stall,
        )
        self.distance = distance
        return reward, terminated, {"distance": distance, "stall": stall, "reached": reached}

    def observe(self, native: Any, reading: Optional["_Reading"] = None) -> Any:
        """The robot's observation now (`reading`: the robot read now, else read here), in
        :attr:`observation_space`."""
        if reading is None:
            reading = self.read(native)[1]
        state = reading.state
        obs: Dict[str, Any] = {
            "rangers": reading.rangers,
            "odometry": state[:6].astype(np.float32),
            "stall": int(state[6]),
        }
        if self.goal is not None:
            obs["goal"] = state[11:13].astype(np.float32)
        if self.flatten:
            return spaces.flatten(self.dict_space, obs)
        return obs


def _check_render_mode(render_mode: Optional[str], modes: Sequence[str], who: str) -> None:
    """A constructor's check of its `render_mode` (StageEnv and parallel_env share it):
    one of `modes` or None, and ``"human"`` only with a display, so that a headless run fails
    when the env is made, not at its first frame."""
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode {render_mode!r}: {who} renders {list(modes)}")
    if render_mode == "human" and not _native.display_available():
        raise RuntimeError(
            "render_mode='human' needs a display for the world window, and neither "
            "DISPLAY nor WAYLAND_DISPLAY is set; use render_mode='rgb_array' to draw "
            "without one (or run under Xvfb with DISPLAY set)"
        )


def _rgb_frame(native: Any) -> np.ndarray:
    """The whole world drawn offscreen (``World.render``) as an ``(H, W, 3)`` uint8 array the
    caller owns."""
    width, height, rgb = native.render()
    return np.frombuffer(rgb, dtype=np.uint8).reshape(height, width, 3).copy()


def _render(
    render_mode: Optional[str], native: Any, show: Callable[[], None]
) -> Optional[np.ndarray]:
    """``render()`` of StageEnv and parallel_env: nothing without a mode, a window frame by
    `show` in ``"human"`` mode, the world drawn offscreen in ``"rgb_array"``."""
    if render_mode is None:
        return None
    if render_mode == "human":
        show()
        return None
    return _rgb_frame(native)


def _show_frame(native: Any, title: str, fps: float, last: float) -> float:
    """One ``"human"`` frame of `native` in the world window, shown no sooner than ``1 / fps``
    after the last one (shown at `last`, monotonic seconds): the world's own pace. Returns
    when this one was shown."""
    wait = last + 1.0 / fps - time.monotonic()
    if wait > 0:
        time.sleep(wait)
    native.show_window(title)
    return time.monotonic()


def _clip(x: float, lo: float, hi: float) -> float:
    """`x` clipped to `[lo, hi]`: a NaN stays NaN, and a value not strictly inside a bound
    becomes the bound (so ``-0.0`` against a bound of ``0.0`` gives ``0.0``). VectorStageEnv's
    native step clips by the same rule (``VectorCore.commands``), so that a lone env and a
    vector's copy command the same speeds to the bit (``numpy.clip``'s own treatment of signed
    zeros depends on the arrays' memory layout)."""
    x = x if (x != x or x > lo) else lo
    return x if (x != x or x < hi) else hi


class _Reading:
    """One robot read by ``step_observe``: its ranger readings (float32, clipped to each
    ranger's bounds, by name) and its state row (float64: ``px py pa vx vy va stall x y a``,
    then with a goal ``distance ahead left``)."""

    __slots__ = ("rangers", "state")

    def __init__(self, rangers: Dict[str, np.ndarray], state: np.ndarray) -> None:
        self.rangers = rangers
        self.state = state

    @property
    def stall(self) -> bool:
        return bool(self.state[6])

    @property
    def distance(self) -> float:
        """The goal task's distance to the goal (m), computed natively."""
        return float(self.state[10])


def _readings(
    rangers: Sequence[Tuple[str, int, float]], scans: Sequence[bytes], state: bytes, m: int,
    goal: bool,
) -> Tuple[Dict[str, np.ndarray], np.ndarray]:
    """``step_observe``'s answer for `m` worlds as arrays with a leading axis of `m`: each
    ranger's readings (float32, clipped to ``[0, range_max]`` natively: the observation's;
    writable, over a fresh bytearray), and the float64 state rows (13 columns with goals, else
    10)."""
    out = {
        name: np.frombuffer(raw, dtype=np.float32).reshape(m, n)
        for (name, n, _), raw in zip(rangers, scans)
    }
    return out, np.frombuffer(state, dtype=np.float64).reshape(m, 13 if goal else 10)


class _ExploreMap:
    """The ``"explore"`` task's map: a world-frame grid of square cells, each seen free or not,
    kept natively beside the episode's world (``World.explore_begin``), so that a lone
    StageEnv and VectorStageEnv's copies (scored on the simulator's threads) compute it by
    the same code.

    A ranger reading marks as seen the cells of the points sampled every half cell along its
    ray, from its transducer up to (not including) the range read, or up to the ranger's
    reach when it read nothing nearer. The ray leaves the transducer's own world position (its
    ``pose`` on the ranger: each sonar of a ring its own) at the transducer's heading plus the
    reading's bearing, as ``World.ranger_rays`` gives them. The grid covers the world's extent at
    load plus the rangers' reach and a cell; what lies outside is not counted. Pure arithmetic
    on the readings: as deterministic as the world. Making the map marks the current view.
    """

    def __init__(
        self,
        native: Any,
        robot: str,
        rangers: Sequence[Tuple[str, float]],
        extent: Sequence[float],
        cell: float,
    ) -> None:
        self._native = native
        self._robot = robot  # the world keeps one map per robot (parallel_env's agents)
        native.explore_begin(robot, list(rangers), list(extent), cell)

    @property
    def area(self) -> float:
        """The area seen free so far (m^2)."""
        return self._native.explored(self._robot)

    def see(self) -> float:
        """Marks what the rangers' current readings show free; returns the new area (m^2)."""
        return self._native.explore_see(self._robot)


def _draw_pose(rng: np.random.Generator, extent: Optional[Sequence[float]], path: str):
    """A pose drawn uniformly over the world's extent with any heading."""
    if extent is None:
        raise RuntimeError(f"{path}: no blocks, so no extent to draw poses in")
    x0, y0, x1, y1 = extent
    return (
        float(rng.uniform(x0, x1)),
        float(rng.uniform(y0, y1)),
        float(rng.uniform(-math.pi, math.pi)),
    )


def _place_free(
    native: Any,
    robot: str,
    rng: np.random.Generator,
    extent: Optional[Sequence[float]],
    max_draws: int,
    path: str,
    accept: Callable[[float, float], bool] = lambda x, y: True,
) -> None:
    """Moves the robot to the first drawn pose where it overlaps nothing and `accept`."""
    for _ in range(max_draws):
        x, y, a = _draw_pose(rng, extent, path)
        if not accept(x, y):
            continue
        native.set_pose(robot, x, y, a)
        if not native.overlaps(robot):
            return
    raise RuntimeError(f"{path}: no free pose for `{robot}` in {max_draws} draws")


def _draw_goal(
    native: Any,
    robot: str,
    rng: np.random.Generator,
    extent: Optional[Sequence[float]],
    max_draws: int,
    path: str,
    start: Sequence[float],
    tolerance: float,
) -> Tuple[float, float]:
    """A goal position where the robot would fit, more than ``2 * tolerance`` from `start`;
    the robot stays put."""
    here = native.pose(robot)
    far = 2.0 * tolerance
    _place_free(
        native, robot, rng, extent, max_draws, path,
        lambda x, y: math.hypot(x - start[0], y - start[1]) > far,
    )
    gx, gy, _ = native.global_pose(robot)
    native.set_pose(robot, *here)
    return (gx, gy)


def _check_common(
    frame_skip: Any,
    max_episode_steps: Any,
    max_draws: Any,
    task: Any,
    goal_tolerance: Any,
    explore_cell: Any,
) -> None:
    """The argument checks StageEnv and parallel_env share: clear errors, before any load."""
    if int(frame_skip) != frame_skip or frame_skip < 1:
        raise ValueError(f"frame_skip {frame_skip!r}: not a whole number >= 1")
    if max_episode_steps is not None and (
        int(max_episode_steps) != max_episode_steps or max_episode_steps < 1
    ):
        raise ValueError(f"max_episode_steps {max_episode_steps!r}: not a whole number >= 1")
    if int(max_draws) != max_draws or max_draws < 1:
        raise ValueError(f"max_draws {max_draws!r}: not a whole number >= 1")
    if isinstance(task, str):
        if task not in _BUILTIN_TASKS:
            raise ValueError(
                f"task {task!r}: the built-in tasks are 'goal' and 'explore' (or None)"
            )
    elif task is not None and not callable(task):
        raise TypeError(f"task {task!r}: not 'goal', 'explore', None or a callable")
    if not (goal_tolerance > 0 and math.isfinite(goal_tolerance)):
        raise ValueError(f"goal_tolerance {goal_tolerance!r}: not a positive length")
    if not (explore_cell > 0 and math.isfinite(explore_cell)):
        raise ValueError(f"explore_cell {explore_cell!r}: not a positive length")


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
