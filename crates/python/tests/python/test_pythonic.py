"""The Pythonic layer: `playerstage.Client` against a real `player`, and the in-process
`playerstage.World`."""

import threading

import pytest
from conftest import REPO, wait_until

import playerstage
from playerstage import (
    BlobfinderFrame,
    Client,
    ConnectionLost,
    Odometry,
    RequestRefused,
    World,
    WorldError,
)

np = pytest.importorskip("numpy")


def test_client_devices_and_typed_data(server):
    with Client("localhost", server.port) as client:
        base = client.position2d(0)
        sonar = client.ranger(0)
        eyes = client.blobfinder(0)
        sim = client.simulation(0)
        wait_until(lambda: sonar.scan.ranges.size == 4 and eyes.frame.blobs, step=client.read)
        assert isinstance(base.odometry, Odometry)
        assert isinstance(sonar.scan.ranges, np.ndarray)
        assert sonar.ranges.shape == (4,)
        assert isinstance(eyes.frame, BlobfinderFrame) and eyes.frame.width == 160
        assert sim.get_pose("orange1").x == pytest.approx(-3.0)
        assert base.geometry()["size"] == pytest.approx([1.25, 1.0])
        assert ("position2d", 0, "stage") in client.devices()
        with client.camera(0) as cam:
            wait_until(lambda: not isinstance(cam.image, tuple), step=client.read)
            assert cam.image.shape == (24, 32, 3)
        grid = client.map(0).grid()
        assert grid.dtype == np.int8 and grid.ndim == 2


def test_client_push_mode(server):
    with Client("localhost", server.port, push=True) as client:
        base = client.position2d(0)
        for _ in range(10):
            client.read()
        assert base.time > 0


def test_client_errors_are_exceptions(server, fresh_server):
    with pytest.raises(ConnectionLost):
        Client("localhost", 1)
    with Client("localhost", server.port) as client:
        with pytest.raises(RequestRefused):
            client.position2d(5)
        with pytest.raises(RequestRefused, match="NACK"):
            client.simulation(0).get_pose("ghost")
    client = Client("localhost", fresh_server.port)
    client.position2d(0)
    client.read()
    raised = []

    def loop():
        try:
            while True:
                client.read()
        except ConnectionLost as e:
            raised.append(e)

    t = threading.Thread(target=loop, daemon=True)
    t.start()
    fresh_server.stop()
    t.join(10)
    assert not t.is_alive(), "read() hung on a dead server"
    assert raised


def simple_world():
    p = REPO.parent / "shared" / "stage-worlds" / "simple.world"
    if not p.is_file():
        pytest.skip(f"{p} not found (Stage's own worlds)")
    return p


def test_world_is_deterministic_for_a_seed():
    path = REPO / "worlds" / "bigbob.world"

    def run(seed):
        w = World(path, seed=seed)
        w.set_velocity("bob1", 0.4, 0.0, 0.3)
        w.set_velocity("bob2", 0.3, 0.0, -0.2)
        trace = []
        for _ in range(50):
            w.step(4)
            trace.append((w.pose("bob1"), tuple(w.ranger("bob1.ranger:0").ranges)))
        return w.digest(), trace, w.time

    a, b = run(1), run(1)
    assert a == b
    assert a[2] == pytest.approx(20.0)


def test_world_sensors_and_commands():
    w = World(REPO / "worlds" / "bigbob.world", seed=3)
    types = w.model_types()
    assert types["bob1"] == "position"
    w.step()
    assert isinstance(w.odometry("bob1"), Odometry)
    frame = w.blobfinder("bob1.blobfinder:0")
    assert frame.width == 160 and frame.blobs  # orange1 is straight ahead
    assert w.ranger("bob1.ranger:1").ranges.size == 180
    w.set_pose("orange1", 0.0, 0.0, 0.0)
    assert w.pose("orange1") == playerstage.Pose2d(0.0, 0.0, 0.0)
    w.gripper_cmd("bob2.gripper:0", "close")
    w.step(30)
    assert w.gripper("bob2.gripper:0")["paddles"] == "closed"
    assert isinstance(w.fiducials("bob2.fiducial:0"), list)
    w.say("bob1", "hi")
    assert w.said("bob1") == "hi"
    with pytest.raises(WorldError, match="no model named `nobody`"):
        w.pose("nobody")


def test_world_errors_name_file_and_line(tmp_path):
    bad = tmp_path / "bad.world"
    bad.write_text('resolution 0.02\n\nposition\n(\n  name "r"\n  pose [0 0 0\n')
    with pytest.raises(WorldError) as e:
        World(bad)
    assert "bad.world:" in str(e.value)
    with pytest.raises(WorldError, match="cannot read"):
        World(tmp_path / "missing.world")


def test_world_simple_world_steps_fast():
    w = World(simple_world(), seed=1)
    assert "r0" in w.models("position")
    import time

    t = time.perf_counter()
    w.step(2000)
    rate = 2000 / (time.perf_counter() - t)
    assert rate > 1000, f"{rate:.0f} steps/s"
