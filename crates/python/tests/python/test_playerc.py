"""The drop-in `playerc` module against a real `player`: every proxy, PUSH and PULL, errors."""

import math
import threading

import pytest
from conftest import wait_until

from playerc import *  # noqa: F401,F403 - the way old scripts use it


def connect(port):
    c = playerc_client(None, "localhost", port)
    assert c.connect() == 0, playerc_error_str()
    return c


def sub(proxy):
    assert proxy.subscribe(PLAYERC_OPEN_MODE) == 0, playerc_error_str()
    return proxy


def read_until(c, pred, timeout=20.0):
    wait_until(pred, timeout, step=lambda: c.read())


def test_position2d_moves_and_reports_geometry(server):
    c = connect(server.port)
    p = sub(playerc_position2d(c, 0))
    assert p.info.drivername == "stage"
    assert p.get_geom() == 0
    assert p.size[0] == pytest.approx(1.25) and p.size[1] == pytest.approx(1.0)
    assert c.read() == c.id  # PULL mode: the client's own id
    assert p.info.datatime > 0
    x0, y0 = p.px, p.py
    assert p.set_cmd_vel(0.4, 0.0, 0.0, 1) == 0
    read_until(c, lambda: math.hypot(p.px - x0, p.py - y0) > 0.2)
    assert p.vx == pytest.approx(0.4)
    assert p.set_cmd_vel(0.0, 0.0, 0.0, 1) == 0
    # bob1 localises by "gps": SET_ODOM is acknowledged but does not last (as in Stage).
    assert p.set_odom(1.0, 2.0, 0.5) == 0
    assert p.enable(1) == 0
    assert p.unsubscribe() == 0
    c.disconnect()


def test_position2d_pose_command(fresh_server):
    c = connect(fresh_server.port)
    p = sub(playerc_position2d(c, 0))
    c.read()
    tx, ty = p.px + 0.5, p.py
    assert p.set_cmd_pose(tx, ty, p.pa, 1) == 0
    read_until(c, lambda: math.hypot(p.px - tx, p.py - ty) < 0.1, timeout=30)
    c.disconnect()


def test_ranger_of_bob1_and_sonar_laser_of_bob2(server):
    c = connect(server.port)
    sonar = sub(playerc_ranger(c, 0))
    tooth = sub(playerc_ranger(c, 1))
    assert sonar.get_geom() == 0
    assert sonar.element_count == 4
    assert sonar.element_poses[0].px == pytest.approx(0.75)
    read_until(c, lambda: sonar.ranges_count == 4 and tooth.ranges_count > 0)
    assert len(sonar.ranges) == sonar.ranges_count
    assert all(0.0 <= r <= 2.0 for r in sonar.ranges)
    assert tooth.ranges_count == 180
    cfg = tooth.get_config()
    assert cfg[0] == 0 and cfg[5] == pytest.approx(0.25)  # max_range
    assert tooth.max_range == pytest.approx(0.25)
    assert len(tooth.bearings) == tooth.ranges_count
    assert len(tooth.points) == tooth.ranges_count

    laser = sub(playerc_laser(c, 0))
    son = sub(playerc_sonar(c, 0))
    assert son.get_geom() == 0 and son.pose_count == 4
    assert laser.get_geom() == 0
    read_until(c, lambda: laser.scan_count == 180 and son.scan_count == 4)
    assert len(laser.scan) == 180 and len(laser.scan[0]) == 2
    assert laser.scan[0][0] == laser.ranges[0]
    assert laser.max_range == pytest.approx(0.25)
    assert all(0.0 <= r <= 2.0 for r in son.scan)
    ret = laser.get_config()
    assert ret[0] == 0
    c.disconnect()


def test_blobfinder_sees_the_orange_ahead(server):
    c = connect(server.port)
    bf = sub(playerc_blobfinder(c, 0))
    read_until(c, lambda: bf.blobs_count > 0)
    assert (bf.width, bf.height) == (160, 120)
    b = bf.blobs[0]
    assert 0 <= b.x <= bf.width and b.left <= b.right
    assert b.range > 0
    c.disconnect()


def test_fiducial_and_gripper_of_bob2(server):
    c = connect(server.port)
    fid = sub(playerc_fiducial(c, 0))
    grip = sub(playerc_gripper(c, 0))
    assert fid.get_geom() == 0
    assert grip.get_geom() == 0
    assert grip.num_beams >= 1
    c.read()
    c.read()
    assert fid.fiducials_count == len(fid.fiducials)
    for f in fid.fiducials:
        assert isinstance(f.id, int) and isinstance(f.pose.px, float)
    assert grip.state in (PLAYER_GRIPPER_STATE_OPEN, PLAYER_GRIPPER_STATE_CLOSED,
                          PLAYER_GRIPPER_STATE_MOVING)
    assert grip.close_cmd() == 0
    read_until(c, lambda: grip.state == PLAYER_GRIPPER_STATE_CLOSED, timeout=30)
    assert grip.open_cmd() == 0
    read_until(c, lambda: grip.state == PLAYER_GRIPPER_STATE_OPEN, timeout=30)
    c.disconnect()


