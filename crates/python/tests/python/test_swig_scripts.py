"""SWIG-era scripts (see swig_scripts/README.md) run unmodified against a real `player`."""

import re
from pathlib import Path

from conftest import run_script

SCRIPTS = Path(__file__).parent / "swig_scripts"


def test_playerc_wanderer_moves(fresh_server):
    out = run_script(SCRIPTS / "wander_ranger.py", fresh_server.port)
    assert "ranger has 4 elements" in out
    moved = float(re.search(r"moved ([\d.]+) m", out).group(1))
    assert moved > 0.3, out


def test_player_binding_test_style_script(server):
    out = run_script(SCRIPTS / "device_test.py", server.port)
    assert "position2d:0" in out and "stage" in out
    assert out.count("position2d: [") == 5
    assert out.count("laser: [") == 5
    assert "[180]" in out


def test_playercpp_blob_follower(fresh_server):
    out = run_script(SCRIPTS / "cpp_blob_follower.py", fresh_server.port)
    m = re.search(r"saw blobs in (\d+) reads; bob1 moved from \(([-\d.]+), ([-\d.]+)\) to "
                  r"\(([-\d.]+), ([-\d.]+)\)", out)
    assert m, out
    seen, x0, y0, x1, y1 = int(m.group(1)), *map(float, m.groups()[1:])
    assert seen > 0
    assert abs(x1 - x0) + abs(y1 - y0) > 0.1, out


def test_simulation_teleport_script(fresh_server):
    out = run_script(SCRIPTS / "sim_teleport.py", fresh_server.port)
    assert "orange1 was at -3.00 -3.50 0.00" in out
    assert "orange1 now at -7.00 -7.40 0.00" in out
    assert "carton1 now at -6.00 -7.40 0.00" in out
