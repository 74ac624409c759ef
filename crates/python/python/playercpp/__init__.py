"""Drop-in replacement for Player 3.0.2's SWIG ``playercpp`` module (libplayerc++'s names).

Scripts written for the old bindings run unchanged::

    from playercpp import *
    robot = PlayerClient("localhost", 6665)
    pp = Position2dProxy(robot, 0)
    rp = RangerProxy(robot, 0)
    while True:
        robot.Read()
        if rp.GetRangeCount() > 0 and rp.GetRange(0) < 0.5:
            pp.SetSpeed(0.0, 0.5)
        else:
            pp.SetSpeed(0.3, 0.0)

As in libplayerc++, proxies subscribe when constructed and errors raise ``PlayerError``
(with ``GetErrorStr()``, as the C++ exception). Methods with C++ output references return
their values instead: ``SimulationProxy.GetPose2d(name)`` returns ``(x, y, a)``. Built on
the ``playerc`` module, as libplayerc++ is on libplayerc.
"""

import playerc as _pc
from playerstage import _native

from playerc import (  # noqa: F401 - re-exported constants, as the SWIG module includes player.h
    PLAYER_DATAMODE_PULL,
    PLAYER_DATAMODE_PUSH,
    PLAYER_GRIPPER_STATE_CLOSED,
    PLAYER_GRIPPER_STATE_MOVING,
    PLAYER_GRIPPER_STATE_OPEN,
    PLAYER_GRIPPER_STATE_ERROR,
    PLAYER_MSGTYPE_CMD,
    PLAYER_MSGTYPE_DATA,
    PLAYER_MSGTYPE_REQ,
    PLAYER_OPEN_MODE,
    PLAYER_CLOSE_MODE,
    player_color_t,
    player_point_2d_t,
    player_point_3d_t,
    player_pose2d_t,
)

for _name in dir(_pc):
    if _name.startswith("PLAYER_") and _name.endswith("_CODE"):
        globals()[_name] = getattr(_pc, _name)

PLAYER_PORTNUM = _native.DEFAULT_PORT
PLAYER_HOSTNAME = "localhost"


def _field(name):
    """A libplayerc++ getter (``GetXPos()``, ...) that returns the playerc proxy's field
    ``name`` as it is: one line per getter instead of a method each."""

    def get(self):
        return getattr(self._dev, name)

    return get


def _getter_name(field):
    """libplayerc++'s name for the getter of the playerc field ``field``: ``Get`` and the field
    in CamelCase (``min_angle``: ``GetMinAngle``)."""
    return "Get" + "".join(word.capitalize() for word in field.split("_"))


def _element(name):
    """A libplayerc++ indexed getter (``GetRange(i)``, ...) that returns element ``i`` of the
    playerc proxy's array field ``name``: one line per getter instead of a method each."""

    def get(self, aIndex):
        return getattr(self._dev, name)[aIndex]

    return get


def _component(name, k):
    """A libplayerc++ indexed getter (``GetBearing(i)``, ...) that returns component ``k`` of
    element ``i`` of the playerc proxy's array field ``name`` (an array of tuples)."""

    def get(self, aIndex):
        return getattr(self._dev, name)[aIndex][k]

    return get


def _planar(args):
    """``(x, y, a)`` of libplayerc++'s two overloads of a planar command: ``(x, a)``, which
    has no sideways part, or ``(x, y, a)``."""
    if len(args) == 2:
        return args[0], 0.0, args[1]
    x, y, a = args
    return x, y, a


class _forward:
    """A libplayerc++ method that passes its arguments to the playerc proxy's ``method`` and
    raises :class:`PlayerError` (naming the method) when that fails: one line per such method
    instead of a method each."""

    def __init__(self, method):
        self._method = method
        self._name = method

    def __set_name__(self, owner, name):
        self._name = name

    def __get__(self, proxy, owner=None):
        if proxy is None:
            return self

        def call(*args):
            proxy._ok(self._name, getattr(proxy._dev, self._method)(*args))

        call.__name__ = self._name
        return call


