"""What SWIG-era scripts call that the drop-ins once lacked (issue 40, item 4): ``destroy()`` on
every proxy and on the client, the C size arguments of the simulation's property calls,
libplayerc++'s quiet simulation setters, and the SWIG methods added after checking Player
3.0.2's bindings (device capabilities and properties on ``info``, the client's own subscribe,
retry and device-list calls, the laser's id and printout, libplayerc++'s extra getters)."""

from __future__ import annotations

import ctypes
import struct
from pathlib import Path

import pytest
from conftest import run_script, start_player, wait_until
from test_nav import GOAL, nav  # noqa: F401 - the planner/localize server fixture
from test_playerc import connect, sub

import playerc
import playercpp
from playerc import *  # noqa: F401,F403 - the way old scripts use it

# Values of player_interfaces.h: a simulation's GET_POSE3D request is one our server (like
# Stage, evidently) says it handles; GET_POSE2D one it answers without saying so.
SIMULATION_REQ_GET_POSE3D = 3
SIMULATION_REQ_GET_POSE2D = 1

SCRIPTS = Path(__file__).parent / "swig_scripts"


def proxy_classes() -> list[type]:
    """Every playerc proxy class (the ones SWIG made of playerc_<interface>_t)."""
    return sorted(
        (c for c in vars(playerc).values()
         if isinstance(c, type) and issubclass(c, playerc._device) and c is not playerc._device),
        key=lambda c: c.__name__,
    )


# --- destroy() ---------------------------------------------------------------------------------


def test_every_proxy_has_destroy_and_is_unusable_after_it(server):
    c = connect(server.port)
    classes = proxy_classes()
    assert len(classes) >= 14
    for cls in classes:
        p = cls(c, 0)
        info = p.info
        assert p.destroy() is None
        with pytest.raises(ReferenceError, match=f"{cls.__name__} .*:0 was destroyed"):
            p.subscribe(PLAYERC_OPEN_MODE)
        with pytest.raises(ReferenceError):
            p.info
        with pytest.raises(ReferenceError):
            info.datatime
        with pytest.raises(ReferenceError):
            p.destroy()  # a second destroy: an error, not a double free
        assert "destroyed" in repr(p)
    p = sub(playerc_position2d(c, 0))
    assert c.read() == c.id
    assert p.info.datatime > 0
    c.disconnect()


def test_a_destroyed_gripper_is_no_longer_updated_by_reads(server):
    c = connect(server.port)
    grip = sub(playerc_gripper(c, 0))
    pos = sub(playerc_position2d(c, 1))
    assert c.datamode(PLAYER_DATAMODE_PUSH) == 0
    wait_until(lambda: grip.info.id in {c.read() for _ in range(20)})
    gone = grip.info.id
    grip.destroy()  # still subscribed (as in C): the server keeps sending the gripper's data
    # PUSH mode: read() returns the proxy a message updated, the client's own id for a
    # message no proxy takes; the destroyed gripper's id never again.
    ids = [c.read() for _ in range(80)]
    assert gone not in ids
    assert pos.info.id in ids and c.id in ids
    with pytest.raises(ReferenceError):
        grip.close_cmd()
    other = sub(playerc_gripper(c, 0))  # a new proxy of the same device is updated
    wait_until(lambda: other.info.id in {c.read() for _ in range(20)})
    assert other.close_cmd() == 0
    c.disconnect()


def test_swig_script_that_destroys_its_gripper_and_client(server):
    out = run_script(SCRIPTS / "gripper_tidy.py", server.port)
    assert out.splitlines()[1:] == ["closed", "opened", "done"], out


def test_destroying_the_client_closes_it_and_its_proxies_fail_cleanly(server):
    c = connect(server.port)
    p = sub(playerc_position2d(c, 0))
    c.destroy()
    with pytest.raises(ReferenceError, match="playerc_client localhost:.* was destroyed"):
        c.read()
    assert p.get_geom() == -1
    assert "destroyed" in playerc_error_str()
    p.destroy()  # after its client: still fine


