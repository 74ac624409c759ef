#!/usr/bin/env python
# List the server's devices, then read a few rounds of each, as Player's binding tests did.
import sys
from playerc import *


def test_position2d(client, index):
    position2d = playerc_position2d(client, index)
    if position2d.subscribe(PLAYERC_OPEN_MODE) != 0:
        raise Exception(playerc_error_str())
    for i in range(5):
        while 1:
            id = client.read()
            if id == None:
                raise Exception(playerc_error_str())
            if id == position2d.info.id:
                break
        print("position2d: [%14.3f] [%6.3f %6.3f %6.3f]" % (
            position2d.info.datatime, position2d.px, position2d.py, position2d.pa))
    position2d.unsubscribe()


def test_laser(client, index):
    laser = playerc_laser(client, index)
    if laser.subscribe(PLAYERC_OPEN_MODE) != 0:
        raise Exception(playerc_error_str())
    for i in range(5):
        while 1:
            id = client.read()
            if id == None:
                raise Exception(playerc_error_str())
            if id == laser.info.id:
                break
        line = "laser: [%14.3f] [%d]" % (laser.info.datatime, laser.scan_count)
        for j in range(3):
            line += " [%06.3f, %06.3f]" % (laser.scan[j][0], laser.scan[j][1])
        print(line)
    laser.unsubscribe()


def main(port):
    c = playerc_client(None, 'localhost', port)
    if c.connect() != 0:
        raise Exception(playerc_error_str())
    if c.get_devlist() != 0:
        raise Exception(playerc_error_str())
    print('-' * 70)
    for i in range(0, c.devinfo_count):
        devinfo = c.devinfos[i]
        print('%d:%s:%d %20s' % (devinfo.addr.robot, playerc_lookup_name(devinfo.addr.interf),
                                 devinfo.addr.index, devinfo.drivername))
    print('-' * 70)
    if c.datamode(PLAYER_DATAMODE_PUSH) != 0:
        raise Exception(playerc_error_str())
    test_position2d(c, 0)
    test_laser(c, 0)
    c.disconnect()


if __name__ == '__main__':
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 6665)