class PlayerError(_native.PlayerError):
    """libplayerc++'s ``PlayerCc::PlayerError``: ``GetErrorStr()``, ``GetErrorFun()``."""

    def __init__(self, fun, msg):
        super().__init__(msg)
        self._fun = fun
        self._msg = msg

    def GetErrorStr(self):
        return self._msg

    def GetErrorFun(self):
        return self._fun

    def GetErrorCode(self):
        return -1


def _check(fun, ret):
    if ret != 0:
        raise PlayerError(fun, _pc.playerc_error_str())


class PlayerClient:
    """``PlayerCc::PlayerClient(host, port)``: connects at once (raises on failure)."""

    def __init__(self, aHostname=PLAYER_HOSTNAME, aPort=PLAYER_PORTNUM, aTransport=None):
        self._pc = _pc.playerc_client(None, aHostname, aPort)
        _check("PlayerClient::Connect", self._pc.connect())

    def Read(self):
        """One read (a PULL round by default); raises on a dropped connection."""
        if self._pc.read() is None:
            raise PlayerError("PlayerClient::Read", _pc.playerc_error_str())

    def ReadIfWaiting(self) -> None:
        """Reads when data is waiting (a PULL round is asked for first), else returns."""
        if self.Peek(0):
            self.Read()

    def Peek(self, timeout: int = 0) -> bool:
        """Whether data is waiting, waiting at most ``timeout`` milliseconds for it (in PULL
        mode a round is asked for first, as libplayerc++ does)."""
        ret = self._pc.peek(timeout)
        if ret < 0:
            raise PlayerError("PlayerClient::Peek", _pc.playerc_error_str())
        return ret > 0

    def SetDataMode(self, aMode):
        _check("PlayerClient::SetDataMode", self._pc.datamode(aMode))

    def SetReplaceRule(self, aReplace, aType=-1, aSubtype=-1, aInterf=-1):
        _check(
            "PlayerClient::SetReplaceRule",
            self._pc.set_replace_rule(aInterf, -1, aType, aSubtype, 1 if aReplace else 0),
        )

    def SetRequestTimeout(self, aTimeout):
        self._pc.set_request_timeout(aTimeout)

    def SetRetryLimit(self, limit: int) -> None:
        """How many times a reconnection is tried (``playerc_client_set_retry_limit``)."""
        self._pc.set_retry_limit(limit)

    def SetRetryTime(self, time: float) -> None:
        """Seconds between reconnection attempts (``playerc_client_set_retry_time``)."""
        self._pc.set_retry_time(time)

    def LookupCode(self, aName: str) -> int:
        """The interface code of a name (``"position2d"``: 4); -1 when unknown."""
        return _pc.playerc_lookup_code(aName)

    def LookupName(self, aCode: int) -> str:
        """The interface name of a code (4: ``"position2d"``)."""
        return _pc.playerc_lookup_name(aCode)

    def Connected(self):
        return self._pc._conn is not None

    def GetHostname(self):
        return self._pc.host

    def GetPort(self):
        return self._pc.port

    def Disconnect(self):
        if self._pc._conn is not None:
            self._pc.disconnect()

    def RequestDeviceList(self):
        _check("PlayerClient::RequestDeviceList", self._pc.get_devlist())

    def GetDeviceList(self):
        return list(self._pc.devinfos)