# --- the simulation's property calls with their C size argument --------------------------------


def test_get_property_fills_a_buffer_of_the_given_size(fresh_server):
    c = connect(fresh_server.port)
    sim = sub(playerc_simulation(c, 0))
    rgba = (ctypes.c_float * 4)()
    assert sim.get_property("bob1", "color", rgba, 16) == 0
    assert sum(rgba) > 0
    raw = bytearray(16)
    assert sim.get_property("bob1", "color", raw, 16) == 0
    assert struct.unpack("<4f", raw) == tuple(rgba)
    t = ctypes.c_uint64()
    assert sim.get_property("bob1", "time", t, ctypes.sizeof(t)) == 0
    assert t.value > 0
    # Without a buffer the bytes come back as an output argument.
    ret = sim.get_property("bob1", "color", 16)
    assert ret == [0, bytes(raw)]
    assert sim.get_property("bob1", "color") == [0, bytes(raw)]
    # Sizes the simulator refuses, buffers that cannot hold the value, unknown names: -1.
    assert sim.get_property("bob1", "color", bytearray(16), 8) == -1
    assert sim.get_property("bob1", "color", bytearray(4), 16) == -1
    assert "buffer has 4 bytes" in playerc_error_str()
    assert sim.get_property("bob1", "color", b"immutable", 9) == -1
    assert "writable buffer" in playerc_error_str()
    assert sim.get_property("no-such-model", "color", bytearray(16), 16) == -1
    c.disconnect()


def test_set_property_takes_the_size_argument(fresh_server):
    c = connect(fresh_server.port)
    sim = sub(playerc_simulation(c, 0))
    red = (ctypes.c_float * 4)(1.0, 0.0, 0.0, 1.0)
    assert sim.set_property("bob1", "color", red, 16) == 0
    back = (ctypes.c_float * 4)()
    assert sim.get_property("bob1", "color", back, 16) == 0
    assert list(back) == [1.0, 0.0, 0.0, 1.0]
    blue = struct.pack("<4f", 0.0, 0.0, 1.0, 1.0) + b"extra"
    assert sim.set_property("bob1", "color", blue, 16) == 0  # only the first 16 bytes
    assert sim.get_property("bob1", "color")[1] == blue[:16]
    assert sim.set_property("bob1", "color", list(blue[:16])) == 0
    assert sim.set_property("bob1", "color", red, 32) == -1
    assert "value_len 32" in playerc_error_str()
    assert sim.set_property("bob1", "color", 3.5, 8) == -1
    c.disconnect()


def test_playercpp_get_and_set_property_with_size(fresh_server):
    robot = playercpp.PlayerClient("localhost", fresh_server.port)
    sim = playercpp.SimulationProxy(robot, 0)
    sim.SetProperty("bob1", "color", (ctypes.c_float * 4)(0.0, 1.0, 0.0, 1.0), 16)
    green = (ctypes.c_float * 4)()
    assert sim.GetProperty("bob1", "color", green, 16) == bytes(green)
    assert list(green) == [0.0, 1.0, 0.0, 1.0]
    assert sim.GetProperty("bob1", "color", None, 16) == bytes(green)
    assert sim.GetProperty("bob1", "color") == bytes(green)
    # libplayerc++ ignores the result: a NACK leaves the caller's buffer untouched.
    untouched = bytearray(b"\x07" * 16)
    assert sim.GetProperty("no-such-model", "color", untouched, 16) is None
    assert untouched == bytearray(b"\x07" * 16)
    sim.SetProperty("no-such-model", "color", green, 16)
    with pytest.raises(playercpp.PlayerError):
        sim.GetProperty("no-such-model", "color")  # nothing to return
    robot.Disconnect()


# --- libplayerc++'s simulation setters ignore NACKs ----------------------------------------------


