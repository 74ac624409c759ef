"""`playerstage.envs.VectorStageEnv`: the vector API contract (gymnasium 1.x has no checker for
vector envs), and copies that match lone StageEnvs and SyncVectorEnv exactly, across
autoresets; the native `step_worlds` it runs on."""

import os

import numpy as np
import pytest

import gymnasium
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.vector.utils import batch_space, iterate

from playerstage import World, WorldError, _native
from playerstage.envs import StageEnv, VectorStageEnv

from conftest import BIGBOB, boxes_world, leaves


def assert_same(a, b, what):
    la, lb = leaves(a), leaves(b)
    assert len(la) == len(lb), what
    for x, y in zip(la, lb):
        assert x.dtype == y.dtype and x.shape == y.shape, what
        assert np.array_equal(x, y), what


# Short episodes, random starts and goals: copies reset at different times and the autoreset
# path (a fresh load, poses drawn from the copy's generator) is taken several times.
KWARGS = dict(random_start=True, max_episode_steps=4, frame_skip=2, terminate_on_stall=True)


@pytest.mark.parametrize(
    "drive, extra",
    [
        ("diff", {}),  # the goal task on Dict observations: the bulk step_observe path
        ("omni", {}),
        ("diff", {"task": None}),
        ("diff", {"flatten": True}),  # the per-copy path after step_worlds
        ("diff", {"task": "explore"}),
        ("diff", {"task": lambda world, robot: (world.time, world.time > 0.9, {})}),
    ],
)
def test_copies_match_lone_stage_envs_and_sync_vector_env(tmp_path, drive, extra):
    small_world = boxes_world(tmp_path, drive)
    kw = {**KWARGS, **extra}
    n = 3
    vec = VectorStageEnv(n, small_world, "r0", **kw)
    lone = [StageEnv(small_world, "r0", **kw) for _ in range(n)]
    sync = SyncVectorEnv([lambda: StageEnv(small_world, "r0", **kw) for _ in range(n)])
    assert vec.single_action_space == sync.single_action_space
    assert vec.observation_space == sync.observation_space
    assert vec.action_space == sync.action_space

    obs_v, _ = vec.reset(seed=7)
    obs_s, _ = sync.reset(seed=7)
    assert_same(obs_v, obs_s, "reset vs SyncVectorEnv")
    for i, env in enumerate(lone):
        env.reset(seed=7 + i)
    done = [False] * n

    rng = np.random.default_rng(3)
    resets = 0
    for t in range(14):
        actions = rng.uniform(vec.action_space.low, vec.action_space.high)
        obs_v, rew_v, term_v, trunc_v, info_v = vec.step(actions)
        obs_s, rew_s, term_s, trunc_s, info_s = sync.step(actions)
        assert sorted(info_v) == sorted(info_s), f"step {t} info keys"
        for k in info_s:
            a, b = np.asarray(info_v[k]), np.asarray(info_s[k])
            assert a.dtype == b.dtype and a.shape == b.shape, f"step {t} info {k}"
            assert all(np.array_equal(x, y) for x, y in zip(a, b)), f"step {t} info {k}"
        assert_same(obs_v, obs_s, f"step {t} vs SyncVectorEnv")
        assert np.array_equal(rew_v, rew_s) and rew_v.dtype == np.float64
        assert np.array_equal(term_v, term_s) and np.array_equal(trunc_v, trunc_s)
        rows = list(iterate(vec.observation_space, obs_v))
        for i, env in enumerate(lone):
            # a lone StageEnv driven as NEXT_STEP autoreset asks
            if done[i]:
                o, r, te, tr = env.reset()[0], 0.0, False, False
                resets += 1
            else:
                o, r, te, tr, _ = env.step(actions[i])
            done[i] = te or tr
            assert_same(rows[i], o, f"step {t} env {i}")
            assert (rew_v[i], term_v[i], trunc_v[i]) == (r, te, tr), f"step {t} env {i}"
            assert vec.envs[i].world.digest() == env.world.digest() == sync.envs[i].world.digest()
    assert resets >= n, "every copy went through an autoreset"


