"""A ROS 2 peer on Cyclone DDS's Python binding, for the `stage_ros2` tests: the ROS 2 message
types under their DDS names (`nav_msgs::msg::dds_::Odometry_`), readers and writers with
ROS 2's QoS, a `std_srvs/Empty` client in rmw_cyclonedds's request/reply mapping, and the
`stage_ros2` process. Everything stays on loopback: Cyclone is configured for `lo` without
multicast, the node runs with ROS_LOCALHOST_ONLY=1, and each node gets its own domain id.
"""

import os
import random
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from conftest import find_binary

# Cyclone reads its configuration when the first participant of a domain is created.
_CONFIG = Path(tempfile.mkdtemp(prefix="playerstage-cyclonedds-")) / "lo.xml"
_CONFIG.write_text(
    '<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface name="lo"/>'
    "</Interfaces><AllowMulticast>false</AllowMulticast></General></Domain></CycloneDDS>"
)
os.environ["CYCLONEDDS_URI"] = f"file://{_CONFIG}"

import cyclonedds.idl.types as t  # noqa: E402
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402



def _name(package, kind, name):
    return f"{package}::{kind}::dds_::{name}_"


@dataclass
class Time(IdlStruct, typename=_name("builtin_interfaces", "msg", "Time")):
    sec: t.int32 = 0
    nanosec: t.uint32 = 0


@dataclass
class Header(IdlStruct, typename=_name("std_msgs", "msg", "Header")):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class Vector3(IdlStruct, typename=_name("geometry_msgs", "msg", "Vector3")):
    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0


@dataclass
class Point(IdlStruct, typename=_name("geometry_msgs", "msg", "Point")):
    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename=_name("geometry_msgs", "msg", "Quaternion")):
    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0
    w: t.float64 = 1.0


@dataclass
class Pose(IdlStruct, typename=_name("geometry_msgs", "msg", "Pose")):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseWithCovariance(IdlStruct, typename=_name("geometry_msgs", "msg", "PoseWithCovariance")):
    pose: Pose = field(default_factory=Pose)
    covariance: t.array[t.float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Twist(IdlStruct, typename=_name("geometry_msgs", "msg", "Twist")):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistStamped(IdlStruct, typename=_name("geometry_msgs", "msg", "TwistStamped")):
    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@dataclass
class TwistWithCovariance(
    IdlStruct, typename=_name("geometry_msgs", "msg", "TwistWithCovariance")
):
    twist: Twist = field(default_factory=Twist)
    covariance: t.array[t.float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Odometry(IdlStruct, typename=_name("nav_msgs", "msg", "Odometry")):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
class Transform(IdlStruct, typename=_name("geometry_msgs", "msg", "Transform")):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename=_name("geometry_msgs", "msg", "TransformStamped")):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename=_name("tf2_msgs", "msg", "TFMessage")):
    transforms: t.sequence[TransformStamped] = field(default_factory=list)


@dataclass
class LaserScan(IdlStruct, typename=_name("sensor_msgs", "msg", "LaserScan")):
    header: Header = field(default_factory=Header)
    angle_min: t.float32 = 0.0
    angle_max: t.float32 = 0.0
    angle_increment: t.float32 = 0.0
    time_increment: t.float32 = 0.0
    scan_time: t.float32 = 0.0
    range_min: t.float32 = 0.0
    range_max: t.float32 = 0.0
    ranges: t.sequence[t.float32] = field(default_factory=list)
    intensities: t.sequence[t.float32] = field(default_factory=list)


@dataclass
class Range(IdlStruct, typename=_name("sensor_msgs", "msg", "Range")):
    header: Header = field(default_factory=Header)
    radiation_type: t.uint8 = 0
    field_of_view: t.float32 = 0.0
    min_range: t.float32 = 0.0
    max_range: t.float32 = 0.0
    range: t.float32 = 0.0


@dataclass
class Clock(IdlStruct, typename=_name("rosgraph_msgs", "msg", "Clock")):
    clock: Time = field(default_factory=Time)


@dataclass
class Bool(IdlStruct, typename=_name("std_msgs", "msg", "Bool")):
    data: bool = False


# The node graph (`ros2 node list` reads it): Jazzy's 16-byte GIDs.
@dataclass
class Gid(IdlStruct, typename=_name("rmw_dds_common", "msg", "Gid")):
    data: t.array[t.uint8, 16] = field(default_factory=lambda: [0] * 16)


