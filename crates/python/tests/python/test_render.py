"""`StageEnv.render()` in ``"rgb_array"`` mode: the viewer's offscreen renderer, headless (Mesa's
software Vulkan in CI). Without any graphics adapter the tests skip, unless
PLAYERSTAGE_REQUIRE_GPU=1 makes that a failure (as the viewer's own render tests do)."""

import os

import numpy as np
import pytest

from playerstage.envs import StageEnv

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


def test_render_modes_and_refusals(world):
    assert StageEnv.metadata["render_modes"] == ["rgb_array"]
    assert StageEnv(world, "r0").render() is None, "no render_mode: nothing rendered"
    with pytest.raises(ValueError, match="human"):
        StageEnv(world, "r0", render_mode="human")
    with pytest.raises(ValueError, match="render_mode"):
        StageEnv(world, "r0", render_mode="ansi")

