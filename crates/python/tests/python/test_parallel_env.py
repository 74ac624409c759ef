"""`playerstage.envs.parallel_env`: PettingZoo's API and seed tests on Bigbob and on a written
world of four robots, agents dropping out on a stall, per-agent goals and spaces, and resets
that undo moves, stalls and a carried puck."""

import math
import warnings

import numpy as np
import pytest

from pettingzoo.test import parallel_api_test, parallel_seed_test

from playerstage import Pose2d, World, WorldError
from playerstage.envs import StageEnv, StageParallelEnv, parallel_env

from conftest import BIGBOB


# Four diff-drive robots with 90-ray lasers in a walled 8 x 8 m room with two boxes; r3 faces
# the east wall 0.5 m away, r2 carries a (position) turret, which is not an agent.
ROBOTS_WORLD = """
resolution 0.02
interval_sim 100
define box model ( size [0.5 0.5 0.5] )
define wall model ( color "gray" )
define bot position
(
  size [0.4 0.4 0.3]
  drive "diff"
  velocity_bounds [-0.5 0.8 0 0 0 0 -90 90]
  ranger ( sensor ( range [0 3] fov 180 samples 90 ) size [0.1 0.1 0.1] pose [0.1 0 0 0] )
)
bot ( name "r0" pose [-2 -2 0 0] )
bot ( name "r1" pose [-2 2 0 0] )
bot
(
  name "r2" pose [1 2 0 180]
  position ( name "turret" size [0.1 0.1 0.1] pose [0 0 0.3 0] )
)
bot ( name "r3" pose [3.25 -2 0 0] )
box ( name "b1" pose [0 0 0 0] )
box ( name "b2" pose [2 -1 0 0] )
wall ( name "north" pose [0 4 0 0] size [8 0.1 0.5] )
wall ( name "south" pose [0 -4 0 0] size [8 0.1 0.5] )
wall ( name "east" pose [4 0 0 0] size [0.1 8 0.5] )
wall ( name "west" pose [-4 0 0 0] size [0.1 8 0.5] )
"""


@pytest.fixture
def robots_world(tmp_path):
    path = tmp_path / "robots.world"
    path.write_text(ROBOTS_WORLD)
    return path


def api_test(env, num_cycles):
    with warnings.catch_warnings():
        # Any PettingZoo warning (a live agent without a reward, a revived agent...) fails;
        # the API test's own reset option is ignored with our warning.
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message="parallel_env.reset: unknown option")
        parallel_api_test(env, num_cycles=num_cycles)


def test_agents_are_the_top_level_robots(robots_world):
    env = parallel_env(robots_world)
    assert isinstance(env, StageParallelEnv)
    assert env.possible_agents == ["r0", "r1", "r2", "r3"]  # not r2's turret
    assert parallel_env(BIGBOB).possible_agents == ["bob1", "bob2"]
    sub = parallel_env(robots_world, agents=["r3", "r1"])
    assert sub.possible_agents == ["r3", "r1"]
    with pytest.raises(ValueError, match="inside another agent"):
        parallel_env(robots_world, agents=["r2", "turret"])
    with pytest.raises(WorldError, match="not a position model"):
        parallel_env(robots_world, agents=["b1"])
    with pytest.raises(ValueError, match="named twice"):
        parallel_env(robots_world, agents=["r0", "r0"])
    with pytest.raises(ValueError, match="built-in tasks"):
        parallel_env(robots_world, task="wander")


def test_spaces_are_stage_envs(robots_world):
    env = parallel_env(robots_world, flatten=True)
    single = StageEnv(robots_world, "r1", flatten=True)
    for agent in env.possible_agents:
        assert env.observation_space(agent) is env.observation_space(agent)
        assert env.action_space(agent) is env.action_space(agent)
        assert env.observation_space(agent) == single.observation_space
        assert env.action_space(agent) == single.action_space
    obs, _ = env.reset(seed=0)
    assert all(env.observation_space(a).contains(o) for a, o in obs.items())


@pytest.mark.parametrize("task", ["goal", "explore"])
def test_pettingzoo_api_bigbob(task):
    api_test(parallel_env(BIGBOB, task=task, max_episode_steps=60), num_cycles=80)


@pytest.mark.parametrize("kwargs", [
    {"random_start": True, "max_episode_steps": 50},
    {"task": "explore", "terminate_on_stall": True, "max_episode_steps": 50},
    {"flatten": True, "agents": ["r0", "r3"], "frame_skip": 2},
])
def test_pettingzoo_api_robots_world(robots_world, kwargs):
    api_test(parallel_env(robots_world, **kwargs), num_cycles=60)


@pytest.mark.parametrize("path", ["bigbob", "robots"])
def test_pettingzoo_seed_test(robots_world, path):
    world = BIGBOB if path == "bigbob" else robots_world
    parallel_seed_test(lambda: parallel_env(world, random_start=True), num_cycles=40)


def run(env, seed, steps, rng_seed=5):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(rng_seed)
    trace = [env.world.digest()]
    for _ in range(steps):
        if not env.agents:
            break
        actions = {
            a: rng.uniform(env.action_space(a).low, env.action_space(a).high)
            for a in env.agents
        }
        obs, rewards, terms, truncs, infos = env.step(actions)
        trace.append((env.world.digest(), sorted(rewards.items()), list(env.agents)))
    return trace


def test_same_seed_same_episode(robots_world):
    a = parallel_env(robots_world, random_start=True)
    b = parallel_env(robots_world, random_start=True)
    ta, tb = run(a, 9, 40), run(b, 9, 40)
    assert ta == tb and len(ta) == 41
    assert run(a, 10, 1)[0] != ta[0]  # another seed, other start poses
    # the goals differ per agent, drawn where the robot fits
    a.reset(seed=9)
    goals = [a.goal(r) for r in a.possible_agents]
    assert len(set(goals)) == 4


