#!/usr/bin/env python
# Move things around with the simulation proxy, the Player/Stage manual's way.
import sys
from playerc import *

port = int(sys.argv[1]) if len(sys.argv) > 1 else 6665
c = playerc_client(None, 'localhost', port)
if c.connect():
    raise Exception(playerc_error_str())
sim = playerc_simulation(c, 0)
if sim.subscribe(PLAYERC_OPEN_MODE):
    raise Exception(playerc_error_str())

for i, name in enumerate(["orange1", "orange2", "carton1"]):
    result, x, y, a = sim.get_pose2d(name)
    if result != 0:
        raise Exception(playerc_error_str())
    print("%s was at %.2f %.2f %.2f" % (name, x, y, a))
    sim.set_pose2d(name, -7.0 + 0.5 * i, -7.4, 0.0)
    result, x, y, a = sim.get_pose2d(name)
    print("%s now at %.2f %.2f %.2f" % (name, x, y, a))

sim.unsubscribe()
c.disconnect()
