"""Learning loops on Stage worlds: Gymnasium environments built on :class:`playerstage.World`.

``import playerstage.envs`` registers ``playerstage/Stage-v0`` with Gymnasium (it needs the
``gymnasium`` package; ``import playerstage`` alone does not)::

    import gymnasium
    import playerstage.envs

    env = gymnasium.make("playerstage/Stage-v0", world="worlds/bigbob.world", robot="bob1")
    obs, info = env.reset(seed=1)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

See :class:`StageEnv` for the spaces and the task contract.

``gymnasium.make_vec("playerstage/Stage-v0", num_envs=N, world=..., robot=...)`` makes a
:class:`VectorStageEnv` (the registered ``vector_entry_point``, Gymnasium's default mode when
one is registered; ``vectorization_mode="vector_entry_point"`` says so explicitly), whose
copies step together in Rust threads; ``vectorization_mode="sync"`` or ``"async"`` makes
Gymnasium's own ``SyncVectorEnv`` / ``AsyncVectorEnv`` of ``StageEnv`` copies instead. In every
mode the registered 1000-step limit applies unless ``max_episode_steps`` is given.

``parallel_env(world=PATH, agents=None, ...)`` makes the world's robots the agents of a
PettingZoo ``ParallelEnv`` (:class:`StageParallelEnv`; it needs the ``pettingzoo`` package,
imported on first use, so Gymnasium users need not install it).
"""

from gymnasium.envs.registration import register, registry

from ._stage_env import StageEnv, Task
from ._vector_env import VectorStageEnv

__all__ = ["StageEnv", "Task", "VectorStageEnv", "ENV_ID", "parallel_env", "StageParallelEnv"]


def __getattr__(name):
    # PettingZoo is imported when the parallel env is first asked for, not with this package.
    if name in ("parallel_env", "StageParallelEnv"):
        from . import _parallel_env

        return getattr(_parallel_env, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: The id :class:`StageEnv` is registered under.
ENV_ID = "playerstage/Stage-v0"

# Registration is the one piece of global state; importing twice (or reloading) must not warn.
if ENV_ID not in registry:
    register(
        id=ENV_ID,
        entry_point="playerstage.envs._stage_env:StageEnv",
        vector_entry_point="playerstage.envs._vector_env:VectorStageEnv",
        max_episode_steps=1000,
    )