def test_agents_drop_out_on_stall(robots_world):
    env = parallel_env(robots_world, terminate_on_stall=True, goals={"r3": (-3.0, 3.0)})
    obs, infos = env.reset(seed=0)
    assert env.agents == ["r0", "r1", "r2", "r3"]
    stop = np.zeros(2)
    ended = None
    for step in range(30):
        # r3 drives into the east wall; the others stay put
        actions = {a: (np.array([0.5, 0.0]) if a == "r3" else stop) for a in env.agents}
        obs, rewards, terms, truncs, infos = env.step(actions)
        assert set(obs) == set(rewards) == set(terms) == set(infos) == set(actions)
        if "r3" not in env.agents:
            ended = step
            break
        assert not terms["r3"]
    assert ended is not None, "r3 never stalled"
    assert terms["r3"] and not truncs["r3"] and infos["r3"]["stall"]
    assert obs["r3"]["stall"] == 1 and rewards["r3"] < -0.5
    assert env.agents == ["r0", "r1", "r2"]
    # it stays out: no observation next step, and acting for it is an error
    obs, rewards, terms, truncs, infos = env.step({a: stop for a in env.agents})
    assert set(obs) == {"r0", "r1", "r2"}
    with pytest.raises(ValueError, match=r"not live agents"):
        env.step({"r3": stop})
    # a reset brings everyone back
    env.reset(seed=0)
    assert env.agents == env.possible_agents


def test_truncation_removes_everyone(robots_world):
    env = parallel_env(robots_world, task=None, max_episode_steps=3)
    env.reset(seed=0)
    for _ in range(3):
        _, rewards, terms, truncs, _ = env.step({a: np.zeros(2) for a in env.agents})
    assert all(truncs.values()) and not any(terms.values()) and env.agents == []
    assert rewards == dict.fromkeys(env.possible_agents, 0.0)


def test_goal_reached_per_agent(robots_world):
    env = parallel_env(robots_world, goals={"r0": (-1.5, -2.0)}, goal_reward=3.0)
    _, infos = env.reset(seed=0, options={"goal": {"r1": (-1.5, 2.0)}})
    assert env.goal("r0") == (-1.5, -2.0) and env.goal("r1") == (-1.5, 2.0)
    assert math.isclose(infos["r0"]["distance"], 0.5)
    done = {}
    for _ in range(20):
        actions = {a: np.array([0.5, 0.0]) if a in ("r0", "r1") else np.zeros(2)
                   for a in env.agents}
        _, rewards, terms, _, infos = env.step(actions)
        done.update({a: rewards[a] for a in terms if terms[a]})
        if len(done) == 2:
            break
    assert set(done) == {"r0", "r1"} and all(r > 3.0 for r in done.values())
    assert env.agents == ["r2", "r3"]
    with pytest.raises(ValueError, match="not agents"):
        env.reset(options={"start": {"b1": (0, 0, 0)}})


def test_reset_restores_moves_stalls_and_a_carried_puck():
    env = parallel_env(BIGBOB, task=None)
    env.reset(seed=4)
    w = env.world
    # bob2 grips orange3, put between its paddles, and drives off with it
    w.set_pose("orange3", 5.0, -4.1, 0.0)
    w.gripper_cmd("bob2.gripper:0", "close")
    for _ in range(30):
        env.step({"bob1": np.zeros(2), "bob2": np.zeros(2)})
    assert w.gripper("bob2.gripper:0")["paddles"] == "closed"
    # bob1 meets carton1 put right in front of it
    w.set_pose("carton1", -3.9, -4.2, 0.0)
    stalled = False
    for _ in range(20):
        obs, *_ = env.step({"bob1": np.array([0.5, 0.0]), "bob2": np.array([0.3, 0.4])})
        stalled = stalled or obs["bob1"]["stall"] == 1
    assert stalled
    carried = w.global_pose("orange3")
    assert math.hypot(carried.x - 5.0, carried.y + 4.1) > 0.5  # it went with bob2
    assert w.pose("orange3") != w.global_pose("orange3")  # held in the gripper's frame
    moved = w.digest()

    obs, infos = env.reset(seed=4)
    fresh = parallel_env(BIGBOB, task=None)
    obs_f, infos_f = fresh.reset(seed=4)
    assert env.world.digest() == fresh.world.digest() != moved
    assert infos == infos_f
    for a in env.possible_agents:
        assert all(np.array_equal(x, y) for x, y in zip(
            [obs[a]["odometry"], obs[a]["stall"]], [obs_f[a]["odometry"], obs_f[a]["stall"]]
        ))
    loaded = World(BIGBOB, 0)
    loaded.step(1)
    assert env.world.digest() == loaded.digest()
    assert env.world.pose("orange3") == loaded.pose("orange3") == Pose2d(5.0, -1.0, 0.0)
    assert env.world.gripper("bob2.gripper:0")["paddles"] == "open"

    # the same through StageEnv on bob2
    single = StageEnv(BIGBOB, "bob2", task=None)
    single.reset(seed=4)
    single.world.set_pose("orange3", 5.0, -4.1, 0.0)
    single.world.gripper_cmd("bob2.gripper:0", "close")
    for _ in range(40):
        single.step(np.array([0.3, 0.4]))
    assert single.world.pose("orange3") != single.world.global_pose("orange3")
    single.reset(seed=4)
    assert single.world.digest() == loaded.digest()


def test_pettingzoo_is_imported_on_first_use():
    import subprocess
    import sys

    code = (
        "import sys, playerstage.envs as e; assert 'pettingzoo' not in sys.modules; "
        "e.parallel_env; assert 'pettingzoo' in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
