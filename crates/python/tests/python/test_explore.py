"""StageEnv's built-in "explore" task: the reward is the free area seen for the first time, in a
world-frame grid, and the info's total matches the room the robot looks around."""

import math

import numpy as np
import pytest

from playerstage.envs import StageEnv

from conftest import BIGBOB


# A 4 x 4 m room (inner faces of the walls at +-2 m) with a robot in the middle whose laser
# sees half of it (180 degrees, 10 m); turning around shows the rest.
ROOM = """
resolution 0.02
interval_sim 100
define wall model ( color "gray" )
position
(
  name "r0"
  pose [0 0 0 0]
  size [0.3 0.3 0.3]
  drive "diff"
  velocity_bounds [-0.5 0.5 0 0 0 0 -90 90]
  ranger ( sensor ( range [0 10] fov 180 samples 361 ) size [0.05 0.05 0.05] )
  ranger ( sensor ( range [0 0.5] fov 10 samples 1 ) size [0.05 0.05 0.05] )
)
wall ( name "north" pose [0 2.05 0 0] size [4.2 0.1 0.5] )
wall ( name "south" pose [0 -2.05 0 0] size [4.2 0.1 0.5] )
wall ( name "east" pose [2.05 0 0 0] size [0.1 4.2 0.5] )
wall ( name "west" pose [-2.05 0 0 0] size [0.1 4.2 0.5] )
"""


@pytest.fixture
def room(tmp_path):
    path = tmp_path / "room.world"
    path.write_text(ROOM)
    return path


def turn(env, steps, speed=math.pi / 4):
    """Turns in place at `speed` rad/s for `steps` steps; the rewards and the last info."""
    rewards, info = [], None
    for _ in range(steps):
        _, reward, terminated, truncated, info = env.step(np.array([0.0, speed]))
        assert not terminated and not truncated
        rewards.append(reward)
    return rewards, info


def test_explored_area_is_the_room(room):
    env = StageEnv(room, "r0", task="explore")
    assert "goal" not in env.observation_space.spaces
    obs, info = env.reset(seed=0)
    first = info["explored"]
    # half the room (8 m^2) at the start, within the cells the walls' edges cut
    assert 7.0 < first < 9.0, first
    # standing still shows nothing new
    _, reward, _, _, info = env.step(np.zeros(2))
    assert reward == 0.0 and info["new_area"] == 0.0 and info["explored"] == first
    # half a turn (pi at pi/4 rad/s: 40 steps of 0.1 s) shows the other half
    rewards, info = turn(env, 40)
    assert all(r >= 0.0 for r in rewards) and sum(rewards) > 6.0
    # the room's 16 m^2, plus some of the cells the walls' faces lie in (Stage's ranges end a
    # little past the face: its rays step over a 0.02 m raster)
    assert 15.0 < info["explored"] < 17.2, info["explored"]
    assert math.isclose(first + sum(rewards), info["explored"], abs_tol=1e-9)
    # going on round: the room was seen, little is new
    more, info = turn(env, 40)
    assert sum(more) < 0.5
    assert info["explored"] < 17.2
    # the count is whole cells
    cells = info["explored"] / 0.01
    assert math.isclose(cells, round(cells), abs_tol=1e-6)


def test_explore_is_deterministic_and_reset(room):
    def episode(env, seed):
        _, info = env.reset(seed=seed)
        rewards, last = turn(env, 25, speed=0.7)
        return info["explored"], rewards, last["explored"]

    a = StageEnv(room, "r0", task="explore", explore_cell=0.05, random_start=True)
    b = StageEnv(room, "r0", task="explore", explore_cell=0.05, random_start=True)
    ea = episode(a, 3)
    assert ea == episode(b, 3)
    assert ea == episode(a, 3)  # the reset starts a new map
    assert ea != episode(a, 4)


