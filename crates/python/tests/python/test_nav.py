"""planner and localize proxies (playerc and playercpp) on Player's wavefront + amcl chain over
the stage robot and its map."""

import math
import shutil

import pytest
from conftest import REPO, start_player, wait_until

import playerc
import playercpp

STAGE_WORLDS = REPO.parent / "shared" / "stage-worlds"

# Stage's simple.world with Player's wavefront-remote.cfg chain on one port: vfh drives r0,
# amcl localises it on the cave map, wavefront plans across the cave.
NAV_CFG = """
driver( name "stage" provides ["simulation:0"] plugin "stageplugin" worldfile "simple.world" )
driver( name "stage" provides ["position2d:0" "laser:0"] model "r0" )
driver( name "mapfile" provides ["map:0"] filename "bitmaps/cave.png" resolution 0.032 )
driver( name "vfh" provides ["position2d:1"] requires ["position2d:0" "laser:0"] )
driver( name "amcl" provides ["localize:0" "position2d:2"]
        requires ["odometry:::position2d:0" "laser:0" "laser:::map:0"]
        init_pose [-6.946 -6.947 45] init_pose_var [0.2 0.2 10] )
driver( name "wavefront" provides ["planner:0"]
        requires ["output:::position2d:1" "input:::position2d:2" "map:0"]
        safety_dist 0.15 distance_epsilon 0.5 angle_epsilon 10 )
"""

GOAL = (-3.0, 0.0, math.pi / 2)


@pytest.fixture(scope="module")
def nav(player_bin, tmp_path_factory):
    if not (STAGE_WORLDS / "simple.world").is_file():
        pytest.skip(f"{STAGE_WORLDS} not found (Stage's own worlds)")
    d = tmp_path_factory.mktemp("nav")
    for f in ("pioneer.inc", "map.inc", "sick.inc"):
        shutil.copy(STAGE_WORLDS / f, d / f)
    (d / "bitmaps").mkdir()
    shutil.copy(STAGE_WORLDS / "bitmaps" / "cave.png", d / "bitmaps" / "cave.png")
    # Without the `wander` controller (the world's comment says to drop it under Player).
    world = (STAGE_WORLDS / "simple.world").read_text().splitlines()
    (d / "simple.world").write_text(
        "\n".join(l for l in world if not l.lstrip().startswith("ctrl")) + "\n"
    )
    s = start_player(player_bin, d, "nav.cfg", NAV_CFG, ["--speedup", "4"])
    yield s
    s.stop()


def test_planner_and_localize_with_playerc(nav):
    c = playerc.playerc_client(None, "localhost", nav.port)
    assert c.connect() == 0, playerc.playerc_error_str()
    loc = playerc.playerc_localize(c, 0)
    plan = playerc.playerc_planner(c, 0)
    assert loc.subscribe(playerc.PLAYERC_OPEN_MODE) == 0, playerc.playerc_error_str()
    assert plan.subscribe(playerc.PLAYERC_OPEN_MODE) == 0, playerc.playerc_error_str()
    assert loc.set_pose([-6.946, -6.947, math.radians(45)], [0.1, 0.1, 0.1]) == 0
    wait_until(lambda: loc.hypoth_count > 0, 30, step=c.read)
    h = loc.hypoths[0]
    assert math.hypot(h.mean.px + 6.946, h.mean.py + 6.947) < 1.0
    assert loc.get_particles() == 0 and loc.num_particles > 0
    assert plan.set_cmd_pose(*GOAL) == 0
    wait_until(lambda: plan.path_valid, 30, step=c.read)
    assert plan.get_waypoints() == 0
    assert plan.waypoint_count >= 1 and len(plan.waypoints) == plan.waypoint_count
    assert (plan.gx, plan.gy) == pytest.approx(GOAL[:2])
    assert plan.enable(0) == 0
    c.disconnect()


def test_planner_and_localize_with_playercpp(nav):
    robot = playercpp.PlayerClient("localhost", nav.port)
    loc = playercpp.LocalizeProxy(robot, 0)
    plan = playercpp.PlannerProxy(robot, 0)
    wait_until(lambda: loc.GetHypothCount() > 0, 30, step=robot.Read)
    assert loc.GetHypoth(0).alpha > 0
    plan.SetGoalPose(*GOAL)
    wait_until(lambda: plan.GetPathValid(), 30, step=robot.Read)
    plan.RequestWaypoints()
    assert plan.GetWaypointCount() >= 1
    assert plan.GetGx() == pytest.approx(GOAL[0])
    plan.SetEnable(False)
    robot.Disconnect()
