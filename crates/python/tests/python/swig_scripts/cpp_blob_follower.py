#!/usr/bin/env python
# Turn towards the biggest blob and drive to it, with libplayerc++'s Python bindings.
import sys
from playercpp import *

port = int(sys.argv[1]) if len(sys.argv) > 1 else 6665
robot = PlayerClient("localhost", port)
pp = Position2dProxy(robot, 0)
sonar = RangerProxy(robot, 0)
blobs = BlobfinderProxy(robot, 0)
sim = SimulationProxy(robot, 0)

x0, y0, a0 = sim.GetPose2d("bob1")
seen = 0
for i in range(120):
    robot.Read()
    if blobs.GetCount() > 0:
        seen += 1
        biggest = blobs.GetBlob(0)
        for j in range(blobs.GetCount()):
            b = blobs.GetBlob(j)
            if (b.right - b.left) > (biggest.right - biggest.left):
                biggest = b
        centre = blobs.GetWidth() / 2.0
        turn = 0.01 * (centre - biggest.x)
        pp.SetSpeed(0.2, turn)
    else:
        pp.SetSpeed(0.0, 0.4)
    if sonar.GetRangeCount() >= 2 and min(sonar.GetRange(0), sonar.GetRange(1)) < 0.4:
        pp.SetSpeed(0.0, 0.0)
        break

pp.SetSpeed(0.0, 0.0)
x1, y1, a1 = sim.GetPose2d("bob1")
print("saw blobs in %d reads; bob1 moved from (%.2f, %.2f) to (%.2f, %.2f)" % (seen, x0, y0, x1, y1))
