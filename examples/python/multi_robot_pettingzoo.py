#!/usr/bin/env python3
"""Several robots of one Stage world as PettingZoo agents, driven by a scripted policy.

``playerstage.envs.parallel_env`` makes every top-level position model of the world an agent
of a PettingZoo ``ParallelEnv``, all in one simulated world stepped once per ``step()``. Here
four diff-drive robots with 32-ray lasers, in a walled 8 x 8 m room with boxes (a world this
script writes, unless ``--world`` names another whose robots have one ranger each), each get a
goal drawn in free space, and each runs the same scripted policy: turn towards the goal, go
forward as far as the laser's front sector allows, and veer away from whatever is close.
An agent leaves the episode when it reaches its goal, or when it stalls (``terminate_on_stall``);
the episode ends when no agent is left or after ``--steps`` actions.

Prints who finished how and each agent's return. Needs numpy, gymnasium and pettingzoo:

    python3 examples/python/multi_robot_pettingzoo.py --seed 3
"""

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

from playerstage.envs import parallel_env

WORLD = """
resolution 0.02
interval_sim 100
define box model ( size [0.6 0.6 0.5] )
define wall model ( color "gray" )
define bot position
(
  size [0.4 0.4 0.3]
  drive "diff"
  velocity_bounds [-0.3 0.6 0 0 0 0 -90 90]
  ranger ( sensor ( range [0 3] fov 180 samples 32 ) size [0.05 0.05 0.05] pose [0.15 0 0 0] )
)
bot ( name "r0" pose [-3 -3 0 45] )
bot ( name "r1" pose [3 -3 0 135] )
bot ( name "r2" pose [3 3 0 -135] )
bot ( name "r3" pose [-3 3 0 -45] )
box ( name "b1" pose [0 0 0 0] )
box ( name "b2" pose [1.8 -0.6 0 30] )
box ( name "b3" pose [-1.5 1.6 0 0] )
wall ( name "north" pose [0 4 0 0] size [8 0.1 0.5] )
wall ( name "south" pose [0 -4 0 0] size [8 0.1 0.5] )
wall ( name "east" pose [4 0 0 0] size [0.1 8 0.5] )
wall ( name "west" pose [-4 0 0 0] size [0.1 8 0.5] )
"""


def scripted(obs, low, high):
    """(forward, turn) towards the goal, slowed and turned away by what the laser sees ahead."""
    gx, gy = float(obs["goal"][0]), float(obs["goal"][1])
    (ranges,) = obs["rangers"].values()
    n = len(ranges)
    # the laser's rays run right (-90 degrees) to left (+90)
    bearings = np.linspace(-math.pi / 2, math.pi / 2, n)
    front = np.abs(bearings) < math.radians(55)
    clearance = float(ranges[front].min())
    bearing = math.atan2(gy, gx)
    turn = 1.5 * bearing
    if clearance < 0.8:
        # veer to the side with more room
        left, right = ranges[bearings > 0].mean(), ranges[bearings < 0].mean()
        turn += 1.2 if left >= right else -1.2
    forward = min(0.6, 0.8 * math.hypot(gx, gy), 0.8 * (clearance - 0.25))
    if abs(bearing) > math.radians(60):
        forward = 0.0  # turn on the spot first
    return np.clip([forward, turn], low, high)


def run(world, steps, seed):
    env = parallel_env(world, max_episode_steps=steps, terminate_on_stall=True, goal_reward=5.0)
    obs, infos = env.reset(seed=seed, options={"random_start": True})
    returns = dict.fromkeys(env.possible_agents, 0.0)
    outcome = {}
    for t in range(steps):
        actions = {
            a: scripted(obs[a], env.action_space(a).low, env.action_space(a).high)
            for a in env.agents
        }
        obs, rewards, terms, truncs, infos = env.step(actions)
        for a, r in rewards.items():
            returns[a] += r
            if terms[a]:
                how = "reached its goal" if infos[a]["reached"] else "stalled"
                outcome[a] = f"{how} after {t + 1} steps"
            elif truncs[a]:
                outcome[a] = f"out of time, {infos[a]['distance']:.2f} m from its goal"
        if not env.agents:
            break
    return returns, outcome


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--world", type=Path, help="a worldfile (default: the script's room)")
    ap.add_argument("--steps", type=int, default=300, help="actions per episode at most")
    ap.add_argument("--seed", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        world = args.world
        if world is None:
            world = Path(tmp) / "robots.world"
            world.write_text(WORLD)
        returns, outcome = run(world, args.steps, args.seed)
    for agent, ret in returns.items():
        print(f"{agent}: {outcome.get(agent, 'still going')}, return {ret:.2f}")
    reached = sum("reached" in o for o in outcome.values())
    print(f"{reached} of {len(returns)} robots reached their goals")
    return 0


if __name__ == "__main__":
    sys.exit(main())
