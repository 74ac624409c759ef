"""`parallel_env`: the position models of a Stage worldfile as the agents of a PettingZoo
``ParallelEnv``, all in one world stepped once per ``step()``."""

from __future__ import annotations

import math
import os
import warnings
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from .. import World, _native
from ._stage_env import (
    _RESET_OPTIONS,
    Task,
    _check_common,
    _check_render_mode,
    _draw_goal,
    _place_free,
    _pose2,
    _pose3,
    _render,
    _Robot,
    _show_frame,
)


def parallel_env(
    world: Union[str, "os.PathLike[str]"],
    agents: Optional[Sequence[str]] = None,
    **kwargs: Any,
) -> "StageParallelEnv":
    """The position models of the worldfile ``world`` as a PettingZoo ``ParallelEnv``.

    ``agents`` names the robots that act (default: every position model no other position
    model carries, in the file's order); the other models, robots included, are part of the
    world. Agents should be top-level models: their poses are set in their parent's frame.
    Keyword arguments are :class:`StageParallelEnv`'s.
    """
    return StageParallelEnv(world, agents, **kwargs)


class StageParallelEnv(ParallelEnv):
    """Several position models of one worldfile acting at once, in one simulated world.

    Each agent (named by its model) has :class:`~playerstage.envs.StageEnv`'s action and
    observation spaces, built by the same code, and its own copy of the task: ``"goal"``
    (each agent its own goal), ``"explore"`` (each its own map), ``None`` or a callable
    ``task(world, robot)``, with the same arguments (``goal_tolerance``, ``goal_reward``,
    ``stall_penalty``, ``terminate_on_stall``, ``explore_cell``, ``explore_rangers`` — the last
    only when every agent has those rangers, so usually left None). ``observation_space(agent)``
    and ``action_space(agent)`` return the same object at every call.

    ``step(actions)`` commands every agent in ``actions`` (a live agent left out is stopped;
    an agent not live is an error), steps the world ``frame_skip`` times, then evaluates each
    live agent's task. An agent whose task terminated it (goal reached; a stall with
    ``terminate_on_stall``) or that was truncated (``max_episode_steps`` actions, or the
    world's ``quit_time``) gets its last observation, reward and flags in that step's dicts and
    is then removed from ``agents``: PettingZoo's convention. Its robot is stopped and stays in
    the world as an obstacle.

    ``reset(seed=..., options=...)`` loads the worldfile afresh with ``world_seed`` (everything
    as loaded, bit for bit, as :class:`StageEnv` does), then places the agents in order:
    ``options["start"][agent]`` (``(x, y, a)``) when given, else a pose drawn in free space when
    ``options["random_start"]`` (default: the constructor's ``random_start``), else where the
    file puts it; then each agent's goal is ``options["goal"][agent]``, else ``goals[agent]``
    from the constructor, else drawn; then the world takes one step at rest. Draws come from
    the env's generator, seeded by ``reset(seed=...)``: the same seed, options and actions give
    the same episode and world digest. Unknown option keys are ignored with a warning
    (PettingZoo's API test passes one).

    **Rendering** — as :class:`StageEnv` renders, the whole world (every agent and the rest):
    ``render_mode="rgb_array"``: :meth:`render` returns the world drawn top-down by the
    viewer's offscreen renderer (headless, software rendering included), an ``(H, W, 3)``
    uint8 array of the worldfile ``window``'s ``size``. ``render_mode="human"``: the world
    window shows the world after every :meth:`reset` and :meth:`step`, paced to
    ``metadata["render_fps"]`` (``1 / (interval_sim * frame_skip)``, the simulated rate of the
    steps); :meth:`render` shows a frame and returns None; :meth:`close` closes the window.
    Without a display, ``"human"`` is refused when the env is made.
    """

    metadata: Dict[str, Any] = {
        "name": "playerstage_stage_parallel_v0",
        "render_modes": ["rgb_array", "human"],
        "render_fps": None,
    }

    def __init__(
        self,
        world: Union[str, "os.PathLike[str]"],
        agents: Optional[Sequence[str]] = None,
        *,
        world_seed: int = 0,
        frame_skip: int = 1,
        task: Union[str, Task, None] = "goal",
        goals: Optional[Mapping[str, Sequence[float]]] = None,
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
        _check_render_mode(render_mode, self.metadata["render_modes"], "parallel_env")
        _check_common(frame_skip, max_episode_steps, max_draws, task, goal_tolerance, explore_cell)
        self.render_mode = render_mode
        self._path = os.fspath(world)
        self._world_seed = int(world_seed)
        self._frame_skip = int(frame_skip)
        self._task = task
        self._goal_tolerance = float(goal_tolerance)
        self._random_start = bool(random_start)
        self._max_episode_steps = max_episode_steps
        self._max_draws = int(max_draws)
        self._load()
        self.metadata = {
            **self.metadata,
            "render_fps": 1.0 / (self._world.interval * self._frame_skip),
        }
        self._last_frame = -math.inf  # when the last "human" frame was shown (monotonic s)

        positions = self._world.models("position")
        if agents is None:
            names = _top_level(self._world, positions)
            if not names:
                raise ValueError(f"{self._path}: no position model to be an agent")
        else:
            names = list(agents)
            if not names:
                raise ValueError("agents: an empty list (None means every top-level robot)")
            if len(set(names)) != len(names):
                raise ValueError(f"agents {names}: a robot named twice")
            # each name must be a position model (the World's error says what it is else)
            for name in names:
                self._world.position_config(name)
            children = set(names) - set(_top_level(self._world, names))
            if children:
                raise ValueError(
                    f"agents {sorted(children)}: inside another agent's model (poses are set "
                    f"in the parent's frame, so agents must not carry each other)"
                )
        self._goals_default: Dict[str, Tuple[float, float]] = {}
        for name, goal in dict(goals or {}).items():
            if name not in names:
                raise ValueError(f"goals: `{name}` is not an agent ({names})")
            self._goals_default[name] = _pose2(goal, f"goals[{name!r}]")

        self.possible_agents: List[str] = names
        self.agents: List[str] = list(names)
        self._robots: Dict[str, _Robot] = {
            name: _Robot(
                self._world,
                name,
                task=task,
                flatten=bool(flatten),
                goal_tolerance=self._goal_tolerance,
                goal_reward=float(goal_reward),
                stall_penalty=float(stall_penalty),
                terminate_on_stall=bool(terminate_on_stall),
                explore_cell=float(explore_cell),
                explore_rangers=explore_rangers,
            )
            for name in names
        }
        self.observation_spaces: Dict[str, spaces.Space] = {
            n: r.observation_space for n, r in self._robots.items()
        }
        self.action_spaces: Dict[str, spaces.Space] = {
            n: r.action_space for n, r in self._robots.items()
        }
        self._extent = self._world.extent()
        self._np_random: Optional[np.random.Generator] = None
        self._steps = 0

    # -- public state -------------------------------------------------------------------

    @property
    def world(self) -> World:
        """The :class:`playerstage.World` of the current episode (a new one at each reset)."""
        return self._world

    @property
    def np_random(self) -> np.random.Generator:
        """The generator start and goal poses are drawn from (seeded by ``reset(seed=...)``)."""
        if self._np_random is None:
            self._np_random, _ = seeding.np_random()
        return self._np_random

    def goal(self, agent: str) -> Optional[Tuple[float, float]]:
        """The agent's goal position ``(x, y)`` (world frame) in the ``"goal"`` task."""
        return self._robots[agent].goal

    def observation_space(self, agent: str) -> spaces.Space:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        return self.action_spaces[agent]

    # -- PettingZoo API -----------------------------------------------------------------

    def reset(
        self, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None
    ) -> Tuple[Dict[str, Any], Dict[str, Dict[str, Any]]]:
        if seed is not None:
            self._np_random, _ = seeding.np_random(seed)
        options = dict(options or {})
        unknown = set(options) - _RESET_OPTIONS
        if unknown:
            warnings.warn(
                f"parallel_env.reset: unknown option(s) {sorted(unknown)} ignored; known: "
                f"{sorted(_RESET_OPTIONS)}",
                stacklevel=2,
            )
        starts = self._per_agent(options.get("start"), "start")
        goals = self._per_agent(options.get("goal"), "goal")
        self._load()
        w, rng = self._native, self.np_random

        for name in self.possible_agents:
            if name in starts:
                w.set_pose(name, *_pose3(starts[name], f"start[{name!r}]"))
            elif options.get("random_start", self._random_start):
                _place_free(w, name, rng, self._extent, self._max_draws, self._path)
        chosen: Dict[str, Optional[Tuple[float, float]]] = {}
        for name in self.possible_agents:
            chosen[name] = None
            if self._task != "goal":
                continue
            if name in goals:
                chosen[name] = _pose2(goals[name], f"goal[{name!r}]")
            elif name in self._goals_default:
                chosen[name] = self._goals_default[name]
            else:
                chosen[name] = _draw_goal(
                    w, name, rng, self._extent, self._max_draws, self._path,
                    w.global_pose(name), self._goal_tolerance,
                )
        starts_now = {name: tuple(w.global_pose(name)) for name in self.possible_agents}

        w.step(1)
        self._steps = 0
        self.agents = list(self.possible_agents)
        infos: Dict[str, Dict[str, Any]] = {}
        for name in self.agents:
            info: Dict[str, Any] = {"start": starts_now[name]}
            info.update(self._robots[name].begin(self._world, chosen[name]))
            infos[name] = info
        obs = {name: self._robots[name].observe(w) for name in self.agents}
        if self.render_mode == "human":
            self._show()
        return obs, infos

    def step(self, actions: Mapping[str, Any]) -> Tuple[
        Dict[str, Any],
        Dict[str, float],
        Dict[str, bool],
        Dict[str, bool],
        Dict[str, Dict[str, Any]],
    ]:
        w = self._native
        live = list(self.agents)
        dead = [a for a in actions if a not in live]
        if dead:
            raise ValueError(f"actions for {sorted(dead)}: not live agents (live: {live})")
        for name in live:
            if name in actions:
                self._robots[name].act(w, actions[name])
            else:
                w.set_velocity(name, 0.0, 0.0, 0.0)
        running = w.step(self._frame_skip)
        self._steps += 1
        out_of_time = not running or (
            self._max_episode_steps is not None and self._steps >= self._max_episode_steps
        )

        rewards: Dict[str, float] = {}
        terminations: Dict[str, bool] = {}
        truncations: Dict[str, bool] = {}
        infos: Dict[str, Dict[str, Any]] = {}
        for name in live:
            rewards[name], terminations[name], infos[name] = self._robots[name].evaluate(
                self._world
            )
            truncations[name] = bool(out_of_time)
        obs = {name: self._robots[name].observe(w) for name in live}
        self.agents = [n for n in live if not (terminations[n] or truncations[n])]
        for name in live:
            if name not in self.agents:
                w.set_velocity(name, 0.0, 0.0, 0.0)  # out of the episode: it stops
        if self.render_mode == "human":
            self._show()
        return obs, rewards, terminations, truncations, infos

    def render(self) -> Optional[np.ndarray]:
        """``"rgb_array"``: the whole world drawn offscreen, an ``(H, W, 3)`` uint8 array (see
        :meth:`StageEnv.render`; raises ``RuntimeError`` "no graphics adapter ..." when wgpu
        finds none). ``"human"``: a frame in the world window (paced to ``render_fps``), None.
        None without a ``render_mode``."""
        return _render(self.render_mode, self._native, self._show)

    def close(self) -> None:
        """Closes the world window in ``"human"`` mode (nothing else holds resources)."""
        if self.render_mode == "human":
            _native.close_window()

    def _show(self) -> None:
        """One ``"human"`` frame of the current world, at most ``render_fps`` a second."""
        self._last_frame = _show_frame(
            self._native,
            f"{os.path.basename(self._path)}: {len(self.agents)} agents",
            self.metadata["render_fps"],
            self._last_frame,
        )

    # -- internals ----------------------------------------------------------------------

    def _load(self) -> None:
        """Loads the worldfile afresh: the world exactly as the file and `world_seed` make it."""
        self._world = World(self._path, self._world_seed)
        self._native = self._world._w

    def _per_agent(self, value: Any, what: str) -> Dict[str, Any]:
        """A reset option given per agent, ``{agent: pose}``, checked."""
        if value is None:
            return {}
        if not isinstance(value, Mapping):
            raise ValueError(f"reset option {what!r}: expected {{agent: pose}}, got {value!r}")
        unknown = [a for a in value if a not in self.possible_agents]
        if unknown:
            raise ValueError(f"reset option {what!r}: {unknown} not agents")
        return dict(value)


def _top_level(world: World, names: Sequence[str]) -> List[str]:
    """The models of `names` that no other model of `names` carries: moving a model moves its
    descendants, so a model whose global pose follows another's is inside it."""
    w = world._w
    inside = set()
    for carrier in names:
        before = {n: w.global_pose(n) for n in names}
        x, y, a = w.pose(carrier)
        w.set_pose(carrier, x + 1000.0, y, a)
        for n in names:
            if n != carrier and w.global_pose(n) != before[n]:
                inside.add(n)
        w.set_pose(carrier, x, y, a)
    return [n for n in names if n not in inside]
