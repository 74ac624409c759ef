"""`StageEnv.render()` in ``"rgb_array"`` mode: the viewer's offscreen renderer, headless (Mesa's
software Vulkan in CI). Without any graphics adapter the tests skip, unless
PLAYERSTAGE_REQUIRE_GPU=1 makes that a failure (as the viewer's own render tests do).
``"human"`` mode: refused without a display; a real window on Xvfb where it is installed.
The same for `parallel_env`."""

import os
import shutil
import subprocess
import time

import gymnasium
import numpy as np
import pytest

from playerstage import World, _native
from playerstage.envs import StageEnv, parallel_env

# A blue box at the world's centre, walls around: the image is fitted to the walls, so the
# box lies at the image's centre.
WORLD = """
resolution 0.02
interval_sim 100
define wall model ( color "black" )
position
(
  name "r0"
  pose [-2 -2 0 0]
  size [0.4 0.4 0.3]
  color "red"
  drive "diff"
  ranger ( sensor ( range [0 4] fov 180 samples 180 ) size [0.1 0.1 0.1] pose [0.1 0 0 0] )
)
model ( name "box" pose [0 0 0 0] size [1 1 0.5] color "blue" )
wall ( name "north" pose [0 4 0 0] size [8 0.1 0.5] )
wall ( name "south" pose [0 -4 0 0] size [8 0.1 0.5] )
wall ( name "east" pose [4 0 0 0] size [0.1 8 0.5] )
wall ( name "west" pose [-4 0 0 0] size [0.1 8 0.5] )
{window}
"""


def frame(env):
    """`env.render()`, or a skip when there is no adapter at all (unless one is required)."""
    try:
        return env.render()
    except RuntimeError as e:
        if "no graphics adapter" in str(e) and os.environ.get("PLAYERSTAGE_REQUIRE_GPU") != "1":
            pytest.skip(f"no wgpu adapter: {e}")
        raise


@pytest.fixture
def world(tmp_path):
    path = tmp_path / "render.world"
    path.write_text(WORLD.format(window=""))
    return path


def test_rgb_array_draws_the_world(world):
    env = StageEnv(world, "r0", task=None, render_mode="rgb_array")
    env.reset(seed=0)
    img = frame(env)
    # the `window` entity's default size, 400 x 300
    assert img.shape == (300, 400, 3) and img.dtype == np.uint8
    blue = img[150, 200]
    assert blue[2] > 150 and blue[0] < 100 and blue[1] < 100, f"box colour at the centre {blue}"
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 3, "more than a blank canvas"
    # the same state draws the same image; a moved robot changes it
    assert np.array_equal(frame(env), img)
    for _ in range(10):
        env.step(np.array([0.5, 0.5]))
    moved = frame(env)
    assert moved.shape == img.shape and not np.array_equal(moved, img)
    assert env.metadata["render_fps"] == pytest.approx(10.0)


def test_window_size_sets_the_image_size(tmp_path):
    path = tmp_path / "sized.world"
    path.write_text(WORLD.format(window="window ( size [160 120] )"))
    env = StageEnv(path, "r0", task=None, render_mode="rgb_array")
    env.reset(seed=0)
    assert frame(env).shape == (120, 160, 3)


def test_render_modes_and_refusals(world, monkeypatch):
    assert StageEnv.metadata["render_modes"] == ["rgb_array", "human"]
    assert StageEnv(world, "r0").render() is None, "no render_mode: nothing rendered"
    with pytest.raises(ValueError, match="render_mode"):
        StageEnv(world, "r0", render_mode="ansi")
    # no display: "human" is refused when the env is made, saying what to do instead
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="needs a display.*rgb_array"):
        StageEnv(world, "r0", render_mode="human")
    with pytest.raises(RuntimeError, match="needs a display"):
        gymnasium.make("playerstage/Stage-v0", world=world, robot="r0", render_mode="human")
    # and the native call says so too, should a display vanish after the env was made
    with pytest.raises(RuntimeError, match="no display"):
        World(world)._w.show_window("no display")


@pytest.fixture(scope="module")
def xvfb_server(tmp_path_factory):
    """An X server (Xvfb) on a free display number, one for the module: the process's world
    window keeps the X connection its event loop opened first, so the server must outlive
    every window test of the process. A skip naming the package where Xvfb is not installed
    (.ci/run installs it)."""
    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb): no X server for the window")
    for number in range(90, 140):
        if not os.path.exists(f"/tmp/.X11-unix/X{number}") and not os.path.exists(
            f"/tmp/.X{number}-lock"
        ):
            break
    logs = tmp_path_factory.mktemp("xvfb")
    log = open(logs / "xvfb.log", "w")
    server = subprocess.Popen(
        [exe, f":{number}", "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        stdout=log, stderr=subprocess.STDOUT,
    )
    deadline = time.monotonic() + 10
    while not os.path.exists(f"/tmp/.X11-unix/X{number}"):
        if server.poll() is not None or time.monotonic() > deadline:
            server.kill()
            pytest.fail(f"Xvfb did not start: {(logs / 'xvfb.log').read_text()}")
        time.sleep(0.05)
    yield f":{number}", logs
    _native.close_window()
    server.terminate()
    server.wait(10)
    log.close()


@pytest.fixture
def xvfb(xvfb_server, monkeypatch):
    """DISPLAY pointing at the module's X server for one test; the window closed after it."""
    display, logs = xvfb_server
    monkeypatch.setenv("DISPLAY", display)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(logs))  # quiets Wayland's probe
    yield display
    _native.close_window()


