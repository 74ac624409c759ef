"""Worlds in forked children: a process that stepped a world forks (``os.fork``, a
``multiprocessing`` pool started with ``fork``, as Gymnasium's ``AsyncVectorEnv`` and
Stable-Baselines3's ``SubprocVecEnv`` do on Linux), and the children load and step worlds, their
own and inherited ones, with the results a single process gets. Each child runs under a timeout,
so a regression (the child waiting forever on the parent's worker threads) fails, not hangs.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import struct
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import BIGBOB, boxes_world, leaves
from playerstage import World


# A child does its work in well under a second; this only bounds a hang.
CHILD_TIMEOUT = 60.0


def crowd_world(directory: Path, threads: int) -> Path:
    """A room of 36 wandering robots with 181-ray lasers and ``threads`` worker threads: enough
    rays and controllers that a step takes the engine's parallel paths."""
    lines = [
        "resolution 0.02",
        "interval_sim 100",
        f"threads {threads}",
        "define bot position (",
        "  size [0.4 0.4 0.3]",
        '  drive "diff"',
        '  ctrl "wander"',
        "  ranger ( sensor ( range [0 4] fov 180 samples 181 ) )",
        ")",
    ]
    for name, x, y, sx, sy in [
        ("north", 0, 5, 10.2, 0.2),
        ("south", 0, -5, 10.2, 0.2),
        ("east", 5, 0, 0.2, 10.2),
        ("west", -5, 0, 0.2, 10.2),
    ]:
        lines.append(f'model ( name "{name}" size [{sx} {sy} 1] pose [{x} {y} 0 0] )')
    for i in range(36):
        x, y = (i % 6) * 1.4 - 3.5, (i // 6) * 1.4 - 3.5
        lines.append(f'bot ( name "r{i}" pose [{x:.2f} {y:.2f} 0 {i * 37 % 360}] )')
    path = directory / f"crowd{threads}.world"
    path.write_text("\n".join(lines) + "\n")
    return path


def run_in_forked_child(work) -> list[int]:
    """Forks; the child calls ``work()`` (a list of digests) and sends the result back. Fails the
    test when the child hangs past ``CHILD_TIMEOUT`` (it is killed) or fails."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:
        code = 0
        try:
            os.close(read_end)
            values = work()
            os.write(write_end, struct.pack(f"<{len(values)}Q", *values))
        except BaseException:  # noqa: BLE001 - anything at all: report it by exit code
            code = 1
        finally:
            os._exit(code)
    os.close(write_end)
    deadline = time.monotonic() + CHILD_TIMEOUT
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done == pid:
            break
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            os.close(read_end)
            pytest.fail(f"the forked child hung for {CHILD_TIMEOUT} s")
        time.sleep(0.02)
    data = b""
    while chunk := os.read(read_end, 4096):
        data += chunk
    os.close(read_end)
    assert os.waitstatus_to_exitcode(status) == 0, "the forked child failed"
    return list(struct.unpack(f"<{len(data) // 8}Q", data))


def stepped(path: Path, seed: int, steps: int) -> int:
    """The digest of a fresh world after ``steps`` steps."""
    world = World(path, seed=seed)
    world.step(steps)
    return world.digest()


@pytest.fixture(params=[1, 2], ids=["threads1", "threads2"])
def world_path(request, tmp_path: Path) -> Path:
    return crowd_world(tmp_path, request.param)


def test_the_issue_sequence_completes() -> None:
    """The issue's own sequence on the Bigbob world: the parent steps, the child loads and
    steps a new world."""
    w = World(BIGBOB, seed=0)
    w.step(5)
    got = run_in_forked_child(lambda: [stepped(BIGBOB, 0, 5)])
    assert got == [w.digest()]


def test_child_steps_new_and_inherited_worlds_as_the_parent_does(world_path: Path) -> None:
    """A world made before the fork, stepped on in the child, ends where the parent's copy
    does; a world loaded in the child matches a single process's run."""
    w = World(world_path, seed=4)
    w.step(10)

    def child() -> list[int]:
        w.step(20)
        return [w.digest(), stepped(world_path, 4, 30)]

    got = run_in_forked_child(child)
    w.step(20)
    assert got == [w.digest(), w.digest()]


def _pool_task(job: tuple[str, int]) -> int:
    path, seed = job
    return stepped(Path(path), seed, 25)


def test_fork_pool_after_the_parent_stepped(world_path: Path) -> None:
    """A ``multiprocessing`` pool started with ``fork`` after the parent stepped a world: every
    task completes, with the digests of runs in this process."""
    stepped(world_path, 1, 5)
    jobs = [(str(world_path), seed) for seed in (1, 2, 3, 4)]
    expected = [_pool_task(job) for job in jobs]
    pool = multiprocessing.get_context("fork").Pool(2)
    try:
        got = pool.map_async(_pool_task, jobs).get(timeout=CHILD_TIMEOUT)
    except multiprocessing.TimeoutError:
        pytest.fail(f"the fork pool's tasks hung for {CHILD_TIMEOUT} s")
    finally:
        pool.terminate()
        pool.join()
    assert got == expected
    assert len(set(expected)) == len(expected), "different seeds, different runs"


def test_connection_inherited_by_a_forked_child_says_so(server) -> None:
    """A Player connection cannot be shared with a forked child (one socket, two readers): the
    child gets ``ConnectionLost`` naming spawn/forkserver, the parent's connection still works,
    and the child can open its own."""
    from playerstage import Client, ConnectionLost

    with Client("localhost", server.port) as client:
        # (a PULL round ends once it has delivered data: subscribe to something first)
        base = client.position2d(0)
        client.read()

        def child() -> list[int]:
            try:
                client.read()
            except ConnectionLost as e:
                said = str(e)
                if "forked child" not in said or "spawn" not in said:
                    return [2]
            else:
                return [1]
            with Client("localhost", server.port) as own:
                own.position2d(0)
                own.read()
            return [0]

        assert run_in_forked_child(child) == [0]
        client.read()
        assert base.odometry is not None


def _digest_task(world, robot) -> tuple:
    """A task that reports the world's digest (as text: it is a 64-bit unsigned number)."""
    return 0.0, False, {"digest": format(world.digest(), "016x")}


def _vector_trace(vec, steps: int = 12) -> list:
    """Resets ``vec`` with a seed and steps it with fixed actions (each wait bounded); every
    step's observations, rewards and world digests."""
    bounded = hasattr(vec, "step_wait")  # AsyncVectorEnv: waits with a timeout
    if bounded:
        vec.reset_async(seed=5)
        vec.reset_wait(timeout=CHILD_TIMEOUT)
    else:
        vec.reset(seed=5)
    rng = np.random.default_rng(11)
    low, high = vec.single_action_space.low, vec.single_action_space.high
    trace = []
    for _ in range(steps):
        actions = rng.uniform(low, high, size=(vec.num_envs, len(low)))
        if bounded:
            vec.step_async(actions)
            obs, reward, _, _, info = vec.step_wait(timeout=CHILD_TIMEOUT)
        else:
            obs, reward, _, _, info = vec.step(actions)
        trace.append((leaves(obs), list(reward), list(info["digest"])))
    return trace


def test_async_vector_env_with_fork_after_the_parent_stepped(tmp_path: Path) -> None:
    """Gymnasium's ``AsyncVectorEnv`` with ``context="fork"`` over ``StageEnv``, started after
    the parent stepped a world: its workers step, and every step's observations, rewards and
    digests equal a ``SyncVectorEnv``'s in this process."""
    pytest.importorskip("gymnasium")
    from gymnasium.vector import AsyncVectorEnv, SyncVectorEnv

    from playerstage.envs import StageEnv

    world = boxes_world(tmp_path)
    stepped(world, 0, 5)

    def make():
        return StageEnv(world, "r0", random_start=True, task=_digest_task)

    sync = SyncVectorEnv([make] * 3)
    expected = _vector_trace(sync)
    sync.close()
    forked = AsyncVectorEnv([make] * 3, context="fork")
    try:
        got = _vector_trace(forked)
    except multiprocessing.TimeoutError:
        pytest.fail(f"the forked workers hung for {CHILD_TIMEOUT} s")
    finally:
        forked.close(terminate=True)
    assert len(got) == len(expected)
    for (obs_a, rew_a, dig_a), (obs_b, rew_b, dig_b) in zip(got, expected):
        assert dig_a == dig_b and rew_a == rew_b
        assert all(np.array_equal(a, b) for a, b in zip(obs_a, obs_b))
    assert len({d for _, _, digests in expected for d in digests}) > 3, "the worlds move"


def test_render_in_a_child_forked_after_the_parent_rendered(tmp_path: Path) -> None:
    """The offscreen renderer is per process: a child forked after the parent rendered (its
    device's driver threads are not in the child) opens its own and draws the same image."""
    from playerstage.envs import StageEnv

    from test_render import frame

    env = StageEnv(boxes_world(tmp_path), "r0", render_mode="rgb_array")
    env.reset(seed=0)
    image = frame(env)

    def child() -> list[int]:
        again = StageEnv(boxes_world(tmp_path), "r0", render_mode="rgb_array")
        again.reset(seed=0)
        fresh, inherited = again.render(), env.render()
        return [int(np.array_equal(fresh, image)), int(np.array_equal(inherited, image))]

    assert run_in_forked_child(child) == [1, 1]
    assert np.array_equal(frame(env), image)