def test_explore_rangers_and_cell(room):
    # only the short single-ray ranger: a strip 0.5 m long
    env = StageEnv(room, "r0", task="explore", explore_rangers=["r0.ranger:1"], explore_cell=0.1)
    _, info = env.reset(seed=0)
    assert 0.0 < info["explored"] <= 0.07
    with pytest.raises(ValueError, match="not rangers of `r0`"):
        StageEnv(room, "r0", task="explore", explore_rangers=["r0.ranger:7"])
    with pytest.raises(ValueError, match="explore_cell"):
        StageEnv(room, "r0", task="explore", explore_cell=0.0)


def test_explore_stall(tmp_path):
    path = tmp_path / "room.world"
    path.write_text(ROOM)
    env = StageEnv(path, "r0", task="explore", terminate_on_stall=True, stall_penalty=2.0)
    env.reset(seed=0, options={"start": (1.6, 0.0, 0.0)})
    for _ in range(20):
        _, reward, terminated, _, info = env.step(np.array([0.5, 0.0]))
        if info["stall"]:
            break
    assert info["stall"] and terminated and reward <= -2.0 + 0.1


def test_check_env_explore(room):
    import warnings

    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # advice on box bounds, as in test_envs
        check_env(StageEnv(room, "r0", task="explore", random_start=True))
        check_env(StageEnv(BIGBOB, "bob1", task="explore", flatten=True))


def test_the_rays_go_where_the_laser_looks(tmp_path):
    # a wall across the room 0.5 m east of the robot: facing east it sees a 0.5 x 4 m strip
    # (less the robot's half), facing west the 2 x 4 m half behind it, facing north a 2.5 x 2 m
    # quarter cut by the wall
    path = tmp_path / "split.world"
    path.write_text(ROOM + 'wall ( name "split" pose [0.55 0 0 0] size [0.1 4 0.5] )\n')
    env = StageEnv(path, "r0", task="explore")
    seen = {}
    for name, a in (("east", 0.0), ("west", math.pi), ("north", math.pi / 2)):
        _, info = env.reset(seed=0, options={"start": (0.0, 0.0, a)})
        seen[name] = info["explored"]
    assert 1.6 < seen["east"] < 2.6, seen
    assert 7.0 < seen["west"] < 9.0, seen
    assert 4.5 < seen["north"] < 6.0, seen


# Bigbob's sonar ring (worlds/bigbob.inc): four one-sample transducers, 2 m reach, at
# [x y heading] = [0.75 0.1875 0], [0.75 -0.1875 0], [0.25 0.5 30], [0.25 -0.5 -30] on the robot.
SONARS = "bob1.ranger:0"


def test_ranger_rays_are_each_transducers_pose():
    from playerstage import World

    w = World(BIGBOB)
    assert w.ranger_rays(SONARS) == [], "no readings before the first step"
    w.set_pose("bob1", -4.6, -4.1, math.pi / 2)  # facing +y: x ahead becomes +y
    w.step(1)
    rays = np.array(w.ranger_rays(SONARS))
    assert rays.shape == (4, 3)
    want = [
        (-4.6 - 0.1875, -4.1 + 0.75, math.pi / 2),
        (-4.6 + 0.1875, -4.1 + 0.75, math.pi / 2),
        (-4.6 - 0.5, -4.1 + 0.25, math.pi / 2 + math.pi / 6),
        (-4.6 + 0.5, -4.1 + 0.25, math.pi / 2 - math.pi / 6),
    ]
    assert np.allclose(rays, want, atol=1e-12)
    # one transducer: every sample, from its own pose: the tooth laser sits at [0.625 0.125]
    # facing 270 degrees and fans 20 degrees over 180 samples
    laser = np.array(w.ranger_rays("bob1.ranger:1"))
    assert laser.shape == (180, 3)
    assert np.allclose(laser[:, :2], [-4.6 - 0.125, -4.1 + 0.625], atol=1e-12)
    heading = math.pi / 2 + 3 * math.pi / 2  # the robot's plus the laser's 270 degrees
    first = np.angle(np.exp(1j * (laser[0, 2] - (heading - math.radians(10)))))
    last = np.angle(np.exp(1j * (laser[-1, 2] - (heading + math.radians(10)))))
    assert abs(first) < 1e-9 and abs(last) < 1e-9


