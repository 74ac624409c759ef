"""`stage_ros2`'s reset_positions service against a real eProsima Fast DDS client speaking
rmw_fastrtps's request/reply mapping (ROS 2's default RMW): plain CDR payloads, the request's
identity out of band in the inline QoS (related sample identity), which the reply must carry
back for the client to match it. The client is fastdds_peer/reset_client.cpp, compiled here
against the system's Fast DDS 2.x (Debian: `apt-get install libfastrtps-dev`); without its
headers these tests skip. The robot is moved from the Cyclone side (ros2_peer.py) and must come
back after the Fast DDS client's request.
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import REPO
from ros2_peer import Node, Odometry, Peer, Pose, domain_id, publish_until, wait_for

SOURCE = Path(__file__).resolve().parent / "fastdds_peer" / "reset_client.cpp"

# A diff robot at the origin; nothing else in the way.
WORLD = """
resolution 0.02
interval_sim 100
position ( name "r0" pose [0 0 0 0] size [0.4 0.4 0.3] drive "diff" )
"""

# The header a Fast DDS 2.x installation provides (libfastrtps-dev on Debian and Ubuntu).
PROBE = "#include <fastdds/dds/domain/DomainParticipantFactory.hpp>\n"


@pytest.fixture(scope="module")
def reset_client():
    """The compiled Fast DDS client (rebuilt when its source is newer); skips without Fast DDS."""
    cxx = os.environ.get("CXX", "g++")
    if shutil.which(cxx) is None:
        pytest.skip(f"no C++ compiler `{cxx}` to build the Fast DDS peer")
    probe = subprocess.run(
        [cxx, "-x", "c++", "-std=c++17", "-E", "-o", os.devnull, "-"],
        input=PROBE,
        capture_output=True,
        text=True,
    )
    if probe.returncode != 0:
        pytest.skip(
            "Fast DDS headers not found (fastdds/dds/domain/DomainParticipantFactory.hpp): "
            "install libfastrtps-dev (Debian/Ubuntu) to run the Fast DDS service peer"
        )
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    out = target / "fastdds-peer" / "reset_client"
    if not out.is_file() or out.stat().st_mtime < SOURCE.stat().st_mtime:
        out.parent.mkdir(parents=True, exist_ok=True)
        build = subprocess.run(
            [cxx, "-std=c++17", "-O1", "-Wall", "-o", str(out), str(SOURCE)]
            + ["-lfastrtps", "-lfastcdr"],
            capture_output=True,
            text=True,
        )
        assert build.returncode == 0, f"building the Fast DDS peer failed:\n{build.stderr}"
    return out


def run_client(client, domain, mode):
    """Runs the client; its exit status and parsed event lines."""
    proc = subprocess.run(
        [str(client), str(domain), mode, "20"], capture_output=True, text=True, timeout=40
    )
    events = []
    for line in proc.stdout.splitlines():
        kind, _, rest = line.partition(" ")
        # "related_guid=.. seq=.. sample_guid=.. seq=..": each seq belongs to the guid before it
        fields, last = {}, ""
        for key, value in re.findall(r"(\w+)=(\S+)", rest):
            if key == "seq":
                key = f"{last}seq"
            elif key.endswith("guid"):
                last = key[: -len("guid")]
            fields[key] = value
        events.append((kind, fields))
    return proc, events


@pytest.mark.parametrize(
    "mode",
    [
        # since Humble, rmw_fastrtps's request names the client's reply reader in its related
        # sample identity (sequence number unknown), and the reply carries that reader's GUID
        # with the request's sequence number
        "rmw_fastrtps",
        # without it (older clients) the reply carries the request's own identity
        "plain",
    ],
)
def test_reset_positions_answers_a_fast_dds_client(tmp_path, reset_client, mode):
    world = tmp_path / "one.world"
    world.write_text(WORLD)
    domain = domain_id()
    # paced: the teleport and the reset are awaited on streamed ground truth, which under
    # --fast queues seconds of samples in the reader on a busy machine
    node = Node(world, domain, ["--speedup", "5"])
    try:
        peer = Peer(domain)
        gt = peer.reader("ground_truth", Odometry)
        teleport = peer.writer("cmd_pose", Pose)
        wait_for(gt)
        away = Pose()
        away.position.x = -1.0
        publish_until(
            teleport, away, gt, lambda m: m.pose.pose.position.x == pytest.approx(-1.0)
        )

        proc, events = run_client(reset_client, domain, mode)
        assert proc.returncode == 0, f"Fast DDS client: {proc.stdout}\n{proc.stderr}"
        (client,) = [f for k, f in events if k == "client"]
        requests = [f for k, f in events if k == "request"]
        replies = [f for k, f in events if k == "reply"]
        assert requests and replies, proc.stdout
        # one reply, from the server in Fast DDS's mapping: the one in Cyclone's (a header in
        # the payload) left this request alone
        assert len(replies) == 1, proc.stdout
        (reply,) = replies
        req = requests[-1]
        expected_guid = client["reader"] if mode == "rmw_fastrtps" else client["writer"]
        assert (reply["related_guid"], reply["related_seq"]) == (expected_guid, req["seq"])
        # Fast DDS's payload: the encapsulation (CDR little endian) and the one byte, padded;
        # no 16-byte header as Cyclone's mapping puts in front
        assert reply["payload"].startswith("0001000000") and len(reply["payload"]) <= 16
        assert reply["member"] == "0"

        back = wait_for(gt, lambda m: abs(m.pose.pose.position.x) < 1e-9)
        assert back.pose.pose.position.y == 0.0
        assert node.text().count("resetting stage") == len(requests)
    finally:
        node.stop()