@dataclass
class NodeEntitiesInfo(IdlStruct, typename=_name("rmw_dds_common", "msg", "NodeEntitiesInfo")):
    node_namespace: str = ""
    node_name: str = ""
    reader_gid_seq: t.sequence[Gid] = field(default_factory=list)
    writer_gid_seq: t.sequence[Gid] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo(
    IdlStruct, typename=_name("rmw_dds_common", "msg", "ParticipantEntitiesInfo")
):
    gid: Gid = field(default_factory=Gid)
    node_entities_info_seq: t.sequence[NodeEntitiesInfo] = field(default_factory=list)


# rmw_cyclonedds puts {uint64 guid; int64 seq} in front of every request and reply.
@dataclass
class EmptyRequest(IdlStruct, typename=_name("std_srvs", "srv", "Empty_Request")):
    guid: t.uint64 = 0
    seq: t.int64 = 0
    structure_needs_at_least_one_member: t.uint8 = 0


@dataclass
class EmptyResponse(IdlStruct, typename=_name("std_srvs", "srv", "Empty_Response")):
    guid: t.uint64 = 0
    seq: t.int64 = 0
    structure_needs_at_least_one_member: t.uint8 = 0


# The same types as Fast DDS (and ros2-client's Enhanced mapping) send them: no header, the
# request's identity travels in the sample's inline QoS.
@dataclass
class PlainEmptyRequest(IdlStruct, typename=_name("std_srvs", "srv", "Empty_Request")):
    structure_needs_at_least_one_member: t.uint8 = 0


@dataclass
class PlainEmptyResponse(IdlStruct, typename=_name("std_srvs", "srv", "Empty_Response")):
    structure_needs_at_least_one_member: t.uint8 = 0


def qos(depth=10, transient_local=False):
    """ROS 2's QoS: reliable, keep last `depth`, volatile or transient local."""
    return Qos(
        Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
        Policy.Durability.TransientLocal if transient_local else Policy.Durability.Volatile,
        Policy.History.KeepLast(depth),
    )


def domain_id():
    """A domain id for one test's node and peer, so that parallel runs do not hear each other."""
    return random.randint(100, 230)


def stage_ros2_bin():
    found = find_binary("stage_ros2", "PLAYERSTAGE_STAGE_ROS2")
    if found is None:
        raise RuntimeError(
            "no `stage_ros2` binary: build it with `cargo build -p cli --bin stage_ros2` or set "
            "PLAYERSTAGE_STAGE_ROS2"
        )
    return found


class Node:
    """A `stage_ros2` process on `world` in domain `domain`, localhost only."""

    def __init__(self, world, domain, args=(), headless=True, env=None):
        self.domain = domain
        env = dict(env or os.environ, ROS_DOMAIN_ID=str(domain), ROS_LOCALHOST_ONLY="1")
        self.proc = subprocess.Popen(
            [str(stage_ros2_bin()), *(["-g"] if headless else []), str(world), *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=env,
        )
        self.output = []
        self._pump = threading.Thread(target=self._read, daemon=True)
        self._pump.start()

    def _read(self):
        for line in self.proc.stdout:
            self.output.append(line)

    def text(self):
        return "".join(self.output)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._pump.join(timeout=5)


class Peer:
    """A Cyclone participant in `domain` with readers and writers made on demand."""

    def __init__(self, domain):
        self.dp = DomainParticipant(domain)
        self._topics = {}

    def topic(self, name, cls):
        key = (name, cls)
        if key not in self._topics:
            self._topics[key] = Topic(self.dp, name, cls)
        return self._topics[key]

    def reader(self, name, cls, **kw):
        return DataReader(self.dp, self.topic("rt/" + name.lstrip("/"), cls), qos=qos(**kw))

    def writer(self, name, cls, **kw):
        return DataWriter(self.dp, self.topic("rt/" + name.lstrip("/"), cls), qos=qos(**kw))


def wait_for(reader, predicate=lambda m: True, timeout=10.0):
    """The first sample from `reader` that satisfies `predicate`, or an AssertionError."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for m in reader.take(N=100):
            if predicate(m):
                return m
        time.sleep(0.01)
    raise AssertionError(f"nothing on {reader.topic.name} within {timeout} s")


def publish_until(writer, msg, reader, predicate, timeout=10.0):
    """Writes `msg` every 50 ms until `reader` yields a sample satisfying `predicate`."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        writer.write(msg)
        for m in reader.take(N=100):
            if predicate(m):
                return m
        time.sleep(0.05)
    raise AssertionError(f"no answer on {reader.topic.name} within {timeout} s")
