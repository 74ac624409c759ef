"""`playerstage.envs.StageEnv`: Gymnasium's checker, spaces from the worldfile, exact resets and
replays, drawn poses in free space, and the goal task's rewards and terminations."""

import math
import subprocess
import sys
import warnings

import numpy as np
import pytest

import gymnasium
from gymnasium.utils.env_checker import check_env

import playerstage.envs  # noqa: F401 (registers playerstage/Stage-v0)
from playerstage import World, WorldError, _native
from playerstage.envs import StageEnv

from conftest import BIGBOB, BOXES, STAGE_WORLDS, boxes_world, leaves


def same_obs(a, b):
    la, lb = leaves(a), leaves(b)
    return len(la) == len(lb) and all(
        x.dtype == y.dtype and np.array_equal(x, y) for x, y in zip(la, lb)
    )


def quiet_check(env):
    with warnings.catch_warnings():
        # Gymnasium's advice (normalised action boxes, finite observation bounds) is not an
        # API error; Stage's units and unbounded odometry are the point here.
        warnings.simplefilter("ignore", UserWarning)
        check_env(env)


def test_import_playerstage_does_not_need_gymnasium():
    code = "import sys, playerstage; assert 'gymnasium' not in sys.modules, 'imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_registered_and_made():
    env = gymnasium.make("playerstage/Stage-v0", world=str(BIGBOB), robot="bob1")
    assert isinstance(env.unwrapped, StageEnv)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    env.close()


def test_check_env_bigbob():
    quiet_check(StageEnv(BIGBOB, "bob1"))
    quiet_check(StageEnv(BIGBOB, "bob2", task=None, random_start=True))


def test_check_env_small_world(small_world):
    quiet_check(StageEnv(small_world, "r0", random_start=True))
    quiet_check(StageEnv(small_world, "r0", flatten=True, frame_skip=2))


def test_check_env_stage_simple_world():
    path = STAGE_WORLDS / "simple.world"
    if not path.is_file():
        pytest.skip(f"{path} absent (Stage's worlds are not on this machine)")
    quiet_check(StageEnv(path, "r0", random_start=True))


def test_spaces_from_the_worldfile(small_world, tmp_path):
    env = StageEnv(small_world, "r0")
    drive, bounds = env.world.position_config("r0")
    assert drive == "diff" and env.drive == "diff"
    assert env.action_space.shape == (2,)
    assert list(env.action_space.low) == [bounds[0], bounds[6]]
    assert list(env.action_space.high) == [bounds[1], bounds[7]]
    # the file's numbers, angles in degrees
    assert (bounds[0], bounds[1]) == (-0.5, 0.8)
    assert math.isclose(bounds[7], math.radians(60)) and math.isclose(bounds[6], -bounds[7])
    laser = env.observation_space["rangers"]["r0.ranger:0"]
    assert laser.shape == (180,) and laser.high.max() == np.float32(4.0)
    assert env.observation_space["stall"].n == 2

    omni = boxes_world(tmp_path, "omni")
    env = StageEnv(omni, "r0")
    _, bounds = env.world.position_config("r0")
    assert env.action_space.shape == (3,)
    assert list(env.action_space.low) == [bounds[0], bounds[2], bounds[6]]
    assert list(env.action_space.high) == [bounds[1], bounds[3], bounds[7]]
    obs, _ = env.reset(seed=0)
    for _ in range(10):
        obs, *_ = env.step(np.array([0.0, 0.3, 0.0]))
    assert obs["odometry"][1] > 0.2  # it moved sideways


def test_bigbob_rangers_and_bounds():
    env = StageEnv(BIGBOB, "bob1", task=None)
    rangers = env.observation_space["rangers"]
    assert set(rangers) == {"bob1.ranger:0", "bob1.ranger:1"}
    assert rangers["bob1.ranger:0"].shape == (4,)  # four sonars, one reading each
    assert rangers["bob1.ranger:1"].shape == (180,)
    _, bounds = env.world.position_config("bob1")
    assert list(env.action_space.high) == [bounds[1], bounds[7]]
    assert "goal" not in env.observation_space.spaces


def test_observed_ranges_are_the_rangers_readings_as_float32_clipped():
    """The observation's ranges (converted natively) are the ranger's readings rounded to
    float32 and clipped to [0, range_max] exactly as numpy does it; writable arrays."""
    env = StageEnv(BIGBOB, "bob1", task=None)
    obs, _ = env.reset(options={"start": (-4.6, -3.9, 0.5)})
    rng = np.random.default_rng(2)
    for t in range(15):
        for name, n, rmax in env.world.rangers("bob1"):
            raw = np.asarray(env.world.ranger(name).ranges, dtype=np.float32)
            want = np.clip(raw, np.float32(0.0), np.float32(rmax))
            got = obs["rangers"][name]
            assert got.dtype == np.float32 and got.shape == (n,)
            assert np.array_equal(got, want), f"step {t} {name}"
            assert got.flags.writeable
        obs, *_ = env.step(rng.uniform(env.action_space.low, env.action_space.high))