def test_explore_casts_a_sonar_ring_from_each_transducer():
    """A hand-computed case. Bigbob at (-4.6, -3.9) facing +x sees nothing within 2 m with its
    sonars. With 1 m cells, the grid starts at the world's corner (-8, -8) less the reach plus
    a cell (3 m): (-11, -11), so a point's cell is (floor(x + 11), floor(y + 11)); a ray's
    points are every half cell, t = 0, 0.5, 1, 1.5 m, from its transducer:

    - sonar 0 from (-3.85, -3.7125) along +x: x + 11 = 7.15, 7.65, 8.15, 8.65, y + 11 =
      7.2875: cells (7, 7), (8, 7);
    - sonar 1 from (-3.85, -4.0875): y + 11 = 6.9125: cells (7, 6), (8, 6);
    - sonar 2 from (-4.35, -3.4) at 30 degrees: x + 11 = 6.65 + 0.866 t = 6.65, 7.08, 7.52,
      7.95 and y + 11 = 7.6 + 0.5 t = 7.6, 7.85, 8.1, 8.35: cells (6, 7), (7, 7), (7, 8);
    - sonar 3 from (-4.35, -4.4) at -30 degrees: y + 11 = 6.6, 6.35, 6.1, 5.85: cells
      (6, 6), (7, 6), (7, 5).

    Eight distinct cells: 8 m^2. Cast from the ring's centre (-4.6, -3.9) all along +x, as
    before each transducer had its own pose, the four rays would cover two cells."""
    env = StageEnv(
        BIGBOB, "bob1", task="explore", explore_cell=1.0, explore_rangers=[SONARS]
    )
    _, info = env.reset(options={"start": (-4.6, -3.9, 0.0)})
    assert env.world.ranger(SONARS).ranges.tolist() == [2.0] * 4, "nothing within reach"
    assert env.world.extent() == [-8.0, -8.0, 8.0, 8.0]
    assert info["explored"] == pytest.approx(8.0)
    # standing still shows nothing new
    _, reward, _, _, step_info = env.step(np.zeros(2))
    assert reward == 0.0 and step_info["explored"] == pytest.approx(8.0)


def reference_new_cells(world, rangers, grid, seen):
    """The explore map's documented rule in numpy, cell by cell: each reading's ray sampled
    every half cell from its transducer (World.ranger_rays) while short of the reading
    (clipped to [0, reach]); a sample's cell is floor((x - x0) / cell), floor((y - y0) /
    cell) when inside the grid. Marks `seen` (a set) and returns how many cells are new."""
    x0, y0, cell, nx, ny = grid
    new = 0
    for name, reach in rangers:
        r = np.asarray(world.ranger(name).ranges, dtype=np.float64)
        rays = np.asarray(world._w.ranger_rays(name), dtype=np.float64).reshape(-1, 3)
        if r.size == 0 or rays.shape[0] != r.size:
            continue
        t = np.arange(0.0, reach, cell / 2)
        for end, (x, y, a) in zip(np.clip(r, 0.0, reach), rays):
            for d in t[t < end]:
                fx = (x - x0) / cell + math.cos(a) * (d / cell)
                fy = (y - y0) / cell + math.sin(a) * (d / cell)
                if fx >= 0 and fy >= 0 and int(fx) < nx and int(fy) < ny:
                    if (int(fx), int(fy)) not in seen:
                        seen.add((int(fx), int(fy)))
                        new += 1
    return new