def test_human_mode_shows_the_world_in_a_window(world, xvfb):
    """A real window on an X server: it opens at reset, paints the frames the env hands it
    (egui/wgpu on software Vulkan or GL), paced to render_fps, closes with the env, and a
    new env opens it again."""
    env = gymnasium.make(
        "playerstage/Stage-v0", world=world, robot="r0", render_mode="human", task=None
    )
    assert env.unwrapped.metadata["render_fps"] == pytest.approx(10.0)  # interval_sim 100 ms
    assert _native.window_state()[0] is False
    _shows_paced_frames_then_closes(env, np.array([0.5, 0.0]))

    again = StageEnv(world, "r0", render_mode="human", task=None)
    again.reset()
    assert _native.window_state()[0], "a new env opens the window again"
    again.close()
    assert _native.window_state()[0] is False

    # make_vec's VectorStageEnv shows copy 0 after its resets and steps
    vec = gymnasium.make_vec(
        "playerstage/Stage-v0", num_envs=2, world=world, robot="r0", render_mode="human",
        task=None,
    )
    vec.reset(seed=1)
    painted = _native.window_state()[1]
    vec.step(np.zeros(vec.action_space.shape))
    assert vec.render() is None and _native.window_state()[0]
    deadline = time.monotonic() + 10
    while _native.window_state()[1] <= painted and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _native.window_state()[1] > painted
    vec.close()
    assert _native.window_state()[0] is False



def test_parallel_env_rgb_array_draws_every_agent(tmp_path):
    """parallel_env's "rgb_array" frame is StageEnv's picture of the same world: the whole
    world, agents and all, and it changes when an agent moves; PettingZoo's API test still
    passes with a render_mode set."""
    path = tmp_path / "two.world"
    # a second robot, green, at the top right
    path.write_text(
        WORLD.format(
            window='position ( name "r1" pose [2 2 0 0] size [0.4 0.4 0.3] color "green" '
            'drive "diff" )'
        )
    )
    env = parallel_env(path, task=None, render_mode="rgb_array")
    assert env.metadata["render_modes"] == ["rgb_array", "human"]
    assert env.metadata["render_fps"] == pytest.approx(10.0)
    env.reset(seed=0)
    img = frame(env)
    assert img.shape == (300, 400, 3) and img.dtype == np.uint8
    lone = StageEnv(path, "r0", task=None, render_mode="rgb_array")
    lone.reset(seed=0)
    assert np.array_equal(frame(lone), img), "the same world draws the same picture"
    green = np.all(img == (0, 255, 0), axis=-1) | (
        (img[..., 1] > 150) & (img[..., 0] < 100) & (img[..., 2] < 100)
    )
    assert green.any(), "r1 (green) is drawn"
    for _ in range(10):
        env.step({"r0": np.array([0.5, 0.5]), "r1": np.array([0.5, -0.5])})
    moved = frame(env)
    assert moved.shape == img.shape and not np.array_equal(moved, img)
    assert parallel_env(path, task=None).render() is None, "no render_mode: nothing rendered"
    with pytest.raises(ValueError, match="render_mode"):
        parallel_env(path, render_mode="ansi")

    import warnings

    from pettingzoo.test import parallel_api_test

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="parallel_env.reset: unknown option")
        parallel_api_test(parallel_env(path, task=None, render_mode="rgb_array"), num_cycles=20)


def test_parallel_env_human_refused_without_display(world, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="needs a display.*rgb_array"):
        parallel_env(world, render_mode="human")


def test_parallel_env_human_mode_shows_the_world(world, xvfb):
    """On an X server: the window opens at reset, paints the frames of the steps, paced to
    render_fps (10 a second here), render() returns None, close() closes it."""
    env = parallel_env(world, task=None, render_mode="human")
    assert _native.window_state()[0] is False
    _shows_paced_frames_then_closes(env, {"r0": np.array([0.5, 0.0])})


def _shows_paced_frames_then_closes(env, action) -> None:
    """A human-mode env (StageEnv or parallel_env, 10 fps): reset opens the window, six steps
    take at least 0.5 s and are painted, render() returns nothing, close() closes it."""
    env.reset(seed=0)
    opened, painted = _native.window_state()
    assert opened, "reset opened the window"
    t0 = time.monotonic()
    for _ in range(6):
        env.step(action)
    elapsed = time.monotonic() - t0
    assert elapsed >= 0.5, f"6 frames at 10 fps took {elapsed:.2f} s"
    assert env.render() is None, "human mode returns nothing"
    deadline = time.monotonic() + 10
    while _native.window_state()[1] < painted + 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _native.window_state()[1] >= painted + 3, "the window painted the frames"
    env.close()
    assert _native.window_state()[0] is False, "close() closed the window"