def test_simulation_moves_a_model(fresh_server):
    c = connect(fresh_server.port)
    sim = sub(playerc_simulation(c, 0))
    res = sim.get_pose2d("orange1")
    assert res[0] == 0
    assert res[1:] == pytest.approx([-3.0, -3.5, 0.0])
    assert sim.set_pose2d("orange1", 1.0, 2.0, 0.5) == 0
    assert sim.get_pose2d("orange1")[1:] == pytest.approx([1.0, 2.0, 0.5])
    # A missing model: the server NACKs, the call returns -1 with a message.
    assert sim.get_pose2d("no-such-model")[0] == -1
    assert "NACK" in playerc_error_str()
    c.disconnect()


def test_speech_graphics2d_camera_and_map(server):
    c = connect(server.port)
    speech = sub(playerc_speech(c, 0))
    assert speech.say("hello from Python") == 0
    g = sub(playerc_graphics2d(c, 0))
    assert g.setcolor((0, 255, 0, 0)) == 0
    assert g.draw_points([(0.0, 0.0), (0.5, 0.5)], 2) == 0
    assert g.draw_polyline([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], 3) == 0
    assert g.draw_polygon([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)], 3, 1, (0, 0, 0, 255)) == 0
    assert g.clear() == 0

    cam = sub(playerc_camera(c, 0))
    read_until(c, lambda: cam.image_count > 0)
    assert (cam.width, cam.height) == (32, 24)
    assert cam.image_count == cam.width * cam.height * cam.bpp // 8

    m = sub(playerc_map(c, 0))
    assert m.get_map() == 0
    assert m.width > 0 and m.height > 0 and m.resolution > 0
    assert len(m.cells) == m.width * m.height
    assert set(m.cells) <= {-1, 0, 1} and 1 in m.cells and -1 in m.cells
    c.disconnect()


def test_push_mode_returns_the_updated_proxy(server):
    c = connect(server.port)
    p = sub(playerc_position2d(c, 0))
    r = sub(playerc_ranger(c, 0))
    assert c.datamode(PLAYER_DATAMODE_PUSH) == 0
    ids = set()
    for _ in range(40):
        ids.add(c.read())
    assert p.info.id in ids and r.info.id in ids
    assert c.id not in ids
    assert c.set_replace_rule(-1, -1, PLAYER_MSGTYPE_DATA, -1, 1) == 0
    assert c.datamode(PLAYER_DATAMODE_PULL) == 0
    assert c.read() == c.id
    c.disconnect()


def test_device_list(server):
    c = connect(server.port)
    assert c.get_devlist() == 0
    names = {(d.addr.interf, d.addr.index) for d in c.devinfos}
    assert (PLAYER_POSITION2D_CODE, 0) in names and (PLAYER_CAMERA_CODE, 0) in names
    assert c.devinfo_count == len(c.devinfos)
    c.disconnect()


def test_errors_are_returned_with_a_message(server):
    # Nothing listens on this port.
    from conftest import free_port

    c = playerc_client(None, "localhost", free_port())
    assert c.connect() == -1
    assert "connect" in playerc_error_str()
    c = connect(server.port)
    missing = playerc_position2d(c, 7)
    assert missing.subscribe(PLAYERC_OPEN_MODE) == -1
    assert "7" in playerc_error_str()
    assert c.datamode(99) == -1
    c.disconnect()
    assert c.read() is None
    assert "not connected" in playerc_error_str()


def test_a_dropped_connection_raises_and_never_hangs(fresh_server):
    c = connect(fresh_server.port)
    p = sub(playerc_position2d(c, 0))
    assert c.read() is not None
    result = []

    def reader():
        for _ in range(1000):
            if c.read() is None:
                result.append(playerc_error_str())
                return
        result.append("kept reading")

    t = threading.Thread(target=reader, daemon=True)
    t.start()
    fresh_server.stop()
    t.join(10)
    assert not t.is_alive(), "read() hung on a dead server"
    assert result and result[0] != "kept reading"
    # A request needs an answer, so it fails at once; a command is only written, and the first
    # write to a socket whose peer has just closed may still be accepted by the kernel, so
    # commands are given a few tries.
    assert p.get_geom() == -1
    assert any(p.set_cmd_vel(0.1, 0, 0, 1) == -1 for _ in range(20))
