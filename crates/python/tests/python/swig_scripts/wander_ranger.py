#!/usr/bin/env python
# Wander around, keeping away from walls with the sonar ranger (playerc style).
import sys
import math
from playerc import *

port = int(sys.argv[1]) if len(sys.argv) > 1 else 6665

c = playerc_client(None, 'localhost', port)
if c.connect() != 0:
    raise Exception(playerc_error_str())

p = playerc_position2d(c, 0)
if p.subscribe(PLAYERC_OPEN_MODE) != 0:
    raise Exception(playerc_error_str())

r = playerc_ranger(c, 0)
if r.subscribe(PLAYERC_OPEN_MODE) != 0:
    raise Exception(playerc_error_str())

if r.get_geom() != 0:
    raise Exception(playerc_error_str())
print("ranger has %d elements" % r.element_count)

start_x, start_y = None, None
for i in range(150):
    if c.read() == None:
        raise Exception(playerc_error_str())
    if start_x is None:
        start_x, start_y = p.px, p.py
    if r.ranges_count < 4:
        continue
    left = min(r.ranges[0], r.ranges[2])
    right = min(r.ranges[1], r.ranges[3])
    if left < 0.6 or right < 0.6:
        if left < right:
            turn = -0.6
        else:
            turn = 0.6
        p.set_cmd_vel(0.0, 0.0, turn, 1)
    else:
        p.set_cmd_vel(0.4, 0.0, 0.1, 1)

p.set_cmd_vel(0.0, 0.0, 0.0, 1)
print("moved %.2f m" % math.hypot(p.px - start_x, p.py - start_y))
p.unsubscribe()
r.unsubscribe()
c.disconnect()