@pytest.mark.parametrize("world, robot", [("room", "r0"), (BIGBOB, "bob1")])
def test_native_explore_map_follows_the_documented_rule(tmp_path, world, robot):
    """The map is native (a lone StageEnv and VectorStageEnv's copies score with it on the
    simulator's threads): its counts, step by step, equal the rule computed here in Python
    from the rangers' readings and rays, on a laser room and Bigbob's sonar ring and laser."""
    if world == "room":
        world = tmp_path / "room.world"
        world.write_text(ROOM)
    cell = 0.25
    env = StageEnv(world, robot, task="explore", explore_cell=cell, random_start=True)
    _, info = env.reset(seed=3)
    agent = env._agent
    rangers = agent._explore_rangers
    grid = grid_of(env.world, rangers, cell)
    seen = set()
    start = reference_new_cells(env.world, rangers, grid, seen)
    assert start > 0 and info["explored"] == start * cell * cell
    rng = np.random.default_rng(4)
    grew = 0
    for _ in range(25):
        _, reward, _, _, info = env.step(rng.uniform(env.action_space.low, env.action_space.high))
        new = reference_new_cells(env.world, rangers, grid, seen)
        assert info["new_area"] == new * cell * cell
        assert info["explored"] == len(seen) * cell * cell
        assert reward == new * cell * cell - (agent.stall_penalty if info["stall"] else 0.0)
        grew += new > 0
    assert grew >= 3, "the robot saw new ground on several steps"


def test_explore_map_refuses_bad_input():
    from playerstage import World, WorldError

    w = World(BIGBOB)._w
    with pytest.raises(WorldError, match="no explore map for `bob1`"):
        w.explore_see("bob1")
    assert w.explored("bob1") is None
    with pytest.raises(WorldError, match="not a ranger"):
        w.explore_begin("bob1", [("bob1", 2.0)], [-8, -8, 8, 8], 0.1)
    with pytest.raises(WorldError, match="positive cell"):
        w.explore_begin("bob1", [(SONARS, 2.0)], [-8, -8, 8, 8], 0.0)
    with pytest.raises(WorldError, match="too large"):
        w.explore_begin("bob1", [(SONARS, 2.0)], [-8, -8, 8, 8], 1e-6)
    assert w.explore_begin("bob1", [(SONARS, 2.0)], [-8, -8, 8, 8], 0.5) == w.explored("bob1")


def grid_of(world, rangers, cell):
    """The explore grid's (x0, y0, cell, nx, ny): the world's extent grown by the largest
    reach plus a cell."""
    x0, y0, x1, y1 = world.extent()
    pad = max(r for _, r in rangers) + cell
    return (
        x0 - pad, y0 - pad, cell,
        math.ceil((x1 - x0 + 2 * pad) / cell), math.ceil((y1 - y0 + 2 * pad) / cell),
    )


def test_parallel_env_agents_each_have_their_own_map():
    """parallel_env's agents share one world, and each has its own explore map (the world
    keeps one per robot): each agent's areas, at reset and step by step, are the documented
    rule applied to its own rangers alone."""
    from playerstage.envs import parallel_env

    cell = 0.25
    env = parallel_env(BIGBOB, task="explore", explore_cell=cell)
    _, infos = env.reset(
        options={"start": {"bob1": (-4.6, -3.9, 0.0), "bob2": (4.0, 4.0, math.pi)}}
    )
    assert sorted(env.agents) == ["bob1", "bob2"]
    seen = {a: set() for a in env.agents}
    rangers = {a: env._robots[a]._explore_rangers for a in env.agents}
    grid = {a: grid_of(env.world, rangers[a], cell) for a in env.agents}
    for a in env.agents:
        start = reference_new_cells(env.world, rangers[a], grid[a], seen[a])
        assert infos[a]["explored"] == start * cell * cell, a
    assert infos["bob1"]["explored"] != infos["bob2"]["explored"], "different views"
    rng = np.random.default_rng(2)
    for _ in range(10):
        actions = {a: rng.uniform(-0.5, 0.5, size=2) for a in env.agents}
        _, _, _, _, infos = env.step(actions)
        for a in infos:
            new = reference_new_cells(env.world, rangers[a], grid[a], seen[a])
            assert infos[a]["new_area"] == new * cell * cell, a
            assert infos[a]["explored"] == len(seen[a]) * cell * cell, a