class ClientProxy:
    """``PlayerCc::ClientProxy``: subscribes on construction.

    Most libplayerc++ getters return the playerc field of the same name: a proxy class lists
    such fields in ``_fields`` (``"min_angle"`` gives ``GetMinAngle()``) and the array fields
    read one element at a time in ``_elements`` (``"intensity"`` gives ``GetIntensity(i)``);
    a getter named otherwise is written out in the class."""

    _playerc = None
    _fields = ()
    _elements = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        getters = [(name, _field) for name in cls.__dict__.get("_fields", ())]
        getters += [(name, _element) for name in cls.__dict__.get("_elements", ())]
        for name, getter in getters:
            method = _getter_name(name)
            if method in cls.__dict__:
                raise TypeError(f"{cls.__name__}.{method} is both written out and listed")
            setattr(cls, method, getter(name))

    def __init__(self, aPc, aIndex=0):
        self._client = aPc
        self._dev = self._playerc(aPc._pc, aIndex)
        _check(f"{type(self).__name__}::Subscribe", self._dev.subscribe(_pc.PLAYERC_OPEN_MODE))

    def _ok(self, what, ret):
        _check(f"{type(self).__name__}::{what}", ret)

    GetIndex = _field("index")
    GetInterface = _field("_code")

    def GetDriverName(self):
        return self._dev.info.drivername

    def GetDataTime(self):
        return self._dev.info.datatime

    def GetElapsedTime(self) -> float:
        """Seconds between the last two data timestamps (``datatime - lasttime``)."""
        return self._dev.info.datatime - self._dev.info.lasttime

    def GetPlayerClient(self) -> "PlayerClient":
        """The client the proxy was made with."""
        return self._client

    def GetInterfaceStr(self) -> str:
        """The interface's name (``"laser"``)."""
        return _pc.playerc_lookup_name(self._dev._code)

    def IsValid(self):
        return self._dev.info.datatime > 0

    def IsFresh(self):
        return bool(self._dev.info.fresh)

    def NotFresh(self):
        self._dev.info.fresh = 0

    def SetReplaceRule(self, aReplace, aType=-1, aSubtype=-1):
        self._ok(
            "SetReplaceRule",
            self._client._pc.set_replace_rule(
                self._dev._code, self._dev.index, aType, aSubtype, 1 if aReplace else 0
            ),
        )

    def Unsubscribe(self):
        if self._dev.info.subscribed:
            self._ok("Unsubscribe", self._dev.unsubscribe())

    def HasCapability(self, aType: int, aSubtype: int) -> int:
        """1 when the device handles messages of (``aType``, ``aSubtype``), else 0."""
        return self._dev.info.hascapability(aType, aSubtype)

    # The property calls return libplayerc++'s int result and do not throw, as in C++; the
    # value the C++ writes through its pointer argument is returned beside it:
    # ``GetIntProp("key")`` is ``[0, value]``, or ``[-1, 0]`` when the device has no "key".

    def GetBoolProp(self, aProperty: str) -> list:
        """``[result, value]`` of a boolean property."""
        result, value = self._dev.info.get_boolprop(aProperty)
        return [result, bool(value)]

    def SetBoolProp(self, aProperty: str, aValue: bool) -> int:
        return self._dev.info.set_boolprop(aProperty, aValue)

    def GetIntProp(self, aProperty: str) -> list:
        """``[result, value]`` of an integer property."""
        return self._dev.info.get_intprop(aProperty)

    def SetIntProp(self, aProperty: str, aValue: int) -> int:
        return self._dev.info.set_intprop(aProperty, aValue)

    def GetDblProp(self, aProperty: str) -> list:
        """``[result, value]`` of a double property."""
        return self._dev.info.get_dblprop(aProperty)

    def SetDblProp(self, aProperty: str, aValue: float) -> int:
        return self._dev.info.set_dblprop(aProperty, aValue)

    def GetStrProp(self, aProperty: str) -> list:
        """``[result, value]`` of a string property."""
        return self._dev.info.get_strprop(aProperty)

    def SetStrProp(self, aProperty: str, aValue: str) -> int:
        return self._dev.info.set_strprop(aProperty, aValue)


