#!/usr/bin/env python3
"""Goal reaching on a Stage world, learnt by cross-entropy search over a linear policy.

The world (written by this script into a temporary directory): a 6 x 6 m walled room with
two boxes and one diff-drive robot carrying a 16-ray laser. The environment is
``playerstage.envs.StageEnv`` with the built-in ``"goal"`` task: every episode starts the
robot and its goal at poses drawn in free space from the episode's seed; the reward is the
progress towards the goal, +1 on arrival, -1 for a stall, which ends the episode.

The policy is linear in four features of the observation's ``goal`` (the goal in the robot's
frame: its bearing's cosine and sine, its distance capped at 2 m, and a constant): ``action =
clip(W @ features)`` with ``W`` 2 x 4 (8 numbers). The cross-entropy method keeps a Gaussian
over ``W``: each iteration draws ``--population`` candidates, scores each by its mean return
over the same ``--episodes`` episodes (seeds fixed per iteration), and refits the Gaussian to
the ``--elite`` best. Everything is seeded (numpy's generator, the episodes' seeds, the world's
seed), so a run is the same every time.

It prints each iteration's mean return over the population (the "mean return" that rises),
and the rise from the first iteration to the last. With the defaults (8 iterations of 24
candidates x 4 episodes of at most 60 actions, 768 episodes) it rises by more than 1.5, from
-1.38 to 1.94 (a random linear policy mostly drives into a wall), in about 2 s; CI runs 6
iterations of 16 candidates (-1.31 to 0.45, about 1 s) and asserts the same margin. Needs
numpy and gymnasium only:

    python3 examples/python/train_goal_cem.py
"""

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from playerstage.envs import StageEnv

WORLD = """
resolution 0.02
interval_sim 100
define box model ( size [0.6 0.6 0.5] )
define wall model ( color "gray" )
position
(
  name "r0"
  pose [0 0 0 0]
  size [0.35 0.35 0.3]
  drive "diff"
  velocity_bounds [-0.3 0.8 0 0 0 0 -120 120]
  ranger ( sensor ( range [0 3] fov 180 samples 16 ) size [0.05 0.05 0.05] pose [0.1 0 0 0] )
)
box ( name "b1" pose [1.5 1.2 0 0] )
box ( name "b2" pose [-1.2 -1.5 0 0] )
wall ( name "north" pose [0 3 0 0] size [6 0.1 0.5] )
wall ( name "south" pose [0 -3 0 0] size [6 0.1 0.5] )
wall ( name "east" pose [3 0 0 0] size [0.1 6 0.5] )
wall ( name "west" pose [-3 0 0 0] size [0.1 6 0.5] )
"""

N_FEATURES = 4


def features(obs):
    """The policy's inputs from a StageEnv observation: the goal's bearing (cos, sin), its
    distance capped at 2 m and halved, and 1."""
    gx, gy = float(obs["goal"][0]), float(obs["goal"][1])
    d = math.hypot(gx, gy)
    if d < 1e-9:
        return np.array([1.0, 0.0, 0.0, 1.0])
    return np.array([gx / d, gy / d, min(d, 2.0) / 2.0, 1.0])


def episode_return(env, weights, seed):
    """One episode's return with the linear policy `weights` (2 x N_FEATURES)."""
    obs, _ = env.reset(seed=seed)
    low, high = env.action_space.low, env.action_space.high
    total = 0.0
    while True:
        action = np.clip(weights @ features(obs), low, high)
        obs, reward, terminated, truncated, _ = env.step(action)
        total += reward
        if terminated or truncated:
            return total


def train(world, iterations, population, elite, episodes, steps, seed, log=print):
    """Runs the cross-entropy search; returns each iteration's mean return over the population."""
    env = StageEnv(
        world, "r0", random_start=True, frame_skip=2, max_episode_steps=steps,
        terminate_on_stall=True,
    )
    rng = np.random.default_rng(seed)
    mean = np.zeros((2, N_FEATURES))
    std = np.ones((2, N_FEATURES))
    history = []
    for it in range(iterations):
        seeds = [seed * 1000 + it * episodes + k for k in range(episodes)]
        candidates = mean + std * rng.standard_normal((population, 2, N_FEATURES))
        scores = np.array(
            [np.mean([episode_return(env, w, s) for s in seeds]) for w in candidates]
        )
        best = candidates[np.argsort(scores)[-elite:]]
        mean = best.mean(axis=0)
        std = best.std(axis=0) + 0.05  # a floor keeps it searching
        history.append(float(scores.mean()))
        log(f"iteration {it}: mean return {scores.mean():.3f}, best {scores.max():.3f}")
    return history, mean


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--iterations", type=int, default=8)
    ap.add_argument("--population", type=int, default=24)
    ap.add_argument("--elite", type=int, default=4)
    ap.add_argument("--episodes", type=int, default=4, help="episodes per candidate")
    ap.add_argument("--steps", type=int, default=60, help="actions per episode at most")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    if not (args.iterations >= 2 and 1 <= args.elite <= args.population):
        ap.error("need --iterations >= 2 and 1 <= --elite <= --population")

    with tempfile.TemporaryDirectory() as tmp:
        world = Path(tmp) / "goal_room.world"
        world.write_text(WORLD)
        start = time.perf_counter()
        history, mean = train(
            world, args.iterations, args.population, args.elite, args.episodes, args.steps,
            args.seed,
        )
        elapsed = time.perf_counter() - start
    steps = args.iterations * args.population * args.episodes
    print(f"policy W = {np.round(mean, 2).tolist()}")
    print(
        f"mean return: first {history[0]:.3f}, last {history[-1]:.3f}, "
        f"rise {history[-1] - history[0]:.3f} ({steps} episodes in {elapsed:.1f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
