#!/usr/bin/env python
# Close and open bob2's gripper, then tidy up as the SWIG-era examples did: unsubscribe and
# destroy() each proxy, then disconnect and destroy() the client.
import sys
from playerc import *


def wait_for_state(client, gripper, state):
    while gripper.state != state:
        if client.read() == None:
            raise Exception(playerc_error_str())


def main(port):
    c = playerc_client(None, 'localhost', port)
    if c.connect() != 0:
        raise Exception(playerc_error_str())
    g = playerc_gripper(c, 0)
    if g.subscribe(PLAYERC_OPEN_MODE) != 0:
        raise Exception(playerc_error_str())
    if g.get_geom() != 0:
        raise Exception(playerc_error_str())
    print("gripper with %d beams, capacity %d" % (g.num_beams, g.capacity))
    g.close_cmd()
    wait_for_state(c, g, PLAYER_GRIPPER_STATE_CLOSED)
    print("closed")
    g.open_cmd()
    wait_for_state(c, g, PLAYER_GRIPPER_STATE_OPEN)
    print("opened")
    g.unsubscribe()
    g.destroy()
    c.disconnect()
    c.destroy()
    print("done")


if __name__ == '__main__':
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 6665)
