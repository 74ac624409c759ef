"""The drop-in `playercpp` module (libplayerc++'s names) against a real `player`."""

import math

import pytest
from conftest import wait_until

from playercpp import *  # noqa: F401,F403


def test_position_ranger_blobfinder_simulation(server):
    robot = PlayerClient("localhost", server.port)
    pp = Position2dProxy(robot, 0)
    rp = RangerProxy(robot, 0)
    bf = BlobfinderProxy(robot, 0)
    sim = SimulationProxy(robot, 0)
    pp.RequestGeom()
    rp.RequestGeom()
    assert rp.GetElementCount() == 4
    wait_until(lambda: rp.GetRangeCount() == 4 and bf.GetCount() > 0, step=robot.Read)
    assert rp[0] == rp.GetRange(0)
    assert bf.GetBlob(0).range > 0 and bf.GetWidth() == 160
    assert pp.IsValid() and pp.GetDriverName() == "stage"
    x, y, a = sim.GetPose2d("bob1")
    assert math.hypot(x - pp.GetXPos(), y - pp.GetYPos()) < 5  # odometry vs truth frames
    pp.SetSpeed(0.3, 0.0)
    x0 = pp.GetXPos()
    wait_until(lambda: abs(pp.GetXPos() - x0) > 0.05, step=robot.Read)
    assert pp.GetXSpeed() == pytest.approx(0.3)
    pp.SetSpeed(0.0, 0.0, 0.0)
    pp.SetMotorEnable(True)
    rp.RequestConfigure()
    assert rp.GetMaxRange() == pytest.approx(2.0)
    robot.Disconnect()


def test_gripper_fiducial_laser_sonar_speech_graphics_camera_map(server):
    robot = PlayerClient("localhost", server.port)
    gp = GripperProxy(robot, 0)
    fp = FiducialProxy(robot, 0)
    lp = LaserProxy(robot, 0)
    sp = SonarProxy(robot, 0)
    speech = SpeechProxy(robot, 0)
    g2 = Graphics2dProxy(robot, 0)
    cam = CameraProxy(robot, 0)
    mp = MapProxy(robot, 0)
    gp.RequestGeometry()
    fp.RequestGeometry()
    lp.RequestGeom()
    sp.RequestGeom()
    assert gp.GetNumBeams() >= 1 and sp.GetPoseCount() == 4
    wait_until(lambda: lp.GetCount() == 180 and sp.GetCount() == 4 and cam.GetWidth() > 0,
               step=robot.Read)
    assert lp.GetRange(0) == lp[0] and lp.GetMaxRange() == pytest.approx(0.25)
    assert fp.GetCount() >= 0
    gp.Close()
    wait_until(lambda: gp.GetState() == PLAYER_GRIPPER_STATE_CLOSED, 30, step=robot.Read)
    gp.Open()
    speech.Say("playercpp")
    g2.Color(255, 0, 0, 0)
    g2.DrawPolyline([player_point_2d_t(0, 0), player_point_2d_t(1, 1)], 2)
    g2.Clear()
    assert len(cam.GetImage()) == cam.GetImageSize() > 0
    mp.RequestMap()
    assert mp.GetWidth() * mp.GetHeight() == len(mp.GetMap())
    assert mp.GetCell(0, 0) in (-1, 0, 1)
    robot.Disconnect()


def test_errors_raise_player_error(server):
    from conftest import free_port

    with pytest.raises(PlayerError) as e:
        PlayerClient("localhost", free_port())
    assert "connect" in e.value.GetErrorStr()
    robot = PlayerClient("localhost", server.port)
    with pytest.raises(PlayerError):
        Position2dProxy(robot, 9)
    sim = SimulationProxy(robot, 0)
    with pytest.raises(PlayerError) as e:
        sim.GetPose2d("nobody")
    assert e.value.GetErrorFun() == "SimulationProxy::GetPose2d"
    robot.Disconnect()


def test_listed_fields_become_getters_of_libplayercpp_names():
    """``_fields``/``_elements`` give ``Get`` + CamelCase getters reading the playerc field."""

    class Dev:
        min_angle = -1.5
        scanning_frequency = 10.0
        intensity = [3, 4]

    lp = object.__new__(LaserProxy)  # no server: only the getters are under test
    lp._dev = Dev()
    assert lp.GetMinAngle() == -1.5
    assert lp.GetScanningFrequency() == 10.0
    assert lp.GetIntensity(1) == 4
    assert hasattr(PlannerProxy, "GetWaypointCount") and hasattr(GripperProxy, "GetNumBeams")
    with pytest.raises(TypeError, match="both written out and listed"):

        class Clash(ClientProxy):
            _fields = ("width",)

            def GetWidth(self):
                return 0
