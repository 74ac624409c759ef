"""The Pythonic layer: ``Client`` and its devices, ``World``, the typed data classes.

Loaded lazily by ``playerstage/__init__.py`` (it imports ``playerc``, which imports
``playerstage._native``: importing it eagerly from the package would be circular).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, List, Optional

import playerc as _pc

from . import _native
from ._native import (
    ConnectionLost,
    PlayerError,
    RequestRefused,
    RequestTimeout,
    WorldError,
)

try:  # numpy is optional: sensor arrays are numpy arrays when it is installed.
    import numpy as _np
except ImportError:  # pragma: no cover - exercised only without numpy
    _np = None

# The public names are listed once, in the package's ``__all__`` (``playerstage/__init__.py``),
# which loads them from here on first use.

HAVE_NUMPY = _np is not None


def _array(values):
    """A float numpy array when numpy is installed, else a list."""
    if _np is not None:
        return _np.asarray(values, dtype=float)
    return list(values)


def _check(ret):
    """Turns playerc's -1 into the exception it recorded."""
    if ret != 0:
        raise _pc._last_exception or PlayerError(_pc.playerc_error_str())


# --- typed data -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Pose2d:
    """A planar pose: metres, metres, radians."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


@dataclass(frozen=True)
class Odometry:
    """A position2d's state: pose (odometry frame), body velocity, stall flag, timestamp."""

    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    vyaw: float
    stall: bool
    time: float

    @property
    def pose(self) -> Pose2d:
        return Pose2d(self.x, self.y, self.yaw)


@dataclass(frozen=True)
class RangerScan:
    """A ranger reading: ranges (m), intensities and bearings (rad) as arrays."""

    ranges: Any
    intensities: Any
    bearings: Any
    time: float


@dataclass(frozen=True)
class LaserScan:
    """A laser reading (Player's deprecated laser interface): ranges and bearings."""

    ranges: Any
    bearings: Any
    intensities: Any
    time: float


@dataclass(frozen=True)
class Blob:
    """One colour blob: colour as 0xRRGGBB, centre and box in image pixels, range (m)."""

    color: int
    x: int
    y: int
    left: int
    right: int
    top: int
    bottom: int
    area: int
    range: float


@dataclass(frozen=True)
class BlobfinderFrame:
    """One blobfinder frame: image size and the blobs in it."""

    width: int
    height: int
    blobs: List[Blob]
    time: float


@dataclass(frozen=True)
class Fiducial:
    """One detected marker: its id and pose relative to the detector (x, y, yaw)."""

    id: int
    x: float
    y: float
    yaw: float

    @property
    def range(self) -> float:
        return math.hypot(self.x, self.y)

    @property
    def bearing(self) -> float:
        return math.atan2(self.y, self.x)


@dataclass(frozen=True)
class GripperState:
    """A gripper's state (``PLAYER_GRIPPER_STATE_*``), break beams and stored objects."""

    state: int
    beams: int
    stored: int
    time: float

    @property
    def closed(self) -> bool:
        return self.state == _pc.PLAYER_GRIPPER_STATE_CLOSED

    @property
    def open(self) -> bool:
        return self.state == _pc.PLAYER_GRIPPER_STATE_OPEN


# --- devices -------------------------------------------------------------------------------


class Device:
    """A subscribed device. A context manager: leaving the block unsubscribes."""

    _proxy_class: Any = None

    def __init__(self, client: "Client", index: int):
        self._client = client
        self._proxy = self._proxy_class(client._pc, index)
        _check(self._proxy.subscribe(_pc.PLAYERC_OPEN_MODE))

    @property
    def index(self) -> int:
        return self._proxy.index

    @property
    def driver(self) -> str:
        """The server's driver name for the device (``stage``, ``vfh``, ...)."""
        return self._proxy.info.drivername

    @property
    def time(self) -> float:
        """Timestamp of the device's latest data (server time)."""
        return self._proxy.info.datatime

    @property
    def fresh(self) -> bool:
        """True when data arrived since the last ``not_fresh()``."""
        return bool(self._proxy.info.fresh)

    def not_fresh(self) -> None:
        self._proxy.info.fresh = 0

    def close(self) -> None:
        """Unsubscribes."""
        if self._proxy.info.subscribed:
            _check(self._proxy.unsubscribe())

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._client._pc._conn is not None:
            self.close()