class Position2dProxy(ClientProxy):
    """``PlayerCc::Position2dProxy``."""

    _playerc = _pc.playerc_position2d

    def SetSpeed(self, *args):
        """``SetSpeed(x, yaw)``, ``SetSpeed(x, y, yaw)`` or ``SetSpeed(player_pose2d_t)``."""
        if len(args) == 1:
            v = args[0]
            x, y, a = v.px, v.py, v.pa
        else:
            x, y, a = _planar(args)
        self._ok("SetSpeed", self._dev.set_cmd_vel(x, y, a, 1))

    def SetVelHead(self, *args):
        """``SetVelHead(x, heading)`` or ``SetVelHead(x, y, heading)``."""
        x, y, h = _planar(args)
        self._ok("SetVelHead", self._dev.set_cmd_vel_head(x, y, h, 1))

    def GoTo(self, *args):
        if len(args) == 3:
            self._ok("GoTo", self._dev.set_cmd_pose(*args, 1))
        elif len(args) == 2:
            self._ok("GoTo", self._dev.set_cmd_pose_with_vel(args[0], args[1], 1))
        else:
            p = args[0]
            self._ok("GoTo", self._dev.set_cmd_pose(p.px, p.py, p.pa, 1))

    SetCarlike = _forward("set_cmd_car")
    RequestGeom = _forward("get_geom")

    def GetSize(self):
        return _pc.player_bbox3d_t(self._dev.size[1], self._dev.size[0], 0.0)

    def GetPose(self):
        return _pc.player_pose3d_t(self._dev.pose[0], self._dev.pose[1], 0, 0, 0, self._dev.pose[2])

    def GetOffset(self) -> "_pc.player_pose3d_t":
        """The base's offset from the robot's centre (x, y, yaw; fill it with
        ``RequestGeom()``), as libplayerc++'s ``GetOffset``."""
        return self.GetPose()

    SetMotorEnable = _forward("enable")

    def ResetOdometry(self):
        self._ok("ResetOdometry", self._dev.set_odom(0.0, 0.0, 0.0))

    SetOdometry = _forward("set_odom")

    GetXPos = _field("px")
    GetYPos = _field("py")
    GetYaw = _field("pa")
    GetXSpeed = _field("vx")
    GetYSpeed = _field("vy")
    GetYawSpeed = _field("va")

    def GetStall(self):
        return bool(self._dev.stall)


class RangerProxy(ClientProxy):
    """``PlayerCc::RangerProxy``; ``rp[i]`` is ``GetRange(i)`` as C++'s ``operator[]``."""

    _playerc = _pc.playerc_ranger

    _fields = ("element_count", "device_pose", "device_size", "min_angle", "max_angle",
               "angular_res", "min_range", "max_range", "range_res", "frequency")

    GetElementPose = _element("element_poses")
    GetElementSize = _element("element_sizes")
    GetRangeCount = _field("ranges_count")
    GetRange = _element("ranges")
    __getitem__ = GetRange
    GetIntensityCount = _field("intensities_count")
    GetIntensity = _element("intensities")

    def SetPower(self, aEnable):
        self._ok("SetPower", self._dev.power_config(1 if aEnable else 0))

    def SetIntensityData(self, aEnable):
        self._ok("SetIntensityData", self._dev.intns_config(1 if aEnable else 0))

    RequestGeom = _forward("get_geom")

    def Configure(self, aMinAngle, aMaxAngle, aAngularRes, aMinRange, aMaxRange, aRangeRes,
                  aFrequency):
        self._ok(
            "Configure",
            self._dev.set_config(aMinAngle, aMaxAngle, aAngularRes, aMinRange, aMaxRange,
                                 aRangeRes, aFrequency),
        )

    def RequestConfigure(self):
        self._ok("RequestConfigure", self._dev.get_config()[0])