def run_episode(env, seed, actions, options=None):
    obs, info = env.reset(seed=seed, options=options)
    seq, digests = [obs], [env.world.digest()]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        seq.append(obs)
        digests.append((env.world.digest(), reward, terminated, truncated))
        if terminated or truncated:
            break
    return seq, digests


@pytest.mark.parametrize("world_robot", [("bigbob", "bob1"), ("small", "r0")])
def test_same_seed_same_episode(world_robot, small_world):
    path = BIGBOB if world_robot[0] == "bigbob" else small_world
    robot = world_robot[1]
    a, b = StageEnv(path, robot, random_start=True), StageEnv(path, robot, random_start=True)
    actions = np.random.default_rng(7).uniform(
        a.action_space.low, a.action_space.high, size=(40, a.action_space.shape[0])
    )
    seq_a, dig_a = run_episode(a, 11, actions)
    seq_b, dig_b = run_episode(b, 11, actions)
    assert dig_a == dig_b
    assert len(seq_a) == len(seq_b) and all(same_obs(x, y) for x, y in zip(seq_a, seq_b))
    # the robot moved, and another seed starts elsewhere
    assert not same_obs(seq_a[0], seq_a[-1])
    other, _ = run_episode(a, 12, actions[:1])
    assert not np.array_equal(other[0]["odometry"], seq_a[0]["odometry"])


def test_reset_restores_the_world(small_world):
    env = StageEnv(small_world, "r0")
    env.reset(seed=3)
    for _ in range(30):
        env.step(np.array([0.8, 0.5]))  # drives into b1 or a wall: poses, velocity, stall
    assert env.world.odometry("r0").x != 0.0
    obs, info = env.reset(seed=3)
    fresh = StageEnv(small_world, "r0")
    obs_f, info_f = fresh.reset(seed=3)
    assert env.world.digest() == fresh.world.digest()
    assert same_obs(obs, obs_f) and info == info_f
    # as loaded: the file's world after one step at rest
    loaded = World(small_world, 0)
    loaded.step(1)
    assert env.world.digest() == loaded.digest()


def test_drawn_poses_are_free(small_world):
    env = StageEnv(small_world, "r0", goal_tolerance=0.25)
    starts = set()
    for seed in range(20):
        _, info = env.reset(seed=seed, options={"random_start": True})
        w = env.world
        x, y, a = info["start"]
        w.set_pose("r0", x, y, a)
        assert not w.overlaps("r0")
        gx, gy = env.goal
        assert math.hypot(gx - x, gy - y) > 0.5
        w.set_pose("r0", gx, gy, 0.0)
        assert not w.overlaps("r0")
        starts.add((x, y))
    assert len(starts) == 20
    # without random_start the robot starts where the file puts it
    _, info = env.reset(seed=0)
    assert info["start"] == (0.0, 0.0, 0.0)


def test_overlaps(small_world):
    w = World(small_world, 0)
    assert not w.overlaps("r0")
    w.set_pose("r0", 1.8, 0.0, 0.3)  # outlines cross b1's
    assert w.overlaps("r0")
    w.set_pose("r0", 2.0, 0.0, 0.0)  # wholly inside b1: no edge crosses
    assert w.overlaps("r0")
    w.set_pose("r0", 3.0, 3.0, 0.0)
    assert not w.overlaps("r0")
    with pytest.raises(WorldError, match="no model named `nobody`"):
        w.overlaps("nobody")


def test_goal_reached_terminates(small_world):
    env = StageEnv(small_world, "r0", goal=(3.0, -3.0), goal_reward=5.0)
    obs, info = env.reset(seed=0)
    assert info["goal"] == (3.0, -3.0)
    assert np.allclose(obs["goal"], [3.0, -3.0])
    before = info["distance"]
    env.world.set_pose("r0", 3.0, -3.0, 0.0)
    obs, reward, terminated, truncated, info = env.step(np.zeros(2))
    assert terminated and not truncated and info["reached"]
    assert math.isclose(reward, before - info["distance"] + 5.0)
    assert np.allclose(obs["goal"], [0.0, 0.0], atol=1e-6)
    # the reset option wins over the constructor's goal
    _, info = env.reset(seed=0, options={"goal": (-3.0, 3.0)})
    assert env.goal == (-3.0, 3.0) and info["goal"] == (-3.0, 3.0)


