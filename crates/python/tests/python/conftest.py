"""Fixtures: a real `player` server (this workspace's binary) on a free port, serving a copy of
the repository's Bigbob world with one extra robot carrying a camera.

The binary is `$PLAYERSTAGE_PLAYER` when set (the cargo test that runs this suite sets it),
else the newest `player` under the workspace's target directories.
"""

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

# The SWIG-style scripts are programs run by test_swig_scripts.py, not test modules (their
# `test_position2d(client, index)` functions would look like tests to pytest).
collect_ignore = ["swig_scripts"]

REPO = Path(__file__).resolve().parents[4]
WORLDS = REPO / "worlds"
# Stage's own worlds, from the shared reference material (tests using them skip without it).
STAGE_WORLDS = Path(os.environ.get("PLAYERSTAGE_SHARED", REPO.parent / "shared")) / "stage-worlds"
# The manual's Bigbob world (two Bigbobs, oranges, cartons).
BIGBOB = WORLDS / "bigbob.world"
# The learning loops' world: a diff robot with a 180-sample laser among three boxes.
BOXES = WORLDS / "boxes.world"


def boxes_world(directory: Path, drive: str = "diff") -> Path:
    """A copy of ``worlds/boxes.world`` in ``directory`` with the robot's ``drive``."""
    path = directory / f"boxes-{drive}.world"
    path.write_text(BOXES.read_text().replace('drive "diff"', f'drive "{drive}"'))
    return path


def leaves(obs) -> list:
    """An observation's arrays in a fixed order (nested dicts flattened by key)."""
    import numpy as np

    if isinstance(obs, dict):
        return [x for k in sorted(obs) for x in leaves(obs[k])]
    return [np.asarray(obs)]
BITMAPS = REPO / "bitmaps"
EXAMPLES = REPO / "examples" / "python"


def find_binary(name, env_var):
    """This workspace's binary `name`: the path in `env_var` (pytest.rs sets it), else the
    newest debug or release build under the target directory, else None."""
    env = os.environ.get(env_var)
    if env:
        return Path(env)
    roots = [os.environ.get("CARGO_TARGET_DIR"), REPO / "target"]
    found = [
        Path(r) / p / name
        for r in roots
        if r
        for p in ("debug", "release")
        if (Path(r) / p / name).is_file()
    ]
    if not found:
        return None
    return max(found, key=lambda p: p.stat().st_mtime)


@pytest.fixture(scope="session")
def player_bin():
    path = find_binary("player", "PLAYERSTAGE_PLAYER")
    if path is None:
        pytest.fail(
            "no `player` binary: build it with `cargo build -p cli --bin player` or set "
            "PLAYERSTAGE_PLAYER"
        )
    return path


# A robot with a camera, added to the Bigbob world for the camera proxy's tests.
CAMERA_ROBOT = """
define test_camera camera
(
  resolution [ 32 24 ]
  range [ 0.2 8.0 ]
  fov [ 70 40 ]
  pantilt [ 0 0 ]
  size [ 0.1 0.1 0.1 ]
)

position
(
  name "cam1"
  pose [ 0 -6 0 90 ]
  size [ 0.4 0.4 0.4 ]
  color "blue"
  test_camera( pose [ 0 0 0 0 ] )
)
"""


@pytest.fixture(scope="session")
def world_dir(tmp_path_factory):
    """worlds/ and bitmaps/ copied side by side (the world names ../bitmaps/...), with
    test.world = bigbob.world + a camera robot."""
    root = tmp_path_factory.mktemp("playerstage")
    shutil.copytree(WORLDS, root / "worlds")
    shutil.copytree(BITMAPS, root / "bitmaps")
    text = (root / "worlds" / "bigbob.world").read_text()
    (root / "worlds" / "test.world").write_text(text + CAMERA_ROBOT)
    return root / "worlds"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class PlayerServer:
    """One `player` process; `port` is where it listens. `stop()` kills it."""

    def __init__(self, player_bin, cfg_path, args=()):
        self.port = free_port()
        self.proc = subprocess.Popen(
            [str(player_bin), "-p", str(self.port), *args, str(cfg_path)],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            cwd=str(cfg_path.parent),
        )
        self.output = []
        ready = threading.Event()

        def pump():
            for line in self.proc.stdout:
                self.output.append(line)
                if "Listening on ports" in line:
                    ready.set()
            ready.set()

        threading.Thread(target=pump, daemon=True).start()
        if not ready.wait(60) or self.proc.poll() is not None:
            self.stop()
            raise RuntimeError("player did not start:\n" + "".join(self.output))
        listening = [l for l in self.output if "Listening on ports" in l]
        if not listening or str(self.port) not in re.findall(r"\d+", listening[-1]):
            self.stop()
            raise RuntimeError("player is not listening on its port:\n" + "".join(self.output))

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(10)


def start_player(player_bin, world_dir, name, cfg_text, args=()):
    cfg = world_dir / name
    cfg.write_text(cfg_text)
    return PlayerServer(player_bin, cfg, args)


# Every stage-driver device the proxies need, on one port.
DEVICES_CFG = """
driver( name "stage" provides ["simulation:0"] plugin "stageplugin" worldfile "test.world" )
driver( name "stage" model "bob1"
        provides ["position2d:0" "ranger:0" "blobfinder:0" "ranger:1" "speech:0"
                  "graphics2d:0"] )
driver( name "stage" model "bob2"
        provides ["position2d:1" "gripper:0" "fiducial:0" "sonar:0" "laser:0"] )
driver( name "stage" model "cam1" provides ["position2d:2" "camera:0"] )
driver( name "stage" model "cave" provides ["map:0"] )
"""


@pytest.fixture(scope="module")
def server(player_bin, world_dir):
    s = start_player(player_bin, world_dir, "devices.cfg", DEVICES_CFG, ["--speedup", "4"])
    yield s
    s.stop()


@pytest.fixture()
def fresh_server(player_bin, world_dir):
    """A server of its own, for tests that kill it or move the robots."""
    s = start_player(player_bin, world_dir, "devices.cfg", DEVICES_CFG, ["--speedup", "4"])
    yield s
    s.stop()


def run_script(path, *args, timeout=240):
    """Runs a Python script with this interpreter; returns its stdout (fails on exit != 0)."""
    out = subprocess.run(
        [sys.executable, str(path), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert out.returncode == 0, f"{path.name} failed:\n{out.stdout}\n{out.stderr}"
    return out.stdout


def wait_until(pred, timeout=20.0, step=None):
    """Calls `step()` (e.g. a read) until `pred()` holds; fails after `timeout` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if step is not None:
            step()
        if pred():
            return
    raise AssertionError("condition not met in time")


@pytest.fixture
def small_world(tmp_path):
    """``worlds/boxes.world`` (a diff robot ``r0`` with a 180-sample laser among boxes)."""
    return boxes_world(tmp_path)