def test_vector_api_contract(small_world):
    """Gymnasium 1.x has no vector env checker: spaces, shapes, dtypes, seeds, masks and the
    NEXT_STEP autoreset checked directly."""
    vec = VectorStageEnv(4, small_world, "r0", max_episode_steps=2, flatten=True)
    assert vec.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    single = StageEnv(small_world, "r0", flatten=True)
    assert vec.single_observation_space == single.observation_space
    assert vec.observation_space == batch_space(single.observation_space, 4)
    assert vec.action_space == batch_space(single.action_space, 4)

    obs, info = vec.reset(seed=1)
    assert obs.shape == (4,) + single.observation_space.shape
    assert obs.dtype == vec.observation_space.dtype
    assert obs in vec.observation_space
    assert isinstance(info, dict) and info["_start"].all()
    again, _ = vec.reset(seed=1)
    assert np.array_equal(obs, again), "same seed, same first observations"

    vec.action_space.seed(0)
    for t in range(5):
        obs, rew, term, trunc, info = vec.step(vec.action_space.sample())
        assert obs.shape == (4,) + single.observation_space.shape and obs in vec.observation_space
        assert rew.shape == (4,) and rew.dtype == np.float64
        assert term.dtype == np.bool_ and trunc.dtype == np.bool_
        if t in (1, 4):  # max_episode_steps=2: steps 2 and 5 of each episode truncate...
            assert trunc.all()
        if t == 2:  # ...and the step after is the autoreset: reward 0, nothing ended
            assert not trunc.any() and not term.any() and (rew == 0).all()
            assert info["_start"].all()
    # the returned arrays are fresh, not views of a reused buffer
    a, *_ = vec.step(vec.action_space.sample())
    b, *_ = vec.step(vec.action_space.sample())
    assert not np.shares_memory(a, b)

    # only the masked copies reset
    obs, _ = vec.reset(seed=2)
    vec.step(np.zeros(vec.action_space.shape))
    before = [e.world.digest() for e in vec.envs]
    obs2, info = vec.reset(options={"reset_mask": np.array([True, False, False, True])})
    after = [e.world.digest() for e in vec.envs]
    assert after[1:3] == before[1:3] and after[0] != before[0]
    assert list(info["_start"]) == [True, False, False, True]

    with pytest.raises(ValueError, match="seeds"):
        vec.reset(seed=[1, 2])
    with pytest.raises(ValueError, match="reset_mask"):
        vec.reset(options={"reset_mask": np.zeros(4, dtype=bool)})
    with pytest.raises(ValueError, match="num_envs"):
        VectorStageEnv(0, small_world, "r0")
    vec.close()


def test_make_vec_style_use_with_bigbob():
    vec = VectorStageEnv(2, BIGBOB, "bob1")
    obs, _ = vec.reset(seed=0)
    assert obs in vec.observation_space
    obs, *_ = vec.step(np.zeros(vec.action_space.shape))
    assert obs in vec.observation_space
    assert isinstance(vec, gymnasium.vector.VectorEnv)


@pytest.mark.parametrize("mode", [None, "vector_entry_point", "sync", "async"])
def test_make_vec_every_mode_matches_lone_stage_envs(tmp_path, mode):
    # make_vec's default (the registered vector_entry_point) and "vector_entry_point" make a
    # VectorStageEnv; "sync" and "async" Gymnasium's own vectors of StageEnvs (async: forked
    # workers). Every mode gives what lone StageEnvs give, truncation by the registered
    # limit's or the given max_episode_steps included.
    small_world = boxes_world(tmp_path, "diff")
    kw = dict(world=small_world, robot="r0", random_start=True, frame_skip=2)
    extra = {} if mode is None else {"vectorization_mode": mode}
    vec = gymnasium.make_vec(
        "playerstage/Stage-v0", num_envs=2, max_episode_steps=3, **kw, **extra
    )
    try:
        if mode in (None, "vector_entry_point"):
            assert isinstance(vec, VectorStageEnv)
        else:
            kind = {"sync": gymnasium.vector.SyncVectorEnv, "async": gymnasium.vector.AsyncVectorEnv}
            assert type(vec) is kind[mode]
        assert vec.num_envs == 2
        lone = [
            gymnasium.make("playerstage/Stage-v0", max_episode_steps=3, **kw) for _ in range(2)
        ]
        obs, _ = vec.reset(seed=4)
        for i, (env, row) in enumerate(zip(lone, iterate(vec.observation_space, obs))):
            assert_same(row, env.reset(seed=4 + i)[0], f"reset env {i}")
        rng = np.random.default_rng(1)
        truncations = 0
        for t in range(5):  # episodes of 3 steps: a truncation at step 3, an autoreset at 4
            actions = rng.uniform(vec.action_space.low, vec.action_space.high)
            obs, rew, term, trunc, _ = vec.step(actions)
            truncations += int(trunc.sum())
            for i, (env, row) in enumerate(zip(lone, iterate(vec.observation_space, obs))):
                if t == 3:  # NEXT_STEP autoreset of every copy
                    o, r, te, tr = env.reset()[0], 0.0, False, False
                else:
                    o, r, te, tr, _ = env.step(actions[i])
                assert_same(row, o, f"step {t} env {i}")
                assert (rew[i], term[i], trunc[i]) == (r, te, tr), f"step {t} env {i}"
        assert truncations == 2, "max_episode_steps=3 reached the vector env in every mode"
    finally:
        vec.close()