def test_playercpp_set_pose_returns_quietly_on_a_nack(fresh_server):
    robot = playercpp.PlayerClient("localhost", fresh_server.port)
    sim = playercpp.SimulationProxy(robot, 0)
    sim.SetPose2d("no-such-model", 1.0, 2.0, 0.0)
    sim.SetPose3d("no-such-model", 1.0, 2.0, 0.0, 0.0, 0.0, 0.0)
    sim.SetPose2d("orange1", 1.0, 2.0, 0.5)
    assert sim.GetPose2d("orange1") == pytest.approx((1.0, 2.0, 0.5))
    sim.SetPose3d("orange1", -1.0, -2.0, 0.0, 0.0, 0.0, 0.25)
    x, y, z, roll, pitch, yaw, t = sim.GetPose3d("orange1")
    assert (x, y, yaw) == pytest.approx((-1.0, -2.0, 0.25))
    assert t >= 0
    with pytest.raises(playercpp.PlayerError):
        sim.GetPose3d("no-such-model")
    # A lost connection is not a NACK: it still raises.
    fresh_server.stop()
    with pytest.raises(playercpp.PlayerError):
        for _ in range(20):
            sim.SetPose2d("orange1", 0.0, 0.0, 0.0)


# --- the device calls of `info` (libplayerc's playerc_device_*) ----------------------------------


def test_info_capabilities_and_properties(server):
    c = connect(server.port)
    sim = sub(playerc_simulation(c, 0))
    assert sim.info.hascapability(PLAYER_MSGTYPE_REQ, SIMULATION_REQ_GET_POSE3D) == 1
    assert sim.info.hascapability(PLAYER_MSGTYPE_REQ, SIMULATION_REQ_GET_POSE2D) == 0
    assert sim.info.hascapability(PLAYER_MSGTYPE_REQ, 1000) == 0
    # The stage driver has no device properties: each request is refused, as in Player.
    pos = sub(playerc_position2d(c, 0))
    for get in (pos.info.get_intprop, pos.info.get_dblprop, pos.info.get_strprop,
                pos.info.get_boolprop):
        result, _ = get("max_speed")
        assert result == -1
        assert "NACK" in playerc_error_str()
    assert pos.info.set_intprop("max_speed", 3) == -1
    assert pos.info.set_dblprop("max_speed", 0.5) == -1
    assert pos.info.set_strprop("name", "x") == -1
    assert pos.info.set_boolprop("on", 1) == -1
    # info.unsubscribe / info.subscribe are the proxy's.
    assert pos.info.unsubscribe() == 0 and pos.info.subscribed == 0
    assert pos.info.subscribe(PLAYERC_OPEN_MODE) == 0 and pos.info.subscribed == 1
    c.disconnect()


# --- the client's own calls ---------------------------------------------------------------------


def test_client_subscribe_deldevice_adddevice(server):
    c = connect(server.port)
    name = bytearray(32)
    assert c.subscribe(PLAYER_LASER_CODE, 0, PLAYERC_OPEN_MODE, name, len(name)) == 0
    assert name.rstrip(b"\0") == b"stage"
    assert c.unsubscribe(PLAYER_LASER_CODE, 0) == 0
    assert c.subscribe(PLAYER_LASER_CODE, 9, PLAYERC_OPEN_MODE) == -1

    p = sub(playerc_position2d(c, 0))
    c.read()
    assert c.deldevice(p.info) == 0
    before = p.info.datatime
    for _ in range(5):
        c.read()
    assert p.info.datatime == before  # off the list: reads leave it alone
    assert c.deldevice(p.info) == -1 and playerc_error_str() == "unknown device"
    assert c.adddevice(p.info) == 0
    wait_until(lambda: p.info.datatime > before, step=c.read)
    p.info.term()
    assert c.deldevice(p.info) == -1
    c.disconnect()