class LaserProxy(ClientProxy):
    """``PlayerCc::LaserProxy``."""

    _playerc = _pc.playerc_laser
    _fields = ("max_range", "scan_res", "range_res", "scanning_frequency", "min_angle",
               "max_angle")
    _elements = ("intensity",)

    GetCount = _field("scan_count")
    GetID = _field("laser_id")

    GetRange = _component("scan", 0)
    GetBearing = _component("scan", 1)
    __getitem__ = GetRange

    def GetPoint(self, aIndex):
        x, y = self._dev.point[aIndex]
        return player_point_2d_t(x, y)

    RequestGeom = _forward("get_geom")

    def RequestConfigure(self):
        self._ok("RequestConfigure", self._dev.get_config()[0])

    def Configure(self, aMinAngle, aMaxAngle, aScanRes, aRangeRes, aIntensity, aScanningFrequency):
        self._ok(
            "Configure",
            self._dev.set_config(aMinAngle, aMaxAngle, aScanRes, aRangeRes, aIntensity,
                                 aScanningFrequency),
        )

    def GetMinLeft(self) -> float:
        """The shortest range of the left half (indices above ``count / 2``), ``max_range``
        when there is none shorter: libplayerc's ``min_left``."""
        n = self._dev.scan_count
        return min([self._dev.max_range] + [r for r, _ in self._dev.scan[n // 2 + 1: n]])

    def GetMinRight(self) -> float:
        """The shortest range of the right half (indices up to ``count / 2``), as
        ``GetMinLeft``: libplayerc's ``min_right``."""
        n = self._dev.scan_count
        return min([self._dev.max_range] + [r for r, _ in self._dev.scan[: n // 2 + 1]])

    MinLeft = GetMinLeft
    MinRight = GetMinRight

    def RequestID(self) -> None:
        """Fetches the laser's serial number (``GetID()``)."""
        self._ok("RequestID", self._dev.get_id())

    def GetConfMinAngle(self) -> float:
        """The start angle of the configuration ``RequestConfigure()`` fetched."""
        return self._dev.min_angle

    def GetConfMaxAngle(self) -> float:
        """The end angle of the configuration ``RequestConfigure()`` fetched."""
        return self._dev.max_angle

    def IntensityOn(self) -> bool:
        """Whether intensities are on, per the last configuration fetched or set."""
        return bool(self._dev.intensity_on)

    def GetPose(self) -> "_pc.player_pose3d_t":
        """The laser's pose on the robot (x, y, yaw; fill it with ``RequestGeom()``)."""
        x, y, a = self._dev.pose
        return _pc.player_pose3d_t(x, y, 0.0, 0.0, 0.0, a)

    def GetRobotPose(self) -> "_pc.player_pose3d_t":
        """The robot's pose as the last scan with a pose carried it (x, y, yaw)."""
        x, y, a = self._dev.robot_pose
        return _pc.player_pose3d_t(x, y, 0.0, 0.0, 0.0, a)

    def GetSize(self) -> "_pc.player_bbox3d_t":
        """The laser's size (fill it with ``RequestGeom()``): ``sl`` and ``sw``, as
        libplayerc++ reads them from libplayerc's ``size``."""
        return _pc.player_bbox3d_t(sw=self._dev.size[1], sl=self._dev.size[0])


class SonarProxy(ClientProxy):
    """``PlayerCc::SonarProxy``."""

    _playerc = _pc.playerc_sonar
    _fields = ("pose_count",)

    GetCount = _field("scan_count")
    GetScan = _element("scan")
    __getitem__ = GetScan

    def GetPose(self, aIndex):
        x, y, a = self._dev.poses[aIndex]
        return _pc.player_pose3d_t(x, y, 0.0, 0.0, 0.0, a)

    RequestGeom = _forward("get_geom")


class BlobfinderProxy(ClientProxy):
    """``PlayerCc::BlobfinderProxy``."""

    _playerc = _pc.playerc_blobfinder
    _fields = ("width", "height")

    GetCount = _field("blobs_count")
    GetBlob = _element("blobs")
    __getitem__ = GetBlob


class FiducialProxy(ClientProxy):
    """``PlayerCc::FiducialProxy``."""

    _playerc = _pc.playerc_fiducial

    GetCount = _field("fiducials_count")
    GetFiducialItem = _element("fiducials")
    __getitem__ = GetFiducialItem

    def GetSensorPose(self):
        return self._dev.fiducial_geom.pose

    def GetSensorSize(self):
        return self._dev.fiducial_geom.size

    def GetFiducialSize(self) -> list:
        """The size of the fiducials the sensor detects, ``[width, length]`` (fill it with
        ``RequestGeometry()``)."""
        return self._dev.fiducial_geom.fiducial_size

    RequestGeometry = _forward("get_geom")


class GripperProxy(ClientProxy):
    """``PlayerCc::GripperProxy``."""

    _playerc = _pc.playerc_gripper
    _fields = ("state", "beams", "stored", "capacity", "num_beams", "pose", "outer_size",
               "inner_size")

    RequestGeometry = _forward("get_geom")
    Open = _forward("open_cmd")
    Close = _forward("close_cmd")
    Stop = _forward("stop_cmd")
    Store = _forward("store_cmd")
    Retrieve = _forward("retrieve_cmd")


class SimulationProxy(ClientProxy):
    """``PlayerCc::SimulationProxy``.

    libplayerc++ ignores the result of every simulation call, so a name the simulator does not
    know (its NACK) passes quietly through the setters here too, as it does in C++; a lost
    connection still raises. The getters return the values C++ writes through its reference
    arguments and raise ``PlayerError`` on a NACK, as there is then nothing to return, except
    ``GetProperty`` into a caller's buffer, which is left as it was, as in C++."""

    _playerc = _pc.playerc_simulation

    def _quiet(self, what: str, ret: int) -> None:
        """libplayerc++'s ignored result: a NACK passes, other failures raise."""
        if ret != 0 and not _pc._refused():
            self._ok(what, ret)

    def SetPose2d(self, identifier: str, x: float, y: float, a: float) -> None:
        """Moves model ``identifier``; a name the simulator does not know is ignored."""
        self._quiet("SetPose2d", self._dev.set_pose2d(identifier, x, y, a))

    def GetPose2d(self, identifier: str, *ignored_refs) -> tuple:
        """``(x, y, a)``: Python has no output references."""
        res = self._dev.get_pose2d(identifier)
        self._ok("GetPose2d", res[0])
        return tuple(res[1:])

    def SetPose3d(self, identifier: str, x: float, y: float, z: float, roll: float,
                  pitch: float, yaw: float) -> None:
        """Moves model ``identifier`` in 3-D; an unknown name is ignored, as ``SetPose2d``."""
        self._quiet("SetPose3d", self._dev.set_pose3d(identifier, x, y, z, roll, pitch, yaw))

    def GetPose3d(self, identifier: str, *ignored_refs) -> tuple:
        """``(x, y, z, roll, pitch, yaw, time)``, ``time`` the simulated time as the
        simulator reports it."""
        res = self._dev.get_pose3d(identifier)
        self._ok("GetPose3d", res[0])
        return tuple(res[1:])

    def GetProperty(self, identifier: str, name: str, value=None, value_len=None):
        """``GetProperty(identifier, name, value, value_len)`` as in C++: the property's bytes
        are written into ``value``, a writable buffer (``bytearray``, a ctypes object such as
        ``(ctypes.c_float * 4)()``), and returned; a NACK leaves the buffer as it was and
        returns ``None``. Without a buffer (``GetProperty(identifier, name[, value_len])``)
        the bytes are returned (``value_len`` default 16) and a NACK raises."""
        if value is None or isinstance(value, int):
            size = value if value_len is None else value_len
            res = self._dev.get_property(identifier, name, size if size is not None else 16)
            self._ok("GetProperty", res[0])
            return res[1]
        ret = self._dev.get_property(identifier, name, value, value_len)
        self._quiet("GetProperty", ret)
        if ret != 0:
            return None
        view = _pc._writable_bytes(value)
        return view[: view.nbytes if value_len is None else value_len].tobytes()

    def SetProperty(self, identifier: str, name: str, value, value_len=None) -> None:
        """Sets a property from the bytes of ``value`` (the first ``value_len`` of them when
        given); an unknown model or property is ignored, as in C++."""
        self._quiet("SetProperty", self._dev.set_property(identifier, name, value, value_len))


class SpeechProxy(ClientProxy):
    """``PlayerCc::SpeechProxy``."""

    _playerc = _pc.playerc_speech

    Say = _forward("say")


class Graphics2dProxy(ClientProxy):
    """``PlayerCc::Graphics2dProxy``."""

    _playerc = _pc.playerc_graphics2d

    def Color(self, *args):
        """``Color(player_color_t)`` or ``Color(red, green, blue, alpha)``."""
        if len(args) == 1:
            self._ok("Color", self._dev.setcolor(args[0]))
        else:
            r, g, b, a = args
            self._ok("Color", self._dev.setcolor((a, r, g, b)))

    Clear = _forward("clear")

    def DrawPoints(self, pts, count=None):
        self._ok("DrawPoints", self._dev.draw_points(_pts(pts), count))

    def DrawPolyline(self, pts, count=None):
        self._ok("DrawPolyline", self._dev.draw_polyline(_pts(pts), count))

    def DrawPolygon(self, pts, count=None, filled=False, fill_color=None):
        fill = fill_color if fill_color is not None else (0, 0, 0, 0)
        self._ok("DrawPolygon", self._dev.draw_polygon(_pts(pts), count, filled, fill))


class ActArrayProxy(ClientProxy):
    """``PlayerCc::ActArrayProxy``; ``ap[i]`` is ``GetActuatorData(i)`` as C++'s
    ``operator[]``."""

    _playerc = _pc.playerc_actarray

    RequestGeometry = _forward("get_geom")
    MoveTo = _forward("position_cmd")
    MoveToMulti = _forward("multi_position_cmd")
    MoveAtSpeed = _forward("speed_cmd")
    MoveAtSpeedMulti = _forward("multi_speed_cmd")
    SetActuatorCurrent = _forward("current_cmd")
    SetActuatorCurrentMulti = _forward("multi_current_cmd")
    SetSpeedConfig = _forward("speed_config")
    GetCount = _field("actuators_count")
    GetBasePos = _field("base_pos")
    GetBaseOrientation = _field("base_orientation")

    def MoveHome(self, aJoint: int) -> None:
        """Sends ``aJoint`` (-1: all) home."""
        self._ok("MoveHome", self._dev.home_cmd(aJoint))

    def SetPowerConfig(self, aVal: bool) -> None:
        """Turns the power on or off; raises when the driver refuses, as in C++."""
        self._ok("SetPowerConfig", self._dev.power(1 if aVal else 0))

    def SetBrakesConfig(self, aVal: bool) -> None:
        """Sets the brakes; raises when the driver refuses."""
        self._ok("SetBrakesConfig", self._dev.brakes(1 if aVal else 0))

    def GetActuatorData(self, aJoint: int) -> "_pc.player_actarray_actuator_t":
        """Joint ``aJoint``'s state; all zero for a joint the array does not have, as in C++."""
        if 0 <= aJoint < self._dev.actuators_count:
            return self._dev.actuators_data[aJoint]
        return _pc.player_actarray_actuator_t(
            position=0.0, speed=0.0, acceleration=0.0, current=0.0, state=0
        )

    __getitem__ = GetActuatorData

    def GetActuatorGeom(self, aJoint: int) -> "_pc.player_actarray_actuatorgeom_t":
        """Joint ``aJoint``'s geometry (after ``RequestGeometry()``); all zero before it or
        for a joint the array does not have, as in C++."""
        if 0 <= aJoint < self._dev.actuators_geom_count:
            return self._dev.actuators_geom[aJoint]
        return _pc.player_actarray_actuatorgeom_t(
            type=0, length=0.0, orientation=_pc.player_orientation_3d_t(),
            axis=_pc.player_point_3d_t(), min=0.0, centre=0.0, max=0.0, home=0.0,
            config_speed=0.0, hasbrakes=0,
        )


class LogProxy(ClientProxy):
    """``PlayerCc::LogProxy``: recording (writelog) and replay (readlog) control."""

    _playerc = _pc.playerc_log

    GetType = _field("type")
    GetState = _field("state")
    QueryState = _forward("get_state")
    SetWriteState = _forward("set_write_state")
    SetReadState = _forward("set_read_state")
    Rewind = _forward("set_read_rewind")
    SetFilename = _forward("set_filename")

    def SetState(self, aState: int) -> None:
        """Recording or replay on or off, whichever the device does (its type is queried
        first if not known yet, as libplayerc++ does)."""
        if self._dev.type == 0:
            self.QueryState()
        if self._dev.type == _pc.PLAYER_LOG_TYPE_READ:
            self._ok("SetState", self._dev.set_read_state(aState))
        elif self._dev.type == _pc.PLAYER_LOG_TYPE_WRITE:
            self._ok("SetState", self._dev.set_write_state(aState))


class Graphics3dProxy(ClientProxy):
    """``PlayerCc::Graphics3dProxy``: ``Color``, ``Clear``, ``Draw(mode, points, count)``."""

    _playerc = _pc.playerc_graphics3d

    def Color(self, *args) -> None:
        """``Color(player_color_t)`` or ``Color(red, green, blue, alpha)``."""
        if len(args) == 1:
            self._ok("Color", self._dev.setcolor(args[0]))
        else:
            r, g, b, a = args
            self._ok("Color", self._dev.setcolor((a, r, g, b)))

    Clear = _forward("clear")

    def Draw(self, mode: int, pts: list, count: int = None) -> None:
        """Draws ``pts`` (``player_point_3d_t`` or ``(x, y, z)`` tuples) as ``mode``."""
        points = [(p.px, p.py, p.pz) if hasattr(p, "px") else tuple(p) for p in pts]
        self._ok("Draw", self._dev.draw(mode, points, count))


def _pts(pts):
    return [(p.px, p.py) if hasattr(p, "px") else tuple(p) for p in pts]


class CameraProxy(ClientProxy):
    """``PlayerCc::CameraProxy``."""

    _playerc = _pc.playerc_camera
    _fields = ("width", "height", "format", "compression")

    GetDepth = _field("bpp")
    GetImageSize = _field("image_count")

    def GetImage(self):
        """The image bytes (C++ copies them into a caller's buffer)."""
        return bytes(self._dev.image)

    def Decompress(self):
        self._dev.decompress()

    def SaveFrame(self, aPrefix, aWidth=4):
        self._frame = getattr(self, "_frame", -1) + 1
        self._dev.save(f"{aPrefix}{self._frame:0{aWidth}d}.ppm")


class MapProxy(ClientProxy):
    """``PlayerCc::MapProxy``."""

    _playerc = _pc.playerc_map
    _fields = ("resolution", "width", "height")

    RequestMap = _forward("get_map")

    def GetCellIndex(self, x, y):
        return y * self._dev.width + x

    def GetCell(self, x, y):
        return self._dev.cells[self.GetCellIndex(x, y)]

    def GetOriginX(self):
        return self._dev.origin[0]

    def GetOriginY(self):
        return self._dev.origin[1]

    def GetMap(self):
        return list(self._dev.cells)


class PlannerProxy(ClientProxy):
    """``PlayerCc::PlannerProxy``."""

    _playerc = _pc.playerc_planner
    _fields = ("path_valid", "path_done", "px", "py", "pa", "gx", "gy", "ga", "wx", "wy", "wa",
               "waypoint_count")

    SetGoalPose = _forward("set_cmd_pose")
    RequestWaypoints = _forward("get_waypoints")
    SetEnable = _forward("enable")

    GetIx = _component("waypoints", 0)
    GetIy = _component("waypoints", 1)
    GetIa = _component("waypoints", 2)

    GetCurrentWaypointId = _field("curr_waypoint")

    def GetPose(self) -> player_pose2d_t:
        """The robot's current pose (``px``, ``py``, ``pa``)."""
        return player_pose2d_t(self._dev.px, self._dev.py, self._dev.pa)

    def GetGoal(self) -> player_pose2d_t:
        """The goal (``gx``, ``gy``, ``ga``)."""
        return player_pose2d_t(self._dev.gx, self._dev.gy, self._dev.ga)

    def GetCurrentWaypoint(self) -> player_pose2d_t:
        """The waypoint being driven to (``wx``, ``wy``, ``wa``)."""
        return player_pose2d_t(self._dev.wx, self._dev.wy, self._dev.wa)

    def GetWaypoint(self, aIndex: int) -> player_pose2d_t:
        """Waypoint ``aIndex`` of the list ``RequestWaypoints()`` fetched."""
        if not 0 <= aIndex < self._dev.waypoint_count:
            raise IndexError(f"waypoint {aIndex} of {self._dev.waypoint_count}")
        return player_pose2d_t(*self._dev.waypoints[aIndex])


class LocalizeProxy(ClientProxy):
    """``PlayerCc::LocalizeProxy``."""

    _playerc = _pc.playerc_localize
    _fields = ("pending_count", "pending_time", "hypoth_count", "num_particles")

    GetHypoth = _element("hypoths")
    GetNumHypoths = _field("hypoth_count")

    def GetParticles(self):
        self._ok("GetParticles", self._dev.get_particles())
        return 0

    def GetParticlePose(self, index):
        return self._dev.particles[index].pose

    SetPose = _forward("set_pose")


__all__ = [n for n in dir() if not n.startswith("_")]
