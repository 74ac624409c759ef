"""`VectorStageEnv`: N copies of a :class:`StageEnv` stepped side by side in Rust threads."""

from __future__ import annotations

from copy import deepcopy
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, create_empty_array, iterate

from .. import _native
from ._stage_env import StageEnv


class VectorStageEnv(VectorEnv):
    """``num_envs`` copies of ``StageEnv(world, robot, **kwargs)`` as one
    :class:`gymnasium.vector.VectorEnv`.

    Each copy is a full :class:`StageEnv` (same spaces, task, rewards, resets and seeds), so
    copy ``i`` gives exactly what a lone ``StageEnv`` fed the same actions and seeds gives, and
    exactly what :class:`gymnasium.vector.SyncVectorEnv` of those envs gives. What differs is
    the simulation: one call steps every copy's world ``frame_skip`` times on the simulator's
    thread pool with the GIL released, so copies use all cores. For the built-in tasks
    (``"goal"``, ``"explore"``, or ``task=None``) on ``Dict`` observations, the whole step is
    native (:class:`playerstage._native.VectorCore`, which keeps every copy's world, goal,
    distance, step count and autoreset flag): it takes the action batch as one float64
    buffer, clips and commands each copy's action, and on the pool steps, reads and scores
    each copy (by the native code a lone StageEnv scores with: the goal reward, the explore
    map) and writes its rows of one block, of which the batched observation, rewards, flags
    and infos are numpy views (a fresh block every step: arrays handed out are never
    overwritten). So the serial share of a vector step, what Python and the argument handling
    cost, stays small next to the simulation. User tasks (callables) and ``flatten=True`` run
    each copy's own StageEnv code around :func:`playerstage._native.step_worlds`. Resets,
    explicit or automatic, reload all the copies concerned side by side on the pool
    (:func:`playerstage._native.load_worlds`) and take their first steps together; placing the
    robots and drawing goals stays in Python, once per episode.
    ``gymnasium.make_vec("playerstage/Stage-v0", num_envs=N, ...)`` makes one (the registered
    ``vector_entry_point``).

    **Spaces** — ``single_observation_space`` / ``single_action_space`` are the StageEnv's;
    ``observation_space`` / ``action_space`` are what :func:`gymnasium.vector.utils.batch_space`
    makes of them (a ``Dict`` observation becomes a ``Dict`` of arrays with a leading axis of
    ``num_envs``).

    **Autoreset** — ``AutoresetMode.NEXT_STEP``, Gymnasium's default
    (``metadata["autoreset_mode"]``): after a step in which copy ``i`` terminated or was
    truncated, the next ``step`` resets copy ``i`` (no seed: its generator goes on) instead of
    stepping it, ignores its action, and returns the first observation of its new episode with
    reward 0 and ``terminated = truncated = False``.

    **Seeds** — ``reset(seed=s)`` seeds copy ``i`` with ``s + i`` (a list seeds each copy),
    as Gymnasium's vector envs do; ``options`` go to every copy, and ``options["reset_mask"]``
    (a bool array) resets only the copies it marks.

    **Infos** — each key of a copy's info becomes an array over the copies plus a
    ``"_key"`` mask of the copies that set it (Gymnasium's vector info layout).
    """

    metadata: Dict[str, Any] = {
        "autoreset_mode": AutoresetMode.NEXT_STEP,
        "render_modes": StageEnv.metadata["render_modes"],
    }

    def __init__(
        self,
        num_envs: int,
        world: Any,
        robot: str,
        **kwargs: Any,
    ) -> None:
        if int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs {num_envs!r}: not a whole number >= 1")
        self.num_envs = int(num_envs)
        self.envs: List[StageEnv] = [StageEnv(world, robot, **kwargs) for _ in range(self.num_envs)]
        first = self.envs[0]
        self.render_mode = first.render_mode
        self.metadata = {**self.metadata, "render_fps": first.metadata.get("render_fps")}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._frame_skip = first._frame_skip
        agent = first._agent
        # The built-in tasks (or none) on Dict observations run on a native VectorCore: one
        # call commands, steps, reads and scores every copy; user tasks and flat observations
        # go through each copy's own StageEnv code after step_worlds.
        self._bulk = (agent.task is None or isinstance(agent.task, str)) and not agent.flatten
        if self._bulk:
            goal = agent.task == "goal"
            self._core = _native.VectorCore(
                self.num_envs,
                agent.robot,
                agent.rangers,
                agent.drive == "omni",
                self.single_action_space.low.tolist(),
                self.single_action_space.high.tolist(),
                self._frame_skip,
                first._max_episode_steps,
                (
                    agent.goal_tolerance,
                    agent.goal_reward,
                    agent.stall_penalty,
                    agent.terminate_on_stall,
                )
                if goal
                else None,
                (agent.stall_penalty, agent.terminate_on_stall)
                if agent.task == "explore"
                else None,
            )
            # each task's infos: (info key, block section, type)
            self._info_keys = {
                "goal": [
                    ("distance", "distance", float),
                    ("stall", "stall_flag", bool),
                    ("reached", "reached", bool),
                ],
                "explore": [
                    ("new_area", "new_area", float),
                    ("explored", "explored", float),
                    ("stall", "stall_flag", bool),
                ],
            }.get(agent.task, [])
            # numpy views over the block each step returns: (key, dtype, shape, offset)
            self._sections = [
                (key, np.dtype(dtype), tuple(shape), offset)
                for key, dtype, shape, offset in self._core.layout()[1]
            ]
            spaces = self.single_observation_space.spaces
            # the batched observation's keys in the space's order (create_empty_array's)
            self._obs_keys = [
                (k, list(spaces[k].spaces) if k == "rangers" else None) for k in spaces
            ]
        # the last batched observation: a partial reset (reset_mask) keeps the other rows
        self._last: Any = self._empty()
        self._rewards = np.zeros(self.num_envs, dtype=np.float64)
        self._terminations = np.zeros(self.num_envs, dtype=np.bool_)
        self._truncations = np.zeros(self.num_envs, dtype=np.bool_)
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)
        # each copy's current world (the bulk step's are also held by the VectorCore)
        self._natives: List[Any] = [env._native for env in self.envs]

    def reset(
        self,
        *,
        seed: Union[int, Sequence[Optional[int]], None] = None,
        options: Optional[Dict[str, Any]] = None,
    ) -> Tuple[Any, Dict[str, Any]]:
        if seed is None:
            seeds: List[Optional[int]] = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(
                    f"{len(seeds)} seeds for {self.num_envs} envs: give one per env, an int or None"
                )
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if mask is None:
            mask = np.ones(self.num_envs, dtype=np.bool_)
        else:
            mask = np.asarray(mask)
            if mask.shape != (self.num_envs,) or mask.dtype != np.bool_ or not mask.any():
                raise ValueError(
                    f"options['reset_mask'] {mask!r}: expected a bool array of shape "
                    f"({self.num_envs},) with at least one True"
                )
        out = deepcopy(self._last)
        infos = self._reset_rows(np.flatnonzero(mask).tolist(), seeds, options or None, out, {})
        self._terminations[mask] = False
        self._truncations[mask] = False
        self._autoreset[mask] = False
        self._last = out
        if self.render_mode == "human":
            self.envs[0]._show()
        return out, infos

    def step(self, actions: Any) -> Tuple[Any, np.ndarray, np.ndarray, np.ndarray, Dict[str, Any]]:
        result = self._step_bulk(actions) if self._bulk else self._step_each(actions)
        if self.render_mode == "human":
            self.envs[0]._show()
        return result

    def _step_each(
        self, actions: Any
    ) -> Tuple[Any, np.ndarray, np.ndarray, np.ndarray, Dict[str, Any]]:
        """`step` through each copy's own StageEnv code (other tasks, flat observations)."""
        out = self._empty()
        infos = self._autoreset_rows(out)
        stepped: List[int] = []
        for i, action in enumerate(iterate(self.action_space, actions)):
            env = self.envs[i]
            if not self._autoreset[i]:
                env._agent.act(env._native, action)
                stepped.append(i)
        # the one call that simulates: every stepped copy's world at once, GIL released
        running = _native.step_worlds([self.envs[i]._native for i in stepped], self._frame_skip)
        for i, still in zip(stepped, running):
            obs, reward, terminated, truncated, info = self.envs[i]._stepped(still)
            self._rewards[i] = reward
            self._terminations[i] = terminated
            self._truncations[i] = truncated
            _put(out, i, obs)
            infos = self._add_info(infos, info, i)
        self._autoreset = self._terminations | self._truncations
        return self._result(out, infos)

    def _step_bulk(
        self, actions: Any
    ) -> Tuple[Any, np.ndarray, np.ndarray, np.ndarray, Dict[str, Any]]:
        """`step` for the built-in tasks (or none) on Dict observations: one native call
        (``VectorCore.step``) clips and commands every copy's action, steps the worlds on the
        simulator's pool, reads them, computes rewards, terminations, truncations and infos
        and keeps the copies' episode state (goal, distance, steps, autoreset), all as a lone
        StageEnv computes them (the goal task's reward by the same native function); it hands
        back one block, of which the batched observation and the rest are numpy views. Only
        the copies it skipped (autoreset) come back through Python, to be reset."""
        acts = np.asarray(actions, dtype=np.float64)
        if acts.shape != self.action_space.shape:
            raise ValueError(
                f"actions of shape {acts.shape}: the action space is {self.action_space}"
            )
        block, skipped = self._core.step(acts.tobytes())
        v = {
            key: np.ndarray(shape, dtype, buffer=block, offset=offset)
            for key, dtype, shape, offset in self._sections
        }
        out = {
            k: {r: v["rangers/" + r] for r in names} if names is not None else v[k]
            for k, names in self._obs_keys
        }
        infos: Dict[str, Any] = {}
        if not skipped:
            n = self.num_envs
            for key, section, _ in self._info_keys:
                infos[key] = v[section]
                infos["_" + key] = np.ones(n, dtype=np.bool_)
        else:
            # NEXT_STEP autoreset of the skipped copies: their first observations go into
            # their rows of the block (left zero, with reward 0 and no flags, natively)
            infos = self._reset_rows(skipped, [None] * self.num_envs, None, out, {})
            stepped = np.ones(self.num_envs, dtype=np.bool_)
            stepped[skipped] = False
            rows = np.flatnonzero(stepped)
            m = len(rows)
            if m:
                # what _add_info makes of each stepped copy's info
                for key, section, dtype in self._info_keys:
                    _add_rows(infos, key, v[section][rows], rows, m, dtype, self.num_envs)
        self._last = out
        return out, v["reward"], v["terminated"], v["truncated"], infos

    def _began(self, i: int) -> None:
        """Hands copy `i`'s new episode to the VectorCore after its reset (its world, goal,
        distance to the goal and step count; the copies' own StageEnv objects are not updated
        by bulk steps: their next reset starts afresh anyway)."""
        env = self.envs[i]
        self._natives[i] = env._native
        if self._bulk:
            agent = env._agent
            self._core.begin(i, env._native, agent.goal, agent.distance, env._steps)

    def _autoreset_rows(self, out: Any) -> Dict[str, Any]:
        """NEXT_STEP autoreset of the copies whose episode ended last step (no seed: their
        generators go on): their new episodes' first observations written into `out`, reward
        0 and no termination; returns their infos."""
        rows = np.flatnonzero(self._autoreset).tolist()
        if not rows:
            return {}
        infos = self._reset_rows(rows, [None] * self.num_envs, None, out, {})
        self._rewards[rows] = 0.0
        self._terminations[rows] = False
        self._truncations[rows] = False
        return infos

    def _reset_rows(
        self,
        rows: List[int],
        seeds: Sequence[Optional[int]],
        options: Optional[Dict[str, Any]],
        out: Any,
        infos: Dict[str, Any],
    ) -> Dict[str, Any]:
        """``StageEnv.reset(seed=seeds[i], options=options)`` of each copy `i` of `rows`, with
        what costs most done for all of them at once on the simulator's threads: their worlds
        loaded side by side (``load_worlds``), then each robot placed and goal drawn (from the
        copy's own generator, so the order does not matter), then every world's first step
        side by side (``step_worlds``). Observations go into `out`, infos into `infos`."""
        envs = [self.envs[i] for i in rows]
        chosen = [env._reset_options(seeds[i], options) for i, env in zip(rows, envs)]
        first = self.envs[0]
        natives = _native.load_worlds(first._path, first._world_seed, len(rows))
        for env, native, opts in zip(envs, natives, chosen):
            env._load(native)
            env._place(opts)
        _native.step_worlds(natives, 1)
        for i, env in zip(rows, envs):
            obs, info = env._begin()
            self._began(i)
            _put(out, i, obs)
            infos = self._add_info(infos, info, i)
        return infos

    def _result(self, obs: Any, infos: Dict[str, Any]):
        self._last = obs
        return (
            obs,
            self._rewards.copy(),
            self._terminations.copy(),
            self._truncations.copy(),
            infos,
        )

    def render(self) -> Optional[Tuple[Any, ...]]:
        """Each copy's :meth:`StageEnv.render`, in order (None without a ``render_mode``).
        ``"human"``: the world window shows copy 0 (after every reset and step too, as a lone
        StageEnv does) and this returns None."""
        if self.render_mode is None:
            return None
        if self.render_mode == "human":
            self.envs[0]._show()
            return None
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()

    def _empty(self) -> Any:
        """A fresh batched observation of zeros (arrays handed out are never reused)."""
        return create_empty_array(self.single_observation_space, n=self.num_envs, fn=np.zeros)


def _put(batch: Any, i: int, obs: Any) -> None:
    """Writes one copy's observation into row `i` of a batched Dict observation."""
    if isinstance(batch, dict):
        for k, v in obs.items():
            _put(batch[k], i, v)
    else:
        batch[i] = obs


def _add_rows(
    infos: Dict[str, Any], key: str, values: np.ndarray, rows: Any, m: int, kind: type, n: int
) -> None:
    """`VectorEnv._add_info` of the same `key` for the `m` copies `rows` (indices or a slice)
    at once: `values[j]` is the `j`-th's, of Python type `kind` (the array's dtype when the key
    is new)."""
    array, mask = infos.get(key), infos.get(f"_{key}")
    if array is None and m == n:  # all copies: no other row to leave zero
        array = np.asarray(values, dtype=kind)
        mask = np.ones(n, dtype=np.bool_)
    else:
        if array is None:
            array = np.zeros(n, dtype=kind)
        array[rows] = values
        if mask is None:
            mask = np.zeros(n, dtype=np.bool_)
        mask[rows] = True
    infos[key], infos[f"_{key}"] = array, mask