class Position2d(Device):
    """A mobile base: ``odometry``, ``set_velocity``, ``goto``, ``set_odometry``."""

    _proxy_class = _pc.playerc_position2d

    @property
    def odometry(self) -> Odometry:
        p = self._proxy
        return Odometry(p.px, p.py, p.pa, p.vx, p.vy, p.va, bool(p.stall), p.info.datatime)

    @property
    def pose(self) -> Pose2d:
        return Pose2d(self._proxy.px, self._proxy.py, self._proxy.pa)

    def set_velocity(self, vx: float, vy: float = 0.0, vyaw: float = 0.0) -> None:
        _check(self._proxy.set_cmd_vel(vx, vy, vyaw, 1))

    def goto(self, x: float, y: float, yaw: float) -> None:
        _check(self._proxy.set_cmd_pose(x, y, yaw, 1))

    def stop(self) -> None:
        self.set_velocity(0.0, 0.0, 0.0)

    def set_odometry(self, x: float, y: float, yaw: float) -> None:
        _check(self._proxy.set_odom(x, y, yaw))

    def enable_motors(self, on: bool = True) -> None:
        _check(self._proxy.enable(on))

    def geometry(self) -> dict:
        """``{"pose": [x, y, yaw], "size": [length, width]}`` of the base."""
        _check(self._proxy.get_geom())
        return {"pose": list(self._proxy.pose), "size": list(self._proxy.size)}


class Ranger(Device):
    """A range sensor: ``scan`` (arrays), ``ranges``, ``geometry()``, ``config()``."""

    _proxy_class = _pc.playerc_ranger

    @property
    def scan(self) -> RangerScan:
        p = self._proxy
        return RangerScan(
            _array(p.ranges), _array(p.intensities), _array(p.bearings), p.info.datatime
        )

    @property
    def ranges(self):
        return _array(self._proxy.ranges)

    def geometry(self) -> dict:
        _check(self._proxy.get_geom())
        p = self._proxy
        return {
            "pose": p.device_pose,
            "size": p.device_size,
            "element_poses": p.element_poses,
            "element_sizes": p.element_sizes,
        }

    def config(self) -> dict:
        res = self._proxy.get_config()
        _check(res[0])
        keys = ("min_angle", "max_angle", "angular_res", "min_range", "max_range",
                "range_res", "frequency")
        return dict(zip(keys, res[1:]))


class Laser(Device):
    """A laser (Player's laser interface): ``scan``."""

    _proxy_class = _pc.playerc_laser

    @property
    def scan(self) -> LaserScan:
        p = self._proxy
        return LaserScan(
            _array(p.ranges),
            _array([b for _, b in p.scan]),
            _array(p.intensity),
            p.info.datatime,
        )


class Sonar(Device):
    """A sonar array (Player's sonar interface): ``ranges``, ``poses()``."""

    _proxy_class = _pc.playerc_sonar

    @property
    def ranges(self):
        return _array(self._proxy.scan)

    def poses(self) -> List[Pose2d]:
        _check(self._proxy.get_geom())
        return [Pose2d(*p) for p in self._proxy.poses]


class Blobfinder(Device):
    """A colour blob detector: ``frame`` / ``blobs``."""

    _proxy_class = _pc.playerc_blobfinder

    @property
    def blobs(self) -> List[Blob]:
        return [
            Blob(b.color, b.x, b.y, b.left, b.right, b.top, b.bottom, b.area, b.range)
            for b in self._proxy.blobs
        ]

    @property
    def frame(self) -> BlobfinderFrame:
        p = self._proxy
        return BlobfinderFrame(p.width, p.height, self.blobs, p.info.datatime)


class FiducialFinder(Device):
    """A marker detector: ``fiducials``."""

    _proxy_class = _pc.playerc_fiducial

    @property
    def fiducials(self) -> List[Fiducial]:
        return [
            Fiducial(f.id, f.pose.px, f.pose.py, f.pose.pyaw) for f in self._proxy.fiducials
        ]


class Gripper(Device):
    """A gripper: ``state``, ``open()``, ``close()``, ``store()``, ``retrieve()``."""

    _proxy_class = _pc.playerc_gripper

    @property
    def state(self) -> GripperState:
        p = self._proxy
        return GripperState(p.state, p.beams, p.stored, p.info.datatime)

    def open(self) -> None:
        _check(self._proxy.open_cmd())

    def close_paddles(self) -> None:
        _check(self._proxy.close_cmd())

    def stop(self) -> None:
        _check(self._proxy.stop_cmd())

    def store(self) -> None:
        _check(self._proxy.store_cmd())

    def retrieve(self) -> None:
        _check(self._proxy.retrieve_cmd())