def test_disconnect_retry_resubscribes(fresh_server):
    c = connect(fresh_server.port)
    p = sub(playerc_position2d(c, 0))
    assert c.disconnect_retry() == -1  # libplayerc's default limit: no attempt
    assert p.info.subscribed == 0 and c.read() is None  # left disconnected
    assert c.connect() == 0 and p.subscribe(PLAYERC_OPEN_MODE) == 0
    c.set_retry_limit(2)
    c.set_retry_time(0.1)
    assert c.disconnect_retry() == 0
    assert p.info.subscribed == 1
    before = p.info.datatime
    wait_until(lambda: p.info.datatime > before, step=c.read)
    fresh_server.stop()
    assert c.disconnect_retry() == -1
    assert "2 attempts" in playerc_error_str()


def test_only_the_tcp_transport_connects(server):
    c = playerc_client(None, "localhost", server.port)
    c.set_transport(PLAYERC_TRANSPORT_UDP)
    assert c.connect() == -1
    assert "TCP" in playerc_error_str()
    c.set_transport(PLAYERC_TRANSPORT_TCP)
    assert c.connect() == 0
    c.disconnect()



def test_peek_requestdata_and_read_nonblock_in_pull_mode(server):
    c = connect(server.port)
    p = sub(playerc_position2d(c, 0))
    assert c.read() == c.id
    # A finished round: nothing more comes until asked for.
    assert c.internal_peek(100) == 0
    assert c.read_nonblock() == 0
    before = p.info.datatime
    assert c.peek(2000) == 1  # asks for a round, then finds its data waiting
    assert c.read() == c.id and p.info.datatime > before
    # Polling: ask once, then read_nonblock until the round is complete.
    before = p.info.datatime
    assert c.requestdata() == 0
    wait_until(lambda: c.read_nonblock() == 1)
    assert p.info.datatime > before
    assert c.read_nonblock() == 0
    c.disconnect()
    assert c.peek(0) == -1 and c.read_nonblock() == -1 and c.requestdata() == -1


def test_read_nonblock_in_push_mode(server):
    c = connect(server.port)
    p = sub(playerc_position2d(c, 0))
    assert c.datamode(PLAYER_DATAMODE_PUSH) == 0
    assert c.peek(2000) == 1
    before = p.info.datatime
    wait_until(lambda: c.read_nonblock() == 1 and p.info.datatime > before)
    assert c.unsubscribe(PLAYER_POSITION2D_CODE, 0) == 0
    # Once what was already on its way is handled, nothing more comes.
    wait_until(lambda: c.read_nonblock() == 0 and c.internal_peek(200) == 0)
    c.disconnect()


def test_playercpp_peek_and_read_if_waiting(server):
    robot = playercpp.PlayerClient("localhost", server.port)
    pp = playercpp.Position2dProxy(robot, 0)
    robot.Read()
    before = pp.GetDataTime()
    assert robot.Peek(2000)
    robot.ReadIfWaiting()
    assert pp.GetDataTime() > before
    robot.Disconnect()
    with pytest.raises(playercpp.PlayerError):
        robot.Peek(0)

# --- the laser's id and printout -----------------------------------------------------------------


def test_laser_get_id_and_printout(server, capsys):
    c = connect(server.port)
    laser = sub(playerc_laser(c, 0))
    laser.laser_id = -1
    assert laser.get_id() == 0
    assert laser.laser_id >= 0
    wait_until(lambda: laser.scan_count > 0, step=c.read)
    laser.printout("bob2")
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("bob2: [") and f"scan_count: {laser.scan_count}" in out[0]
    assert out[1] == "# ranges"
    assert len(out[2].split()) == laser.scan_count
    c.disconnect()


# --- libplayerc++'s other calls ------------------------------------------------------------------