@pytest.mark.parametrize("terminate_on_stall", [False, True])
def test_stall_penalty(small_world, terminate_on_stall):
    env = StageEnv(
        small_world,
        "r0",
        goal=(-3.0, -3.0),
        stall_penalty=2.0,
        terminate_on_stall=terminate_on_stall,
    )
    obs, _ = env.reset(seed=0, options={"start": (1.2, 0.0, 0.0)})  # facing b1, 0.35 m away
    assert obs["stall"] == 0
    for _ in range(30):
        obs, reward, terminated, truncated, info = env.step(np.array([0.5, 0.0]))
        if info["stall"]:
            break
        assert reward > -0.1 and not terminated
    assert info["stall"] and obs["stall"] == 1
    assert reward <= -2.0 + 0.06  # progress of one 0.05 m move at most, minus the penalty
    assert terminated == terminate_on_stall


def test_frame_skip_and_user_task(small_world):
    calls = []

    def task(world, robot):
        calls.append(world.steps)
        x = world.pose(robot).x
        return x, x > 0.5, {"x": x}

    env = StageEnv(small_world, "r0", task=task, frame_skip=3, max_episode_steps=2)
    env.reset(seed=0)
    assert isinstance(env.world, World)
    assert env.world.steps == 1 and "goal" not in env.observation_space.spaces
    _, reward, terminated, truncated, info = env.step(np.array([0.8, 0.0]))
    assert env.world.steps == 4 and calls == [4]
    assert reward == info["x"] > 0 and not terminated and not truncated
    _, _, _, truncated, _ = env.step(np.array([0.8, 0.0]))
    assert truncated  # max_episode_steps

    env = StageEnv(small_world, "r0", task=lambda w, r: 1.0)
    env.reset(seed=0)
    with pytest.raises(TypeError, match="expected \\(reward, terminated, info\\)"):
        env.step(np.zeros(2))


def test_bad_arguments(small_world):
    with pytest.raises(WorldError, match="no model named `r9`"):
        StageEnv(small_world, "r9")
    with pytest.raises(WorldError, match="not a position model"):
        StageEnv(small_world, "b1")
    with pytest.raises(ValueError, match="frame_skip"):
        StageEnv(small_world, "r0", frame_skip=0)
    with pytest.raises(ValueError, match="built-in tasks"):
        StageEnv(small_world, "r0", task="wander")
    env = StageEnv(small_world, "r0")
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(options={"random_goal": True})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action of shape"):
        env.step(np.zeros(3))


def test_no_free_pose_is_an_error(tmp_path):
    # a robot wider than the walled-in floor fits nowhere
    path = tmp_path / "cramped.world"
    text = BOXES.read_text().replace("size [0.4 0.4 0.3]", "size [9 9 0.3]")
    path.write_text(text)
    env = StageEnv(path, "r0", goal=(0.0, 0.0), max_draws=50)
    env.reset(seed=0)  # the file's pose is not drawn, so not tested
    with pytest.raises(RuntimeError, match="no free pose for `r0` in 50 draws"):
        env.reset(seed=0, options={"random_start": True})
    with pytest.raises(ValueError, match="max_draws"):
        StageEnv(path, "r0", max_draws=0)


def test_action_clip_single_and_vector_agree():
    """StageEnv clips an action in plain Python; VectorStageEnv's native step (VectorCore)
    clips its batch. They must agree bit for bit, signed zeros and NaN included, whatever the
    batch's memory layout, or a lone env and a vector's copy could command different speeds
    (numpy.clip itself treats -0.0 differently in strided arrays)."""
    import math

    from playerstage.envs._stage_env import _clip

    values = [-0.0, 0.0, math.nan, -1.0, 2.0, 0.5, math.inf, -math.inf, 1e-300, -0.5, 1.0]
    n = len(values)
    for lo, hi in [(0.0, 1.0), (-0.5, 0.0), (-1.0, 1.0), (-0.0, 0.0), (0.0, 0.0)]:
        core = _native.VectorCore(n, "r0", [], False, [lo, lo], [hi, hi], 1, None)
        contiguous = np.array([[v, v] for v in values])
        strided = np.array([values] * 2).T
        for batch in (contiguous, strided):
            commands = core.commands(np.ascontiguousarray(batch).tobytes())
            for x, (vx, vy, va) in zip(values, commands):
                want = _clip(x, lo, hi)
                assert vy == 0.0, "a diff drive has no sideways speed"
                for got in (vx, va):
                    if math.isnan(want):
                        assert math.isnan(got)
                    else:
                        assert got == want and math.copysign(1, got) == math.copysign(1, want)
        assert _clip(-0.0, 0.0, 1.0) == 0.0 and math.copysign(1, _clip(-0.0, 0.0, 1.0)) == 1
    omni = _native.VectorCore(1, "r0", [], True, [-1, -2, -3], [1, 2, 3], 1, None)
    assert omni.commands(np.array([5.0, -5.0, 0.5]).tobytes()) == [[1.0, -2.0, 0.5]]
    with pytest.raises(ValueError, match="bytes of actions for 1 envs of 3"):
        omni.commands(np.array([5.0, -5.0]).tobytes())