class Simulation(Device):
    """The simulator: model poses by name."""

    _proxy_class = _pc.playerc_simulation

    def get_pose(self, name: str) -> Pose2d:
        res = self._proxy.get_pose2d(name)
        _check(res[0])
        return Pose2d(*res[1:])

    def set_pose(self, name: str, x: float, y: float, yaw: float) -> None:
        _check(self._proxy.set_pose2d(name, x, y, yaw))


class Speech(Device):
    """Text to speech (a speech bubble under Stage)."""

    _proxy_class = _pc.playerc_speech

    def say(self, text: str) -> None:
        _check(self._proxy.say(text))


class Graphics2d(Device):
    """Drawing on a model: colours are ``(r, g, b)`` 0-255."""

    _proxy_class = _pc.playerc_graphics2d

    def _color(self, rgb):
        r, g, b = rgb
        _check(self._proxy.setcolor((0, r, g, b)))

    def points(self, pts, color=(0, 0, 0)) -> None:
        self._color(color)
        _check(self._proxy.draw_points([tuple(p) for p in pts]))

    def polyline(self, pts, color=(0, 0, 0)) -> None:
        self._color(color)
        _check(self._proxy.draw_polyline([tuple(p) for p in pts]))

    def polygon(self, pts, color=(0, 0, 0), fill=None) -> None:
        self._color(color)
        fill_color = (0, *fill) if fill is not None else (0, 0, 0, 0)
        _check(self._proxy.draw_polygon([tuple(p) for p in pts], None, fill is not None, fill_color))

    def clear(self) -> None:
        _check(self._proxy.clear())


