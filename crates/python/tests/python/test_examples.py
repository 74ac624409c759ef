"""examples/python: the manual's Bigbob controller, with playerc and with the Pythonic layer,
collects an orange from the Bigbob world (worlds/bigbob.cfg)."""

import pytest
from conftest import EXAMPLES, run_script, start_player

BIGBOB_CFG = (EXAMPLES.parents[1] / "worlds" / "bigbob.cfg").read_text()


@pytest.mark.parametrize("script", ["bigbob_playerc.py", "bigbob_pythonic.py"])
def test_bigbob_collects_an_orange(player_bin, world_dir, script):
    server = start_player(player_bin, world_dir, "bigbob.cfg", BIGBOB_CFG, ["--speedup", "8"])
    try:
        out = run_script(EXAMPLES / script, "--port", server.port, "--collect", 1,
                         "--iterations", 3000)
    finally:
        server.stop()
    assert "bigbob: connected to localhost:" in out and "4 sonars" in out
    assert "bigbob: collected orange" in out, out
    assert "1 collected" in out, out


def test_bench_runs(player_bin):
    """The benchmark script (figures in the package README) runs and prints every figure."""
    out = run_script(EXAMPLES.parents[1] / "crates" / "python" / "bench" / "bench.py",
                     "--player", player_bin, "--seconds", 0.3)
    assert "request round trips/s" in out
    assert "data messages/s read by read()" in out
    assert "PULL rounds/s" in out
