#!/usr/bin/env python3
"""The Player/Stage manual's rubbish-collecting Bigbob, on the drop-in `playerc` module.

Bigbob wanders, keeps off things with its four sonars, turns towards the biggest blob its
blobfinder sees, and when its tooth laser says something sits between its teeth it "collects"
it: the nearest orange or carton is moved to the bin with the simulation proxy. The same
controller as examples/bigbob.rs (Rust) and examples/bigbob/bigbob.cc (libplayerc++);
bigbob_pythonic.py is the same again on the Pythonic `playerstage.Client`.

    player worlds/bigbob.cfg &
    python3 examples/python/bigbob_playerc.py [--host H] [--port P] [--iterations N]
                                              [--collect N] [--robot NAME]
"""

import argparse
import math
import sys

from playerc import *  # noqa: F401,F403 - the SWIG bindings' way

AVOID_RANGE = 0.6  # closer than this on a front sonar (m): turn away
CRUISE = 0.3  # m/s
TURN = 0.6  # rad/s
CAUGHT_RANGE = 0.2  # a tooth-laser range below this: something is between the teeth
THINGS = ["orange%d" % i for i in range(1, 7)] + ["carton%d" % i for i in range(1, 5)]


def steer(sonar, eyes):
    """(speed, turn, avoiding) from the sonars and the blobs."""
    if sonar.ranges_count >= 4:
        fl, fr, l, r = sonar.ranges[0:4]
        left, right = min(fl, l), min(fr, r)
        if left < AVOID_RANGE or right < AVOID_RANGE:
            return 0.0, (-TURN if left < right else TURN), True
    if eyes.blobs_count > 0 and eyes.width > 0:
        biggest = max(eyes.blobs, key=lambda b: b.right - b.left)
        return CRUISE * 0.5, 0.01 * (eyes.width / 2.0 - biggest.x), False
    return CRUISE, 0.2, False


def collect(sim, robot, collected):
    """Moves the thing nearest to the point 1 m ahead of the robot into the bin."""
    result, rx, ry, ra = sim.get_pose2d(robot)
    if result != 0:
        raise RuntimeError(playerc_error_str())
    tx, ty = rx + math.cos(ra), ry + math.sin(ra)
    nearest, best = None, 1.0
    for name in THINGS:
        result, x, y, _ = sim.get_pose2d(name)
        if result == 0 and math.hypot(x - tx, y - ty) < best:
            nearest, best = name, math.hypot(x - tx, y - ty)
    if nearest is not None:
        sim.set_pose2d(nearest, -7.0 + 0.4 * collected, -7.4, 0.0)
    return nearest


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--host", default="localhost")
    ap.add_argument("--port", type=int, default=6665)
    ap.add_argument("--iterations", type=int, default=None, help="stop after N reads")
    ap.add_argument("--collect", type=int, default=None, help="stop after collecting N things")
    ap.add_argument("--robot", default="bob1")
    o = ap.parse_args()

    client = playerc_client(None, o.host, o.port)
    if client.connect() != 0:
        sys.exit("bigbob: " + playerc_error_str())
    base = playerc_position2d(client, 0)
    sonar = playerc_ranger(client, 0)
    eyes = playerc_blobfinder(client, 0)
    laser = playerc_ranger(client, 1)
    sim = playerc_simulation(client, 0)
    for proxy in (base, sonar, eyes, laser, sim):
        if proxy.subscribe(PLAYERC_OPEN_MODE) != 0:
            sys.exit("bigbob: " + playerc_error_str())
    base.enable(1)
    if sonar.get_geom() != 0:
        sys.exit("bigbob: " + playerc_error_str())
    print("bigbob: connected to %s:%d, %d sonars" % (o.host, o.port, sonar.element_count))

    collected = avoided = saw_blobs = 0
    i = 0
    while o.iterations is None or i < o.iterations:
        i += 1
        if client.read() is None:
            sys.exit("bigbob: " + playerc_error_str())
        speed, turn, avoiding = steer(sonar, eyes)
        avoided += avoiding
        saw_blobs += eyes.blobs_count > 0
        if any(r < CAUGHT_RANGE for r in laser.ranges):
            name = collect(sim, o.robot, collected)
            if name is not None:
                collected += 1
                print("bigbob: collected %s" % name, flush=True)
                if o.collect is not None and collected >= o.collect:
                    break
        base.set_cmd_vel(speed, 0.0, turn, 1)
    base.set_cmd_vel(0.0, 0.0, 0.0, 1)
    print("bigbob: pose %.2f %.2f %.2f, %d reads with blobs, %d avoiding, %d collected"
          % (base.px, base.py, base.pa, saw_blobs, avoided, collected))
    client.disconnect()


if __name__ == "__main__":
    main()
