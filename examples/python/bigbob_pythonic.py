#!/usr/bin/env python3
"""The Player/Stage manual's rubbish-collecting Bigbob, on the Pythonic `playerstage.Client`.

The same controller as bigbob_playerc.py (see there), with context managers, typed data
and exceptions instead of return codes.

    player worlds/bigbob.cfg &
    python3 examples/python/bigbob_pythonic.py [--host H] [--port P] [--iterations N]
                                               [--collect N] [--robot NAME]
"""

import argparse
import math
import sys

import playerstage

AVOID_RANGE = 0.6
CRUISE = 0.3
TURN = 0.6
CAUGHT_RANGE = 0.2
THINGS = [f"orange{i}" for i in range(1, 7)] + [f"carton{i}" for i in range(1, 5)]


def steer(sonar_ranges, frame):
    """(speed, turn, avoiding) from the sonar ranges and the blobfinder frame."""
    if len(sonar_ranges) >= 4:
        fl, fr, l, r = sonar_ranges[:4]
        left, right = min(fl, l), min(fr, r)
        if left < AVOID_RANGE or right < AVOID_RANGE:
            return 0.0, (-TURN if left < right else TURN), True
    if frame.blobs and frame.width > 0:
        biggest = max(frame.blobs, key=lambda b: b.right - b.left)
        return CRUISE * 0.5, 0.01 * (frame.width / 2 - biggest.x), False
    return CRUISE, 0.2, False


def collect(sim, robot, collected):
    """Moves the thing nearest to the point 1 m ahead of the robot into the bin."""
    r = sim.get_pose(robot)
    tx, ty = r.x + math.cos(r.yaw), r.y + math.sin(r.yaw)
    poses = {name: sim.get_pose(name) for name in THINGS}
    name, pose = min(poses.items(), key=lambda kv: math.hypot(kv[1].x - tx, kv[1].y - ty))
    if math.hypot(pose.x - tx, pose.y - ty) >= 1.0:
        return None
    sim.set_pose(name, -7.0 + 0.4 * collected, -7.4, 0.0)
    return name


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--host", default="localhost")
    ap.add_argument("--port", type=int, default=playerstage.DEFAULT_PORT)
    ap.add_argument("--iterations", type=int, default=None)
    ap.add_argument("--collect", type=int, default=None)
    ap.add_argument("--robot", default="bob1")
    o = ap.parse_args()

    try:
        with playerstage.Client(o.host, o.port) as client:
            base = client.position2d(0)
            sonar = client.ranger(0)
            eyes = client.blobfinder(0)
            laser = client.ranger(1)
            sim = client.simulation(0)
            base.enable_motors()
            n = len(sonar.geometry()["element_poses"])
            print(f"bigbob: connected to {o.host}:{o.port}, {n} sonars")
            collected = avoided = saw_blobs = 0
            i = 0
            while o.iterations is None or i < o.iterations:
                i += 1
                client.read()
                frame = eyes.frame
                speed, turn, avoiding = steer(list(sonar.ranges), frame)
                avoided += avoiding
                saw_blobs += bool(frame.blobs)
                if len(laser.ranges) and min(laser.ranges) < CAUGHT_RANGE:
                    name = collect(sim, o.robot, collected)
                    if name is not None:
                        collected += 1
                        print(f"bigbob: collected {name}", flush=True)
                        if o.collect is not None and collected >= o.collect:
                            break
                base.set_velocity(speed, 0.0, turn)
            base.stop()
            p = base.odometry
            print(f"bigbob: pose {p.x:.2f} {p.y:.2f} {p.yaw:.2f}, {saw_blobs} reads with blobs, "
                  f"{avoided} avoiding, {collected} collected")
    except playerstage.PlayerError as e:
        sys.exit(f"bigbob: {e}")


if __name__ == "__main__":
    main()