def test_make_vec_uses_the_registered_step_limit(tmp_path):
    vec = gymnasium.make_vec(
        "playerstage/Stage-v0", num_envs=2, world=boxes_world(tmp_path), robot="r0"
    )
    assert isinstance(vec, VectorStageEnv)
    assert all(env._max_episode_steps == 1000 for env in vec.envs)
    assert vec.spec is not None and vec.spec.kwargs["vectorization_mode"] == "vector_entry_point"
    vec.close()


def test_step_worlds_equals_stepping_each_world_alone():
    alone = [World(BIGBOB, seed) for seed in (0, 1, 2)]
    batch = [World(BIGBOB, seed) for seed in (0, 1, 2)]
    for w in alone + batch:
        w._w.set_velocity("bob1", 0.3, 0.0, 0.4)
    for w in alone:
        w.step(25)
    assert _native.step_worlds([w._w for w in batch], 25) == [True] * 3
    assert [w.digest() for w in batch] == [w.digest() for w in alone]
    assert len({w.digest() for w in batch}) > 1, "different seeds, different runs"


def test_step_worlds_stops_at_quit_time_and_refuses_a_world_twice():
    a, b = World(BIGBOB), World(BIGBOB)
    a.quit_time = a.interval * 3
    assert _native.step_worlds([a._w, b._w], 5) == [False, True]
    assert a.steps == 3 and b.steps == 5
    with pytest.raises(WorldError, match="twice"):
        _native.step_worlds([a._w, a._w], 1)
    assert _native.step_worlds([], 3) == []


def test_vector_env_renders_each_copy(tmp_path):
    world = boxes_world(tmp_path)  # no window entity: 400 x 300 images
    vec = VectorStageEnv(2, world, "r0", task=None, render_mode="rgb_array", random_start=True)
    vec.reset(seed=3)
    try:
        frames = vec.render()
    except RuntimeError as e:
        if "no graphics adapter" in str(e) and os.environ.get("PLAYERSTAGE_REQUIRE_GPU") != "1":
            pytest.skip(f"no wgpu adapter: {e}")
        raise
    assert len(frames) == 2 and all(f.shape == (300, 400, 3) for f in frames)
    assert not np.array_equal(frames[0], frames[1]), "different random starts"


def test_step_observe_refuses_bad_input():
    a, b = World(BIGBOB), World(BIGBOB)
    rangers = a._w.rangers("bob1")
    with pytest.raises(WorldError, match="2 velocities for 1 worlds"):
        _native.step_observe([a._w], "bob1", [[0, 0, 0], [0, 0, 0]], 1, rangers)
    with pytest.raises(WorldError, match="twice"):
        _native.step_observe([a._w, a._w], "bob1", [[0, 0, 0]] * 2, 1, rangers)
    with pytest.raises(WorldError, match="no model named `nobody`"):
        _native.step_observe([a._w, b._w], "nobody", [[0, 0, 0]] * 2, 1, rangers)
    with pytest.raises(WorldError, match="not a ranger"):
        _native.step_observe([a._w], "bob1", [[0, 0, 0]], 1, [("bob1", 1, 1.0)])
    # a refused call changes nothing: not a step, not a command
    assert a.steps == 0 and b.steps == 0
    assert a.digest() == b.digest() == World(BIGBOB).digest()


