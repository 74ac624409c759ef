"""`VectorStageEnv`: N copies of a :class:`StageEnv` stepped side by side in Rust threads."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array, iterate

from .. import _native
from ._stage_env import StageEnv


class VectorStageEnv(VectorEnv):
    """``num_envs`` copies of ``StageEnv(world, robot, **kwargs)`` as one
    :class:`gymnasium.vector.VectorEnv`.

    Each copy is a full :class:`StageEnv` (same spaces, task, rewards, resets and seeds), so
    copy ``i`` gives exactly what a lone ``StageEnv`` fed the same actions and seeds gives, and
    exactly what :class:`gymnasium.vector.SyncVectorEnv` of those envs gives. What differs is
    the simulation: one call steps every copy's world ``frame_skip`` times on the simulator's
    thread pool with the GIL released (:func:`playerstage._native.step_worlds`), so copies use
    all cores while Python only sets commands and reads observations.

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
        self._obs: List[Any] = [None] * self.num_envs
        self._rewards = np.zeros(self.num_envs, dtype=np.float64)
        self._terminations = np.zeros(self.num_envs, dtype=np.bool_)
        self._truncations = np.zeros(self.num_envs, dtype=np.bool_)
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)

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
        infos: Dict[str, Any] = {}
        for i in np.flatnonzero(mask):
            self._obs[i], info = self.envs[i].reset(seed=seeds[i], options=options or None)
            infos = self._add_info(infos, info, int(i))
        self._terminations[mask] = False
        self._truncations[mask] = False
        self._autoreset[mask] = False
        return self._batch(), infos

    def step(self, actions: Any) -> Tuple[Any, np.ndarray, np.ndarray, np.ndarray, Dict[str, Any]]:
        infos: Dict[str, Any] = {}
        stepped: List[int] = []
        for i, action in enumerate(iterate(self.action_space, actions)):
            env = self.envs[i]
            if self._autoreset[i]:
                self._obs[i], info = env.reset()
                self._rewards[i] = 0.0
                self._terminations[i] = False
                self._truncations[i] = False
                infos = self._add_info(infos, info, i)
            else:
                env._agent.act(env._native, action)
                stepped.append(i)
        # the one call that simulates: every stepped copy's world at once, GIL released
        running = _native.step_worlds([self.envs[i]._native for i in stepped], self._frame_skip)
        for i, still in zip(stepped, running):
            env = self.envs[i]
            # what StageEnv.step does after its world's steps
            env._steps += 1
            reward, terminated, info = env._agent.evaluate(env._world)
            limit = env._max_episode_steps
            self._rewards[i] = reward
            self._terminations[i] = terminated
            self._truncations[i] = (not still) or (limit is not None and env._steps >= limit)
            self._obs[i] = env._agent.observe(env._native)
            infos = self._add_info(infos, info, i)
        self._autoreset = self._terminations | self._truncations
        return (
            self._batch(),
            self._rewards.copy(),
            self._terminations.copy(),
            self._truncations.copy(),
            infos,
        )

    def render(self) -> Optional[Tuple[Any, ...]]:
        """Each copy's :meth:`StageEnv.render`, in order (None without a ``render_mode``)."""
        if self.render_mode is None:
            return None
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()

    def _batch(self) -> Any:
        """The copies' latest observations in a fresh batched array (never reused)."""
        out = create_empty_array(self.single_observation_space, n=self.num_envs, fn=np.zeros)
        return concatenate(self.single_observation_space, self._obs, out)
