#!/usr/bin/env python3
"""Writes the fuzz targets' seed inputs into fuzz/seeds/<target>/ (not committed: the committed
corpora in fuzz/corpus/ were grown from them and minimised with `cargo fuzz cmin`).

Sources: the repository's worlds and bitmaps, Stage's own worlds, cfgs and bitmaps in
../shared/stage-worlds, the recorded sessions and XDR vectors in ../shared/conformance, and the
log lines upstream's writelog wrote (from the log format's tests), and ROS 2 commands (cmd_vel,
cmd_pose, reset_positions requests) as ROS 2 writers encode them. Missing sources are skipped.
"""

import json
import math
import re
import struct
import sys
from pathlib import Path

FUZZ = Path(__file__).resolve().parent
REPO = FUZZ.parent
SHARED = REPO.parent / "shared"
OUT = FUZZ / "seeds"
SEP = b"\n%%file "


def put(target, name, data):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data)


def tree(top: Path, seen=None):
    """A top-level file with its includes appended as named parts (fuzz/src/lib.rs write_tree)."""
    text = top.read_bytes().replace(b'"../bitmaps/', b'"bitmaps/')
    parts = [text]
    seen = seen if seen is not None else set()
    for name in re.findall(rb'^\s*include\s+"([^"]+)"', text, re.M):
        inc = top.parent / name.decode()
        if name in seen or not inc.is_file():
            continue
        seen.add(name)
        sub = tree(inc, seen)
        parts.append(name + b"\n" + sub)
    return SEP.join(parts)


def worlds():
    dirs = [REPO / "worlds", SHARED / "stage-worlds", SHARED / "conformance/sessions/world"]
    for d in dirs:
        if not d.is_dir():
            continue
        for f in sorted(d.glob("*.world")):
            put("worldfile", f"{d.name}-{f.name}", tree(f))
        for f in sorted(d.glob("*.inc")):
            put("worldfile", f"{d.name}-{f.name}", tree(f))
        for f in sorted(d.glob("*.cfg")):
            put("cfg", f"{d.name}-{f.name}", tree(f))


def header(interf, index, mtype, subtype, size, host=0, robot=0, ts=0.0, seq=0):
    # XDR widens the 16-bit interface and index to 4 bytes: 40 bytes in all
    return struct.pack(">IIIIIIdII", host, robot, interf, index, mtype, subtype, ts, seq, size)


def wire():
    sess = SHARED / "conformance/sessions"
    for f in sorted(sess.glob("*.json")):
        s = json.loads(f.read_text())
        c2s = b"".join(
            bytes.fromhex(m["header_hex"]) + bytes.fromhex(m.get("body_hex") or "")
            for m in s["messages"]
            if m["dir"] == "c2s"
        )
        s2c = b"".join(
            bytes.fromhex(m["header_hex"]) + bytes.fromhex(m.get("body_hex") or "")
            for m in s["messages"]
            if m["dir"] == "s2c"
        )
        # first byte: the chunk size the target feeds the framer with
        put("wire_server", f"session-{f.stem}", bytes([7]) + c2s)
        put("wire_client", f"session-{f.stem}", s2c[:200_000])
    xdr = SHARED / "conformance/xdr"
    for f in sorted(xdr.glob("*.json")):
        vectors = json.loads(f.read_text())
        if not isinstance(vectors, list):
            continue
        for v in vectors:
            if "body_hex" not in v or "interface_code" not in v:
                continue
            body = bytes.fromhex(v["body_hex"])
            h = header(v["interface_code"], 0, v["msg_type"], v["subtype"], len(body))
            put("wire_server", f"xdr-{v['id']}", bytes([63]) + h + body)


UPSTREAM_LOG = [
    "0000000000.100 16777343 7001 position2d 00 004 001 -00.040 +00.000 +0.000 +00.440 +00.380",
    "0000000000.300 16777343 7001 ranger 00 004 005 -0.130900 0.130900 0.261799 0.000000 5.000000 0.020000 10.000000 ",
    "0000000000.400 16777343 7001 ranger 01 004 001 +00.000 +00.000 +00.000 +00.000 +00.000 +00.000 +00.155 +00.156 +00.000 0001 +00.000 +00.000 +00.100 +00.000 +00.000 +00.000 0001 +00.020 +00.020 +00.020 ",
    "0000000016.500 16777343 7001 position2d 00 001 001 -02.077 -04.546 -0.065 +00.050 +00.000 -00.500 0",
    "0000000016.500 16777343 7001 ranger 00 001 001 0016 5.000 1.081 0.828 5.000 5.000 5.000 3.986 3.338 3.364 4.871 5.000 5.000 5.000 1.928 2.864 5.000 ",
    "0000000016.500 16777343 7001 ranger 00 001 003 0016 0.000 0.500 0.500 0.000 0.000 0.000 0.500 0.500 0.500 0.500 0.000 0.000 0.000 0.500 0.500 0.000 ",
    "0000000001.000 16777343 7001 camera 00 001 001 2 1 8 1 0 2 00ff",
    "0000000002.000 16777343 7001 laser 00 001 001 0000 -1.5708 +1.5708 0.01745 8.000 0003 1.000 0 2.000 0 3.000 1",
    "0000000003.000 16777343 7001 sonar 00 001 001 0002 1.000 2.000",
    "0000000004.000 16777343 7001 fiducial 00 001 001 0001 0007 +01.000 +02.000 +00.000 +00.000 +00.000 +00.500 +00.000 +00.000 +00.000 +00.000 +00.000 +00.000",
    "0000000005.000 16777343 7001 blobfinder 00 001 001 0080 0060 0001 0 16711680 20 40 30 10 50 30 50 1.500",
]