@pytest.mark.parametrize("tolerance", [2.0, 100.0])
def test_bulk_step_rewards_goal_and_stall_like_sync_vector_env(tmp_path, tolerance):
    # The bulk path's batched rewards: a goal at the centre reached by some copies (2 m) or by
    # all at once (100 m: every copy terminates together, so the next step steps none and
    # resets all),
    # stall penalties and terminations, non-default weights; infos and all against SyncVectorEnv.
    small_world = boxes_world(tmp_path, "diff")
    kw = dict(
        random_start=True, goal=(0.0, 0.0), frame_skip=3, goal_tolerance=tolerance,
        goal_reward=2.5,
        stall_penalty=0.25, max_episode_steps=6,
    )
    n = 4
    vec = VectorStageEnv(n, small_world, "r0", **kw)
    sync = SyncVectorEnv([lambda: StageEnv(small_world, "r0", **kw) for _ in range(n)])
    with pytest.raises(RuntimeError, match="reset"):
        vec.step(vec.action_space.sample())
    assert_same(vec.reset(seed=11)[0], sync.reset(seed=11)[0], "reset")
    rng = np.random.default_rng(5)
    reached = stalled = 0
    for t in range(16):
        actions = rng.uniform(vec.action_space.low, vec.action_space.high)
        actions[:, 0] = vec.action_space.high[:, 0]  # full speed ahead: walls get hit
        obs_v, rew_v, term_v, trunc_v, info_v = vec.step(actions)
        obs_s, rew_s, term_s, trunc_s, info_s = sync.step(actions)
        assert_same(obs_v, obs_s, f"step {t}")
        assert np.array_equal(rew_v, rew_s), f"step {t}"
        assert np.array_equal(term_v, term_s) and np.array_equal(trunc_v, trunc_s)
        assert sorted(info_v) == sorted(info_s), f"step {t} info keys"
        for k in info_s:
            a, b = np.asarray(info_v[k]), np.asarray(info_s[k])
            assert a.dtype == b.dtype and a.shape == b.shape, f"step {t} info {k}"
            assert all(np.array_equal(x, y) for x, y in zip(a, b)), f"step {t} info {k}"
        if "reached" in info_s:
            reached += int(np.sum(info_s["reached"] & info_s["_reached"]))
            stalled += int(np.sum(info_s["stall"] & info_s["_stall"]))
    assert reached >= 1, "some copy reached its goal"
    assert stalled >= 1, "some copy stalled"
    if tolerance > 10:
        assert reached >= 2 * n, "all copies reached at once, twice"


def test_load_worlds_equals_separate_loads():
    worlds = _native.load_worlds(str(BIGBOB), 3, 4)
    assert len(worlds) == 4 and len({id(w) for w in worlds}) == 4, "four distinct worlds"
    alone = World(BIGBOB, 3)
    assert [w.digest() for w in worlds] == [alone.digest()] * 4
    for w in worlds:
        w.set_velocity("bob1", 0.3, 0.0, 0.4)
    alone._w.set_velocity("bob1", 0.3, 0.0, 0.4)
    alone.step(10)
    assert _native.step_worlds(worlds, 10) == [True] * 4
    assert [w.digest() for w in worlds] == [alone.digest()] * 4
    assert _native.load_worlds(str(BIGBOB), 0, 0) == []
    with pytest.raises(WorldError):
        _native.load_worlds("/nonexistent/nothing.world", 0, 2)


def test_goal_distance_is_computed_natively_once_for_single_and_vector(tmp_path):
    """The goal task's distance and relative goal come from one native function (libm's hypot,
    cos and sin: CPython's math.hypot is its own and may differ in the last bit), which
    StageEnv and VectorStageEnv both use."""
    import ctypes
    import ctypes.util

    libm = ctypes.CDLL(ctypes.util.find_library("m"))
    for f in ("hypot", "cos", "sin"):
        getattr(libm, f).restype = ctypes.c_double
    libm.hypot.argtypes = [ctypes.c_double, ctypes.c_double]
    libm.cos.argtypes = libm.sin.argtypes = [ctypes.c_double]

    small_world = boxes_world(tmp_path)
    kw = dict(random_start=True, frame_skip=2)
    env = StageEnv(small_world, "r0", **kw)
    vec = VectorStageEnv(1, small_world, "r0", **kw)
    env.reset(seed=5)
    vec.reset(seed=5)
    rng = np.random.default_rng(3)
    for t in range(20):
        action = rng.uniform(env.action_space.low, env.action_space.high)
        obs, _, term, trunc, info = env.step(action)
        obs_v, _, _, _, info_v = vec.step(action[None])
        x, y, a = env.world._w.global_pose("r0")
        dx, dy = env.goal[0] - x, env.goal[1] - y
        c, s = libm.cos(a), libm.sin(a)
        assert info["distance"] == libm.hypot(dx, dy), f"step {t}"
        assert info_v["distance"][0] == info["distance"], f"step {t}"
        want = np.array([c * dx + s * dy, -s * dx + c * dy], dtype=np.float32)
        assert np.array_equal(obs["goal"], want) and np.array_equal(obs_v["goal"][0], want)
        if term or trunc:
            break
    # the native call reads without commanding or stepping when asked to
    w = World(small_world)
    w._w.set_velocity("r0", 0.4, 0.0, 0.0)
    rangers = w._w.rangers("r0")
    running, _, state = _native.step_observe([w._w], "r0", None, 0, rangers, [[1.0, 2.0]])
    assert running == [True] and w.steps == 0 and len(state) == 13 * 8
    w.step(3)
    assert w._w.position("r0")["vx"] == pytest.approx(0.4), "the command was kept"
    with pytest.raises(WorldError, match="2 goals for 1 worlds"):
        _native.step_observe([w._w], "r0", None, 0, rangers, [[0, 0], [1, 1]])