def test_playercpp_client_proxy_and_laser_extras(server):
    robot = playercpp.PlayerClient("localhost", server.port)
    assert robot.LookupCode("laser") == PLAYER_LASER_CODE
    assert robot.LookupName(PLAYER_LASER_CODE) == "laser"
    robot.SetRetryLimit(1)
    robot.SetRetryTime(0.5)
    sim = playercpp.SimulationProxy(robot, 0)
    assert sim.HasCapability(PLAYER_MSGTYPE_REQ, SIMULATION_REQ_GET_POSE3D) == 1
    pp = playercpp.Position2dProxy(robot, 0)
    assert pp.GetIntProp("max_speed") == [-1, 0]
    assert pp.SetDblProp("max_speed", 1.0) == -1
    pp.RequestGeom()
    assert pp.GetOffset().px == pp.GetPose().px

    lp = playercpp.LaserProxy(robot, 0)
    assert lp.GetInterfaceStr() == "laser" and lp.GetPlayerClient() is robot
    wait_until(lambda: lp.GetElapsedTime() > 0, step=robot.Read)
    lp.RequestID()
    assert lp.GetID() >= 0
    lp.RequestGeom()
    assert lp.GetSize().sl > 0 and lp.GetSize().sw > 0
    assert isinstance(lp.GetPose().pyaw, float)
    lp.RequestConfigure()
    assert lp.GetConfMaxAngle() > lp.GetConfMinAngle()
    assert lp.IntensityOn() in (True, False)
    wait_until(lambda: lp.GetCount() > 0, step=robot.Read)
    n = lp.GetCount()
    ranges = [lp.GetRange(i) for i in range(n)]
    # libplayerc's halves: right up to and including count/2, left above it.
    assert lp.MinRight() == min([lp.GetMaxRange()] + ranges[: n // 2 + 1])
    assert lp.MinLeft() == min([lp.GetMaxRange()] + ranges[n // 2 + 1:])
    fp = playercpp.FiducialProxy(robot, 0)
    fp.RequestGeometry()
    assert len(fp.GetFiducialSize()) == 2
    robot.Disconnect()


def test_playercpp_planner_and_localize_getters(nav):
    robot = playercpp.PlayerClient("localhost", nav.port)
    loc = playercpp.LocalizeProxy(robot, 0)
    plan = playercpp.PlannerProxy(robot, 0)
    wait_until(lambda: loc.GetNumHypoths() > 0, 30, step=robot.Read)
    assert loc.GetNumHypoths() == loc.GetHypothCount()
    plan.SetGoalPose(*GOAL)
    wait_until(lambda: plan.GetPathValid(), 30, step=robot.Read)
    plan.RequestWaypoints()
    assert plan.GetGoal() == player_pose2d_t(plan.GetGx(), plan.GetGy(), plan.GetGa())
    assert (plan.GetGoal().px, plan.GetGoal().py) == pytest.approx(GOAL[:2])
    assert plan.GetPose() == player_pose2d_t(plan.GetPx(), plan.GetPy(), plan.GetPa())
    assert plan.GetCurrentWaypoint() == player_pose2d_t(plan.GetWx(), plan.GetWy(), plan.GetWa())
    n = plan.GetWaypointCount()
    assert n >= 1
    last = plan.GetWaypoint(n - 1)
    assert (last.px, last.py, last.pa) == (plan.GetIx(n - 1), plan.GetIy(n - 1), plan.GetIa(n - 1))
    with pytest.raises(IndexError):
        plan.GetWaypoint(n)
    plan.SetEnable(False)
    robot.Disconnect()


# --- graphics3d, which the stage driver serves --------------------------------------------------

GRAPHICS3D_CFG = """
driver( name "stage" provides ["simulation:0"] plugin "stageplugin" worldfile "test.world" )
driver( name "stage" model "bob1" provides ["position2d:0" "graphics3d:0"] )
"""


@pytest.fixture(scope="module")
def graphics3d_server(player_bin, world_dir):
    s = start_player(player_bin, world_dir, "graphics3d.cfg", GRAPHICS3D_CFG)
    yield s
    s.stop()


def test_graphics3d_draws_with_playerc_and_playercpp(graphics3d_server):
    c = connect(graphics3d_server.port)
    g = sub(playerc_graphics3d(c, 0))
    assert g.info.drivername == "stage"
    assert g.setcolor((0, 255, 0, 0)) == 0
    assert g.translate(0.0, 0.0, 0.5) == 0
    assert g.rotate(0.3, 0.0, 0.0, 1.0) == 0
    triangle = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.5)]
    assert g.draw(PLAYER_DRAW_LINE_LOOP, triangle, 3) == 0
    assert g.draw(PLAYER_DRAW_POINTS, [player_point_3d_t(0.5, 0.5, 0.5)]) == 0
    assert g.clear() == 0
    assert g.draw(PLAYER_DRAW_POINTS, [(0.0, 0.0)]) == -1
    assert "(x, y, z)" in playerc_error_str()
    assert g.setcolor("green") == -1
    # The commands left the connection usable: a request after them is answered.
    p = sub(playerc_position2d(c, 0))
    assert p.get_geom() == 0
    c.disconnect()

    robot = playercpp.PlayerClient("localhost", graphics3d_server.port)
    g3 = playercpp.Graphics3dProxy(robot, 0)
    g3.Color(255, 0, 0, 0)
    g3.Draw(PLAYER_DRAW_TRIANGLES, [player_point_3d_t(0, 0, 0), player_point_3d_t(1, 0, 0),
                                    player_point_3d_t(0, 1, 0)], 3)
    g3.Clear()
    with pytest.raises(playercpp.PlayerError):
        g3.Draw(PLAYER_DRAW_POINTS, [(0.0, 0.0)])
    robot.Disconnect()


# --- actarray, which the stage driver serves on a Stage actuator ---------------------------------

ARM_ROBOT = """
position
(
  name "arm1"
  pose [ 0 6 0 0 ]
  size [ 0.5 0.5 0.5 ]
  actuator ( type "linear" axis [1 0 0] min_position 0 max_position 0.5 max_speed 1 )
)
"""

ACTARRAY_CFG = """
driver( name "stage" provides ["simulation:0"] plugin "stageplugin" worldfile "arm.world" )
driver( name "stage" model "arm1" provides ["actarray:0"] )
"""


@pytest.fixture(scope="module")
def actarray_server(player_bin, world_dir):
    (world_dir / "arm.world").write_text((world_dir / "test.world").read_text() + ARM_ROBOT)
    s = start_player(player_bin, world_dir, "actarray.cfg", ACTARRAY_CFG)
    yield s
    s.stop()


def test_actarray_with_playerc(actarray_server):
    c = connect(actarray_server.port)
    arm = sub(playerc_actarray(c, 0))
    assert arm.get_geom() == 0
    assert arm.actuators_geom_count == 1
    geom = arm.get_actuator_geom(0)
    assert geom.type == PLAYER_ACTARRAY_TYPE_LINEAR
    assert (geom.min, geom.max) == (0.0, 0.5)
    assert isinstance(geom.axis, player_point_3d_t)
    assert isinstance(arm.base_orientation, player_orientation_3d_t)
    wait_until(lambda: arm.actuators_count == 1, step=c.read)
    assert arm.get_actuator_data(0).state == PLAYER_ACTARRAY_ACTSTATE_IDLE
    # Stage reports a position goal, clamped to the joint's range, as the speed, moving.
    assert arm.position_cmd(0, 0.9) == 0
    wait_until(lambda: arm.get_actuator_data(0).state == PLAYER_ACTARRAY_ACTSTATE_MOVING,
               step=c.read)
    assert arm.get_actuator_data(0).speed == pytest.approx(0.5)
    assert arm.speed_cmd(0, 0.25) == 0
    wait_until(lambda: arm.get_actuator_data(0).speed == pytest.approx(0.25), step=c.read)
    assert arm.speed_cmd(0, 0.0) == 0
    wait_until(lambda: arm.get_actuator_data(0).state == PLAYER_ACTARRAY_ACTSTATE_IDLE,
               step=c.read)
    # Commands Stage ignores are still sent; the configuration requests are refused.
    assert arm.home_cmd(-1) == 0
    assert arm.multi_position_cmd([0.1], 1) == 0
    assert arm.multi_speed_cmd([0.1]) == 0
    assert arm.current_cmd(0, 1.0) == 0 and arm.multi_current_cmd([1.0]) == 0
    assert arm.multi_position_cmd(["far"]) == -1
    assert arm.power(1) == -1 and arm.brakes(0) == -1
    assert arm.speed_config(0, 0.5) == -1 and arm.accel_config(-1, 0.5) == -1
    with pytest.raises(IndexError):
        arm.get_actuator_data(1)
    assert arm.info.get_dblprop("speed")[0] == -1
    c.disconnect()


def test_actarray_with_playercpp(actarray_server):
    robot = playercpp.PlayerClient("localhost", actarray_server.port)
    arm = playercpp.ActArrayProxy(robot, 0)
    arm.RequestGeometry()
    assert arm.GetActuatorGeom(0).max == 0.5
    assert arm.GetActuatorGeom(3).max == 0.0  # a joint the arm lacks: zeros, as in C++
    wait_until(lambda: arm.GetCount() == 1, step=robot.Read)
    arm.MoveTo(0, 0.2)
    wait_until(lambda: arm[0].speed == pytest.approx(0.2), step=robot.Read)
    assert arm.GetActuatorData(0) == arm[0]
    assert arm.GetActuatorData(5).position == 0.0
    arm.MoveAtSpeed(0, 0.0)
    arm.MoveHome(-1)
    with pytest.raises(playercpp.PlayerError):
        arm.SetPowerConfig(True)
    assert isinstance(arm.GetBasePos(), player_point_3d_t)
    robot.Disconnect()


# --- log: a writelog recording the stage robot ---------------------------------------------------

WRITELOG_CFG = """
driver( name "stage" provides ["simulation:0"] plugin "stageplugin" worldfile "test.world" )
driver( name "stage" model "bob1" provides ["position2d:0"] )
driver( name "writelog" requires ["position2d:0"] provides ["log:0"] alwayson 1 autorecord 0
        filename "first.log" )
"""


def test_log_controls_a_writelog(player_bin, world_dir, tmp_path):
    s = start_player(player_bin, world_dir, "writelog.cfg", WRITELOG_CFG)
    try:
        c = connect(s.port)
        log = sub(playerc_log(c, 0))
        assert log.get_state() == 0
        assert (log.type, log.state) == (PLAYER_LOG_TYPE_WRITE, 0)
        target = tmp_path / "robot.log"
        assert log.set_filename(str(target)) == 0
        assert log.set_write_state(1) == 0
        assert log.get_state() == 0 and log.state == 1
        assert log.set_filename(str(tmp_path / "other.log")) == -1  # refused while recording
        assert log.set_read_state(1) == -1  # a writelog does not replay
        wait_until(lambda: target.is_file() and "position2d" in target.read_text())
        assert log.set_write_state(0) == 0
        assert log.get_state() == 0 and log.state == 0
        c.disconnect()

        robot = playercpp.PlayerClient("localhost", s.port)
        lp = playercpp.LogProxy(robot, 0)
        lp.SetState(1)  # queries the type first, then records
        assert lp.GetType() == PLAYER_LOG_TYPE_WRITE
        lp.QueryState()
        assert lp.GetState() == 1
        lp.SetWriteState(0)
        with pytest.raises(playercpp.PlayerError):
            lp.Rewind()
        robot.Disconnect()
    finally:
        s.stop()