def logs():
    header = b"".join(
        l.encode() + b"\n"
        for l in [
            "## Player version 3.0.2 ",
            "## File version 0.3.0 ",
        ]
    )
    put("readlog", "upstream-all", header + "\n".join(UPSTREAM_LOG).encode() + b"\n")
    for i, line in enumerate(UPSTREAM_LOG):
        put("readlog", f"line-{i}", line.encode() + b"\n")


def bitmaps():
    for d in [REPO / "bitmaps", SHARED / "stage-worlds/bitmaps"]:
        for f in sorted(d.glob("*.png")) if d.is_dir() else []:
            if f.stat().st_size <= 8000:
                put("bitmap", f.name, f.read_bytes())
    # the other formats the image crate reads, tiny
    put("bitmap", "p5.pgm", b"P5\n4 3\n255\n" + bytes([0, 255, 0, 255] * 3))
    put("bitmap", "p2.pgm", b"P2\n2 2\n15\n0 15\n15 0\n")
    put("bitmap", "p6.ppm", b"P6\n2 1\n255\n" + bytes([0, 0, 0, 255, 255, 255]))
    put("bitmap", "p1.pbm", b"P1\n3 2\n1 0 1\n0 1 0\n")
    put("bitmap", "p7.pam", b"P7\nWIDTH 2\nHEIGHT 1\nDEPTH 2\nMAXVAL 255\nTUPLTYPE GRAYSCALE_ALPHA\nENDHDR\n" + bytes([0, 255, 255, 255]))
    # 2x2 24-bit BMP
    row = bytes([0, 0, 0, 255, 255, 255]) + b"\0\0"
    pix = row * 2
    bmp = b"BM" + struct.pack("<IHHI", 54 + len(pix), 0, 0, 54)
    bmp += struct.pack("<IiiHHIIiiII", 40, 2, 2, 1, 24, 0, len(pix), 2835, 2835, 0, 0) + pix
    put("bitmap", "tiny.bmp", bmp)
    # 1x1 GIF
    put("bitmap", "tiny.gif", bytes.fromhex(
        "47494638396101000100800000000000ffffff21f90401000000002c00000000010001000002024401003b"))


def cdr(fmt_le, *values, big=False):
    """A ROS 2 sample: the encapsulation header (CDR_LE 00 01 or CDR_BE 00 00) and the body."""
    fmt = (">" if big else "<") + fmt_le
    return (b"\x00\x00" if big else b"\x00\x01") + b"\x00\x00" + struct.pack(fmt, *values)


def stamped(sec, nsec, frame, twist, big=False):
    """A TwistStamped: the header's stamp and frame (a CDR string with its NUL), padding to 8."""
    o = ">" if big else "<"
    body = struct.pack(o + "iiI", sec, nsec, len(frame) + 1) + frame + b"\x00"
    body += b"\x00" * (-len(body) % 8) + struct.pack(o + "6d", *twist)
    return (b"\x00\x00" if big else b"\x00\x01") + b"\x00\x00" + body


def record(kind, vehicle, sample):
    """One record of the ros2_inbound target: kind, vehicle, u16 LE length, the sample."""
    return struct.pack("<BBH", kind, vehicle, len(sample)) + sample


def ros2():
    """cmd_vel (Twist 0, TwistStamped 1), cmd_pose (2), reset_positions (Cyclone 3, Fast DDS 4)."""
    nan, inf = float("nan"), float("inf")

    def pose(x, y, yaw):
        return cdr("7d", x, y, 0.0, 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))

    def twist(vx, vy, va, big=False):
        return cdr("6d", vx, vy, 0.0, 0.0, 0.0, va, big=big)

    cyclone = cdr("8siIB", bytes(range(1, 9)), 0, 7, 0)
    fast = cdr("B", 0)
    seeds = {
        "forward": [record(0, 0, twist(0.5, 0.0, 0.2))] * 3,
        "forward-be": [record(0, 1, twist(0.5, 0.0, -0.2, big=True))] * 3,
        "stamped": [record(1, 0, stamped(1, 500, b"r0/base_link", (0.3, 0.1, 0, 0, 0, 0.4)))],
        "stamped-empty-frame": [record(1, 2, stamped(0, 0, b"", (0.3, 0, 0, 0, 0, 0)))],
        "stamped-be": [record(1, 1, stamped(2, 0, b"odom", (1, 0, 0, 0, 0, 1), big=True))],
        "nan": [record(0, 0, twist(nan, 0.0, 0.0)), record(0, 1, twist(0.0, inf, -inf))],
        "huge": [record(0, 1, twist(1e300, -1e300, 1e300)), record(0, 0, twist(1.7e308, 0, 0))],
        "teleport": [record(2, 0, pose(1.5, -1.0, 0.7)), record(2, 2, pose(-3.0, 2.0, -2.0))],
        "teleport-far": [record(2, 1, pose(1e9, -1e9, 3.0)), record(0, 1, twist(1e30, 0, 0))],
        "teleport-nan": [record(2, 0, pose(nan, 0, 0)), record(2, 2, pose(inf, -inf, 0))],
        "reset-cyclone": [record(0, 0, twist(1, 0, 0)), record(3, 0, cyclone)],
        "reset-fast-dds": [record(2, 1, pose(2, 2, 1)), record(4, 0, fast)],
        "reset-crossed": [record(3, 0, fast), record(4, 0, cyclone)],
        "short": [record(0, 0, b"\x00\x01"), record(2, 0, cdr("3d", 1, 2, 3))],
    }
    for name, records in seeds.items():
        put("ros2_inbound", name, b"".join(records))


if __name__ == "__main__":
    worlds()
    wire()
    logs()
    bitmaps()
    ros2()
    for d in sorted(OUT.iterdir()):
        print(d.name, len(list(d.iterdir())), file=sys.stderr)