def test_goal_reward_is_the_documented_formula():
    """The goal task's reward, natively (StageEnv, parallel_env and VectorStageEnv all take it
    from there): the decrease of the distance to the goal, minus stall_penalty on a stall,
    plus goal_reward within goal_tolerance (which terminates, as a stall does with
    terminate_on_stall). Hand-computed cases, in the argument order (before, distance, stall,
    goal_tolerance, goal_reward, stall_penalty, terminate_on_stall)."""
    g = _native.goal_reward
    # 3.0 -> 2.5 m, free, far from the goal: +0.5, nothing ends
    assert g(3.0, 2.5, False, 0.3, 1.0, 1.0, False) == (0.5, False, False)
    # moving away: a negative reward
    assert g(2.0, 2.25, False, 0.3, 1.0, 1.0, False) == (-0.25, False, False)
    # stalled while 0.5 m nearer: 0.5 - 2.0
    assert g(3.0, 2.5, True, 0.3, 1.0, 2.0, False) == (-1.5, False, False)
    # ... and with terminate_on_stall it ends the episode without reaching
    assert g(3.0, 2.5, True, 0.3, 1.0, 2.0, True) == (-1.5, False, True)
    # reached: 0.5 -> 0.25 within 0.3: 0.25 + 4.0
    assert g(0.5, 0.25, False, 0.3, 4.0, 1.0, False) == (4.25, True, True)
    # exactly at the tolerance counts as reached (distance <= goal_tolerance)
    assert g(0.5, 0.3, False, 0.3, 1.0, 1.0, False)[1:] == (True, True)
    # reached while stalled: both terms, 0.25 - 1.0 + 2.0
    assert g(0.5, 0.25, True, 0.3, 2.0, 1.0, False) == (1.25, True, True)
    # the float operations in the documented order: (before - distance) - penalty + bonus
    before, distance = 0.1 + 0.2, 0.1
    assert g(before, distance, True, 0.3, 0.7, 0.3, False)[0] == (before - distance) - 0.3 + 0.7


def test_bulk_step_hands_out_fresh_arrays(tmp_path):
    """The bulk step's observations, rewards and flags are numpy views of one block made per
    step: a step never overwrites what an earlier one returned; they are writable and
    C-contiguous, as create_empty_array's would be; bad actions are refused clearly."""
    small_world = boxes_world(tmp_path, "diff")
    vec = VectorStageEnv(3, small_world, "r0", random_start=True, max_episode_steps=3)
    vec.reset(seed=1)
    rng = np.random.default_rng(0)
    first = vec.step(rng.uniform(vec.action_space.low, vec.action_space.high))
    kept = [np.copy(x) for x in leaves(first[0])] + [np.copy(x) for x in first[1:4]]
    for _ in range(4):  # across an autoreset (max_episode_steps=3)
        vec.step(rng.uniform(vec.action_space.low, vec.action_space.high))
    now = leaves(first[0]) + list(first[1:4])
    for a, b in zip(now, kept):
        assert np.array_equal(a, b), "an earlier step's arrays were overwritten"
        assert a.flags.writeable and a.flags.c_contiguous
    assert first[1].dtype == np.float64 and first[2].dtype == first[3].dtype == np.bool_
    with pytest.raises(ValueError, match="actions of shape"):
        vec.step(np.zeros((2, 2)))
    # a Fortran-ordered batch is taken as its values
    acts = np.asfortranarray(rng.uniform(vec.action_space.low, vec.action_space.high))
    twin = VectorStageEnv(3, small_world, "r0", random_start=True, max_episode_steps=3)
    vec.reset(seed=2)
    twin.reset(seed=2)
    assert_same(vec.step(acts)[0], twin.step(np.ascontiguousarray(acts))[0], "layouts")