class Camera(Device):
    """A camera: ``image`` as an (height, width, channels) uint8 array with numpy, else
    ``(width, height, bytes)``."""

    _proxy_class = _pc.playerc_camera

    @property
    def image(self):
        p = self._proxy
        if _np is None or p.width == 0:
            return (p.width, p.height, p.image)
        channels = max(1, p.bpp // 8)
        return _np.frombuffer(p.image, dtype=_np.uint8).reshape(p.height, p.width, channels)


class Map(Device):
    """A map: ``grid()`` fetches the occupancy grid (-1 free, 0 unknown, +1 occupied), as a
    (height, width) int8 array with numpy (row 0 is the lowest)."""

    _proxy_class = _pc.playerc_map

    def grid(self):
        _check(self._proxy.get_map())
        p = self._proxy
        if _np is not None:
            return _np.asarray(p.cells, dtype=_np.int8).reshape(p.height, p.width)
        return p.cells

    @property
    def resolution(self) -> float:
        return self._proxy.resolution

    @property
    def origin(self):
        return tuple(self._proxy.origin)


class Planner(Device):
    """A path planner: ``set_goal``, ``waypoints()``, ``done``, ``valid``."""

    _proxy_class = _pc.playerc_planner

    def set_goal(self, x: float, y: float, yaw: float) -> None:
        _check(self._proxy.set_cmd_pose(x, y, yaw))

    def waypoints(self) -> List[Pose2d]:
        _check(self._proxy.get_waypoints())
        return [Pose2d(*w) for w in self._proxy.waypoints]

    @property
    def done(self) -> bool:
        return bool(self._proxy.path_done)

    @property
    def valid(self) -> bool:
        return bool(self._proxy.path_valid)

    def enable(self, on: bool = True) -> None:
        _check(self._proxy.enable(on))


class Localize(Device):
    """A localiser: ``hypotheses`` as (Pose2d, covariance, weight), ``set_pose``."""

    _proxy_class = _pc.playerc_localize

    @property
    def hypotheses(self):
        return [
            (Pose2d(h.mean.px, h.mean.py, h.mean.pa), tuple(h.cov), h.alpha)
            for h in self._proxy.hypoths
        ]

    def set_pose(self, x: float, y: float, yaw: float, cov=(0.5, 0.5, 0.5)) -> None:
        _check(self._proxy.set_pose([x, y, yaw], list(cov)))


# --- the client ----------------------------------------------------------------------------


class Client:
    """A connection to a Player server. A context manager: leaving the block disconnects.

    ``push=True`` switches to PUSH mode (every message as published) from libplayerc's
    default PULL mode (one round of the latest data per ``read()``). ``read_timeout``
    (seconds) bounds how long ``read()`` waits; by default it waits as long as it takes, but
    a dropped connection always raises ``ConnectionLost`` at once.
    """

    def __init__(
        self,
        host: str = "localhost",
        port: int = _native.DEFAULT_PORT,
        *,
        push: bool = False,
        request_timeout: float = 5.0,
        read_timeout: Optional[float] = None,
    ):
        self._pc = _pc.playerc_client(None, host, port)
        self._pc.request_timeout = request_timeout
        _check(self._pc.connect())
        if read_timeout is not None:
            self._pc._conn.set_read_timeout(read_timeout)
        if push:
            _check(self._pc.datamode(_pc.PLAYER_DATAMODE_PUSH))

    @property
    def host(self) -> str:
        return self._pc.host

    @property
    def port(self) -> int:
        return self._pc.port

    def read(self) -> None:
        """Reads one round (PULL) or one message (PUSH) into the devices."""
        if self._pc.read() is None:
            raise _pc._last_exception or PlayerError(_pc.playerc_error_str())

    def devices(self) -> List[tuple]:
        """The server's devices as ``(interface name, index, driver)``."""
        _check(self._pc.get_devlist())
        names = {getattr(_native, n): n[len("PLAYER_"):-len("_CODE")].lower()
                 for n in dir(_native) if n.startswith("PLAYER_") and n.endswith("_CODE")}
        return [
            (names.get(d.addr.interf, str(d.addr.interf)), d.addr.index, d.drivername)
            for d in self._pc.devinfos
        ]

    def set_replace_rule(self, replace: bool, msg_type=-1, subtype=-1, interf=-1, index=-1):
        """Keep only the newest queued message of this kind on the server (``replace``)."""
        _check(self._pc.set_replace_rule(interf, index, msg_type, subtype, 1 if replace else 0))

    def position2d(self, index: int = 0) -> Position2d:
        return Position2d(self, index)

    def ranger(self, index: int = 0) -> Ranger:
        return Ranger(self, index)

    def laser(self, index: int = 0) -> Laser:
        return Laser(self, index)

    def sonar(self, index: int = 0) -> Sonar:
        return Sonar(self, index)

    def blobfinder(self, index: int = 0) -> Blobfinder:
        return Blobfinder(self, index)

    def fiducial(self, index: int = 0) -> FiducialFinder:
        return FiducialFinder(self, index)

    def gripper(self, index: int = 0) -> Gripper:
        return Gripper(self, index)

    def simulation(self, index: int = 0) -> Simulation:
        return Simulation(self, index)

    def speech(self, index: int = 0) -> Speech:
        return Speech(self, index)

    def graphics2d(self, index: int = 0) -> Graphics2d:
        return Graphics2d(self, index)

    def camera(self, index: int = 0) -> Camera:
        return Camera(self, index)

    def map(self, index: int = 0) -> Map:
        return Map(self, index)

    def planner(self, index: int = 0) -> Planner:
        return Planner(self, index)

    def localize(self, index: int = 0) -> Localize:
        return Localize(self, index)

    def close(self) -> None:
        """Disconnects (the server drops this client's subscriptions)."""
        if self._pc._conn is not None:
            self._pc.disconnect()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# --- the in-process simulator --------------------------------------------------------------


def _native_value(name, doc):
    """A read-only property that is the native world's attribute ``name``."""
    return property(lambda world: getattr(world._w, name), doc=doc)


class World:
    """A Stage world simulated in this process: ``World(path, seed=0)``.

    Models are addressed by name (``"r0"``, or a generated name such as ``"r0.ranger:0"``;
    ``models()`` lists them). ``step(n)`` advances ``n`` simulation intervals; sensors read
    the state at the end of the last step. No server, no sockets, no clock: as fast as the
    simulation computes, and deterministic for a seed.
    """

    def __init__(self, path, seed: int = 0, text: Optional[str] = None):
        """``text``, when given, is the worldfile itself, read as if it were the file at
        ``path`` (includes and bitmaps resolve against its directory; it need not exist)."""
        self._w = _native.World(str(path), seed, text=text)

    def step(self, n: int = 1) -> bool:
        """Advances ``n`` steps; False once the world's ``quit_time`` is reached."""
        return self._w.step(n)

    time = _native_value("time", "Simulated seconds (float).")
    seed = _native_value("seed", "The seed the world was built with (int).")
    steps = _native_value("steps", "Steps taken so far (int).")
    interval = _native_value(
        "interval", "Simulated seconds per step (float; the world's ``interval_sim``)."
    )

    @property
    def quit_time(self) -> float:
        """The world's ``quit_time`` (s; 0 = never): ``step`` returns False from there."""
        return self._w.quit_time

    @quit_time.setter
    def quit_time(self, seconds: float) -> None:
        self._w.quit_time = seconds

    def digest(self) -> int:
        """A digest of the whole state: equal for identical runs."""
        return self._w.digest()

    def models(self, type: Optional[str] = None) -> List[str]:
        """Model names in creation order, optionally only those of one type
        (``position``, ``ranger``, ``blobfinder``, ``fiducial``, ``gripper``, ``camera``, ...)."""
        return [n for n, t in self._w.models() if type is None or t == type]

    def model_types(self) -> dict:
        """``{name: type}`` of every model."""
        return dict(self._w.models())

    def pose(self, name: str) -> Pose2d:
        """Pose in the parent's frame."""
        return Pose2d(*self._w.pose(name))

    def global_pose(self, name: str) -> Pose2d:
        return Pose2d(*self._w.global_pose(name))

    def set_pose(self, name: str, x: float, y: float, yaw: float) -> None:
        self._w.set_pose(name, x, y, yaw)

    def set_velocity(self, name: str, vx: float, vy: float = 0.0, vyaw: float = 0.0) -> None:
        self._w.set_velocity(name, vx, vy, vyaw)

    def position_config(self, name: str) -> tuple:
        """A position model's drive (``"diff"``, ``"omni"`` or ``"car"``) and its
        ``velocity_bounds`` ``[xmin, xmax, ymin, ymax, zmin, zmax, amin, amax]`` (m/s, rad/s):
        the commands Stage accepts, e.g. an agent's action bounds."""
        return self._w.position_config(name)

    def rangers(self, name: str) -> List[tuple]:
        """The rangers in the model's tree (itself and its descendants, parents first) as
        ``[(name, samples, range_max)]``: ``samples`` is the length of ``ranger(name).ranges``,
        ``range_max`` the largest reach of its transducers (m); known before the first step."""
        return self._w.rangers(name)

    def ranger_rays(self, name: str) -> List[tuple]:
        """Where each of the ranger's readings was cast from, in the world frame as the ranger
        now stands: ``[(x, y, heading)]``, one per entry of ``ranger(name).ranges`` (each
        transducer's own position on the ranger, e.g. every sonar of a ring; its heading plus
        the reading's bearing); empty before the ranger's first update."""
        return [tuple(r) for r in self._w.ranger_rays(name)]

    def extent(self) -> Optional[List[float]]:
        """The axis-aligned box around every model's blocks as they are now, ``[xmin, ymin,
        xmax, ymax]`` (m); None when no model has blocks."""
        return self._w.extent()

    def overlaps(self, name: str) -> bool:
        """Whether the model's tree, at its current pose, overlaps a block of any model outside
        its tree (outlines crossing or one inside the other, z ranges overlapping, whatever
        their ``obstacle_return``): False means the pose is in free space."""
        return self._w.overlaps(name)

    def goto(self, name: str, x: float, y: float, yaw: float) -> None:
        self._w.set_goal(name, x, y, yaw)

    def odometry(self, name: str) -> Optional[Odometry]:
        d = self._w.position(name)
        if d is None:
            return None
        return Odometry(d["px"], d["py"], d["pa"], d["vx"], d["vy"], d["va"], d["stall"], d["time"])

    def ranger(self, name: str) -> RangerScan:
        d = self._w.ranger(name)
        return RangerScan(
            _array(d["ranges"]), _array(d["intensities"]), _array(d["bearings"]), d["time"]
        )

    def blobfinder(self, name: str) -> BlobfinderFrame:
        d = self._w.blobfinder(name)
        blobs = [
            Blob(b["color"], b["x"], b["y"], b["left"], b["right"], b["top"], b["bottom"],
                 b["area"], b["range"])
            for b in d["blobs"]
        ]
        return BlobfinderFrame(d["width"], d["height"], blobs, d["time"])

    def fiducials(self, name: str) -> List[Fiducial]:
        out = []
        for f in self._w.fiducials(name):
            r, b = f["range"], f["bearing"]
            out.append(Fiducial(f["id"], r * math.cos(b), r * math.sin(b), f["heading"]))
        return out

    def gripper(self, name: str) -> dict:
        """``{paddles, lift, beams, time}``."""
        return self._w.gripper(name)

    def gripper_cmd(self, name: str, what: str) -> None:
        """``open``, ``close``, ``up`` or ``down``."""
        self._w.gripper_cmd(name, what)

    def camera(self, name: str):
        """The latest image, (height, width, 4) RGBA uint8 with numpy; None before the first
        (call ``subscribe(name)`` first)."""
        img = self._w.camera(name)
        if img is None or _np is None:
            return img
        w, h, data = img
        return _np.frombuffer(data, dtype=_np.uint8).reshape(h, w, 4)

    def subscribe(self, name: str) -> None:
        """Starts updating a model not updated by default (cameras)."""
        self._w.subscribe(name)

    def say(self, name: str, text: str) -> None:
        self._w.say(name, text)

    def said(self, name: str) -> str:
        return self._w.said(name)
