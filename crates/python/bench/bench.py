#!/usr/bin/env python3
"""Benchmarks of the Python package, printed as one line each:

- request round trips per second from Python (`playerc_simulation.get_pose2d`, one request and
  its ACK each) against a `player` serving worlds/bigbob.cfg;
- data messages per second read by `playerc_client.read()` in PUSH mode (one DATA message per
  read) from the same server running `--fast`, and PULL rounds per second;
- in-process `playerstage.World` steps per second on Stage's simple.world.

    python3 crates/python/bench/bench.py --player target/release/player \
        [--world ../shared/stage-worlds/simple.world] [--seconds 3]
"""

import argparse
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_player(player, args):
    port = free_port()
    proc = subprocess.Popen(
        [str(player), "-p", str(port), *args, str(REPO / "worlds" / "bigbob.cfg")],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    for line in proc.stdout:
        if "Listening on ports" in line:
            return proc, port
    proc.wait()
    sys.exit("player did not start")


def stop(proc):
    proc.send_signal(signal.SIGKILL)
    proc.wait()


def bench_requests(player, seconds):
    from playerc import PLAYERC_OPEN_MODE, playerc_client, playerc_simulation

    proc, port = start_player(player, [])
    try:
        c = playerc_client(None, "localhost", port)
        assert c.connect() == 0
        sim = playerc_simulation(c, 0)
        assert sim.subscribe(PLAYERC_OPEN_MODE) == 0
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            for _ in range(100):
                assert sim.get_pose2d("bob1")[0] == 0
            n += 100
        rate = n / (time.perf_counter() - t0)
        c.disconnect()
    finally:
        stop(proc)
    return rate


def bench_reads(player, seconds):
    from playerc import (
        PLAYER_DATAMODE_PUSH,
        PLAYERC_OPEN_MODE,
        playerc_blobfinder,
        playerc_client,
        playerc_position2d,
        playerc_ranger,
    )

    proc, port = start_player(player, ["--fast"])
    try:
        c = playerc_client(None, "localhost", port)
        assert c.connect() == 0
        for proxy in (playerc_position2d(c, 0), playerc_ranger(c, 0), playerc_ranger(c, 1),
                      playerc_blobfinder(c, 0)):
            assert proxy.subscribe(PLAYERC_OPEN_MODE) == 0
        # PULL: one round (the latest of every device) per read.
        pull = reads_per_second(c, seconds)
        # PUSH: every DATA message as published, one per read.
        assert c.datamode(PLAYER_DATAMODE_PUSH) == 0
        push = reads_per_second(c, seconds)
        c.disconnect()
    finally:
        stop(proc)
    return push, pull


def reads_per_second(client, seconds):
    """How many ``client.read()`` calls return a message per second, over ``seconds``."""
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        assert client.read() is not None
        n += 1
    return n / (time.perf_counter() - t0)


def bench_world(world, seconds):
    import playerstage

    w = playerstage.World(world, seed=1)
    w.quit_time = 0  # simple.world stops at one simulated hour; a benchmark may go past it
    w.step(10)
    n, t0 = 0, time.perf_counter()
    s0 = w.steps
    while time.perf_counter() - t0 < seconds:
        assert w.step(100)
    n = w.steps - s0
    batched = n / (time.perf_counter() - t0)
    n, t0 = 0, time.perf_counter()
    robots = w.models("position")
    rangers = w.models("ranger")
    while time.perf_counter() - t0 < seconds:
        for r in robots:
            w.set_velocity(r, 0.3, 0.0, 0.1)
        w.step()
        for r in rangers:
            w.ranger(r)
        n += 1
    loop = n / (time.perf_counter() - t0)
    return batched, loop


def main():
    ap = argparse.ArgumentParser(description="Python package benchmarks")
    ap.add_argument("--player", required=True, help="the `player` binary")
    ap.add_argument("--world", default=str(REPO.parent / "shared" / "stage-worlds" / "simple.world"))
    ap.add_argument("--seconds", type=float, default=3.0)
    o = ap.parse_args()
    print(f"request round trips/s (simulation GET_POSE2D): {bench_requests(o.player, o.seconds):,.0f}")
    push, pull = bench_reads(o.player, o.seconds)
    print(f"data messages/s read by read() (PUSH, server --fast): {push:,.0f}")
    print(f"PULL rounds/s read by read() (4 devices, server --fast): {pull:,.0f}")
    if os.path.isfile(o.world):
        batched, loop = bench_world(o.world, o.seconds)
        print(f"World steps/s on {Path(o.world).name}: {batched:,.0f} (step(100)), "
              f"{loop:,.0f} (step() + commands + every ranger read each step)")
    else:
        print(f"World: {o.world} not found, skipped")


if __name__ == "__main__":
    main()
