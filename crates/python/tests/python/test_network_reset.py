"""An episode reset over the network, as the package README describes it for libplayerc clients:
`simulation` set_pose2d puts a robot back but keeps its velocity command, its odometry and (until
its next update) its stall; stopping it and set_odom complete the reset."""

import pytest
from conftest import start_player, wait_until

from playerc import (
    PLAYERC_OPEN_MODE,
    playerc_client,
    playerc_error_str,
    playerc_position2d,
    playerc_simulation,
)

# A robot 0.9 m in front of a box, odometry by integration.
WORLD = """
resolution 0.02
interval_sim 100
position
(
  name "r0"
  pose [0 0 0 0]
  size [0.4 0.4 0.3]
  drive "diff"
  localization "odom"
  odom_error [0 0 0 0]
)
model ( name "box" pose [1.2 0 0 0] size [0.5 2 0.5] )
"""

CFG = """
driver( name "stage" provides ["simulation:0"] plugin "stageplugin" worldfile "reset.world" )
driver( name "stage" model "r0" provides ["position2d:0"] )
"""


@pytest.fixture
def reset_server(player_bin, world_dir):
    (world_dir / "reset.world").write_text(WORLD)
    s = start_player(player_bin, world_dir, "reset.cfg", CFG, ["--speedup", "8"])
    yield s
    s.stop()


def test_a_network_reset(reset_server):
    c = playerc_client(None, "localhost", reset_server.port)
    assert c.connect() == 0, playerc_error_str()
    sim = playerc_simulation(c, 0)
    pos = playerc_position2d(c, 0)
    assert sim.subscribe(PLAYERC_OPEN_MODE) == 0 and pos.subscribe(PLAYERC_OPEN_MODE) == 0

    def read_until(pred):
        wait_until(pred, 30.0, step=lambda: c.read())

    # an episode: drive into the box
    assert pos.set_cmd_vel(0.5, 0.0, 0.0, 1) == 0
    read_until(lambda: pos.stall == 1)
    assert pos.px > 0.5

    # set_pose2d alone: the pose is set, the command goes on, odometry is not reset
    assert sim.set_pose2d("r0", -1.0, 0.0, 0.0) == 0
    odom_before = pos.px
    read_until(lambda: pos.stall == 0)
    res = sim.get_pose2d("r0")
    assert res[0] == 0 and res[1] > -1.0  # it moved on from where it was put
    assert pos.vx == pytest.approx(0.5) and pos.px > odom_before

    # the README's reset: stop, put back, set the odometry
    assert pos.set_cmd_vel(0.0, 0.0, 0.0, 1) == 0
    read_until(lambda: pos.vx == 0.0)
    assert sim.set_pose2d("r0", 0.0, 0.0, 0.0) == 0
    assert pos.set_odom(0.0, 0.0, 0.0) == 0
    read_until(lambda: (pos.px, pos.py, pos.pa) == (0.0, 0.0, 0.0))
    for _ in range(5):
        c.read()
    assert sim.get_pose2d("r0")[1:] == pytest.approx([0.0, 0.0, 0.0])
    assert (pos.px, pos.vx, pos.stall) == (0.0, 0.0, 0)
    # a name the world lacks is NACKed
    assert sim.set_pose2d("nobody", 0.0, 0.0, 0.0) == -1
    c.disconnect()
