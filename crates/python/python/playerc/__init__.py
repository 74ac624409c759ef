"""Drop-in replacement for Player 3.0.2's SWIG ``playerc`` module, on Python 3.

Scripts written for the old bindings run unchanged::

    from playerc import *
    c = playerc_client(None, 'localhost', 6665)
    if c.connect() != 0:
        raise Exception(playerc_error_str())
    p = playerc_position2d(c, 0)
    if p.subscribe(PLAYERC_OPEN_MODE) != 0:
        raise Exception(playerc_error_str())
    while True:
        if c.read() is None:
            raise Exception(playerc_error_str())
        print(p.px, p.py, p.pa)
        p.set_cmd_vel(0.1, 0.0, 0.2, 1)

The conventions are libplayerc's, as SWIG exposed them: functions that return ``int`` in C
return 0 on success and -1 on failure (the message is then in ``playerc_error_str()``),
``client.read()`` returns an id (the client's own ``id`` in PULL mode, the updated proxy's
``info.id`` in PUSH mode) or ``None`` on error, proxies are created unsubscribed and carry
libplayerc's field names (``px``, ``ranges``, ``ranges_count``, ``scan``, ``blobs``, ...),
and ``playerc_simulation.get_pose2d`` returns ``[result, x, y, a]`` as SWIG's OUTPUT typemap
does.

Everything here is pure Python over ``playerstage._native.Connection``: the codec and the
session rules are the workspace's Rust ``player-client``.
"""

from typing import Optional as _Optional

from playerstage import _native

__all__ = []  # filled at the end: every public name, for `from playerc import *`

# --- constants (values of player.h / player_interfaces.h / playerc.h) -------------------------

PLAYER_OPEN_MODE = 1
PLAYER_CLOSE_MODE = 2
PLAYER_ERROR_MODE = 3
PLAYERC_OPEN_MODE = PLAYER_OPEN_MODE
PLAYERC_CLOSE_MODE = PLAYER_CLOSE_MODE
PLAYERC_ERROR_MODE = PLAYER_ERROR_MODE

PLAYER_DATAMODE_PUSH = 1
PLAYER_DATAMODE_PULL = 2

PLAYERC_TRANSPORT_TCP = 1
PLAYERC_TRANSPORT_UDP = 2

PLAYER_MSGTYPE_DATA = 1
PLAYER_MSGTYPE_CMD = 2
PLAYER_MSGTYPE_REQ = 3
PLAYER_MSGTYPE_RESP_ACK = 4
PLAYER_MSGTYPE_SYNCH = 5
PLAYER_MSGTYPE_RESP_NACK = 6

PLAYER_PLAYER_MSG_REPLACE_RULE_ACCEPT = 0
PLAYER_PLAYER_MSG_REPLACE_RULE_REPLACE = 1
PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE = 2

PLAYER_GRIPPER_STATE_OPEN = 1
PLAYER_GRIPPER_STATE_CLOSED = 2
PLAYER_GRIPPER_STATE_MOVING = 3
PLAYER_GRIPPER_STATE_ERROR = 4

PLAYER_POSITION2D_DATA_STATE = 1
PLAYER_POSITION2D_DATA_GEOM = 2
PLAYER_POSITION2D_CMD_VEL = 1
PLAYER_POSITION2D_CMD_POS = 2
PLAYER_POSITION2D_CMD_CAR = 3
PLAYER_POSITION2D_CMD_VEL_HEAD = 4
PLAYER_RANGER_DATA_RANGE = 1
PLAYER_RANGER_DATA_RANGESTAMPED = 2
PLAYER_RANGER_DATA_INTNS = 3
PLAYER_RANGER_DATA_INTNSSTAMPED = 4
PLAYER_RANGER_DATA_GEOM = 5
PLAYER_LASER_DATA_SCAN = 1
PLAYER_LASER_DATA_SCANPOSE = 2
PLAYER_LASER_DATA_SCANANGLE = 3
PLAYER_SONAR_DATA_RANGES = 1
PLAYER_SONAR_DATA_GEOM = 2
PLAYER_BLOBFINDER_DATA_BLOBS = 1
PLAYER_FIDUCIAL_DATA_SCAN = 1
PLAYER_GRIPPER_DATA_STATE = 1
PLAYER_CAMERA_DATA_STATE = 1
PLAYER_PLANNER_DATA_STATE = 1
PLAYER_LOCALIZE_DATA_HYPOTHS = 1

PLAYER_DRAW_POINTS = 0
PLAYER_DRAW_LINES = 1
PLAYER_DRAW_LINE_STRIP = 2
PLAYER_DRAW_LINE_LOOP = 3
PLAYER_DRAW_TRIANGLES = 4
PLAYER_DRAW_TRIANGLE_STRIP = 5
PLAYER_DRAW_TRIANGLE_FAN = 6
PLAYER_DRAW_QUADS = 7
PLAYER_DRAW_QUAD_STRIP = 8
PLAYER_DRAW_POLYGON = 9

PLAYER_ACTARRAY_ACTSTATE_IDLE = 1
PLAYER_ACTARRAY_ACTSTATE_MOVING = 2
PLAYER_ACTARRAY_ACTSTATE_BRAKED = 4
PLAYER_ACTARRAY_ACTSTATE_STALLED = 8
PLAYER_ACTARRAY_TYPE_LINEAR = 1
PLAYER_ACTARRAY_TYPE_ROTARY = 2
PLAYERC_ACTARRAY_ACTSTATE_IDLE = PLAYER_ACTARRAY_ACTSTATE_IDLE
PLAYERC_ACTARRAY_ACTSTATE_MOVING = PLAYER_ACTARRAY_ACTSTATE_MOVING
PLAYERC_ACTARRAY_ACTSTATE_BRAKED = PLAYER_ACTARRAY_ACTSTATE_BRAKED
PLAYERC_ACTARRAY_ACTSTATE_STALLED = PLAYER_ACTARRAY_ACTSTATE_STALLED
PLAYERC_ACTARRAY_TYPE_LINEAR = PLAYER_ACTARRAY_TYPE_LINEAR
PLAYERC_ACTARRAY_TYPE_ROTARY = PLAYER_ACTARRAY_TYPE_ROTARY

PLAYER_LOG_TYPE_READ = 1
PLAYER_LOG_TYPE_WRITE = 2

PLAYER_CAMERA_FORMAT_MONO8 = 1
PLAYER_CAMERA_FORMAT_MONO16 = 2
PLAYER_CAMERA_FORMAT_RGB565 = 4
PLAYER_CAMERA_FORMAT_RGB888 = 5
PLAYER_CAMERA_COMPRESS_RAW = 0
PLAYER_CAMERA_COMPRESS_JPEG = 1

# Interface codes, from the native module (the workspace's one table of them).
PLAYER_PLAYER_CODE = _native.PLAYER_PLAYER_CODE
PLAYER_POSITION2D_CODE = _native.PLAYER_POSITION2D_CODE
PLAYER_RANGER_CODE = _native.PLAYER_RANGER_CODE
PLAYER_LASER_CODE = _native.PLAYER_LASER_CODE
PLAYER_SONAR_CODE = _native.PLAYER_SONAR_CODE
PLAYER_BLOBFINDER_CODE = _native.PLAYER_BLOBFINDER_CODE
PLAYER_FIDUCIAL_CODE = _native.PLAYER_FIDUCIAL_CODE
PLAYER_GRIPPER_CODE = _native.PLAYER_GRIPPER_CODE
PLAYER_SIMULATION_CODE = _native.PLAYER_SIMULATION_CODE
PLAYER_SPEECH_CODE = _native.PLAYER_SPEECH_CODE
PLAYER_GRAPHICS2D_CODE = _native.PLAYER_GRAPHICS2D_CODE
PLAYER_GRAPHICS3D_CODE = _native.PLAYER_GRAPHICS3D_CODE
PLAYER_ACTARRAY_CODE = _native.PLAYER_ACTARRAY_CODE
PLAYER_LOG_CODE = _native.PLAYER_LOG_CODE
PLAYER_CAMERA_CODE = _native.PLAYER_CAMERA_CODE
PLAYER_MAP_CODE = _native.PLAYER_MAP_CODE
PLAYER_PLANNER_CODE = _native.PLAYER_PLANNER_CODE
PLAYER_LOCALIZE_CODE = _native.PLAYER_LOCALIZE_CODE



def PLAYERC_MAP_INDEX(map, i, j):
    """Index of cell (i, j) in ``map.cells``."""
    return map.width * j + i


_NAMES = {
    getattr(_native, n): n[len("PLAYER_"):-len("_CODE")].lower()
    for n in dir(_native)
    if n.startswith("PLAYER_") and n.endswith("_CODE")
}


def playerc_lookup_name(code):
    """The interface name of a code (``playerc_lookup_name``), e.g. 4 -> ``position2d``."""
    return _NAMES.get(code, "unknown")


def playerc_lookup_code(name):
    """The code of an interface name (``playerc_lookup_code``); -1 when unknown."""
    for code, n in _NAMES.items():
        if n == name:
            return code
    return -1


# --- errors -------------------------------------------------------------------------------------

_last_error = ""
_last_exception = None


def _fail(err):
    """Records an error for ``playerc_error_str()`` and returns libplayerc's -1. The
    exception itself is kept for ``playerstage``, which raises it."""
    global _last_error, _last_exception
    _last_error = str(err)
    _last_exception = err if isinstance(err, Exception) else _native.PlayerError(str(err))
    return -1


def playerc_error_str():
    """The message of the last failed call (libplayerc's ``playerc_error_str``)."""
    return _last_error


def _refused() -> bool:
    """Whether the last failed call was refused by the server (a NACK), not lost or timed out:
    libplayerc++ ignores some NACKs, never a dead connection."""
    return isinstance(_last_exception, _native.RequestRefused)


# --- destroyed proxies and clients ---------------------------------------------------------------


class _DestroyedError(_native.PlayerError, ReferenceError):
    """A proxy or client was used after ``destroy()``. libplayerc's ``playerc_X_destroy`` frees
    the struct, so the SWIG bindings then read freed memory; here the use raises this instead,
    naming what was destroyed. It is a ``ReferenceError`` (a use of something gone) and a
    ``PlayerError``, so a proxy whose client was destroyed returns -1 from its calls."""


class _Destroyed:
    """What a proxy or client becomes in ``destroy()``: every attribute it had (fields and
    methods alike) raises :class:`_DestroyedError`. Swapping the class, rather than checking a
    flag in every method, keeps the living objects' attribute reads as fast as before."""

    def __getattribute__(self, name: str):
        if name in ("__class__", "__dict__"):
            return object.__getattribute__(self, name)
        what = object.__getattribute__(self, "__dict__").get("_destroyed_what", "object")
        raise _DestroyedError(
            f"{what} was destroyed: destroy() frees it, as libplayerc's does; create a new one"
        )

    def __setattr__(self, name: str, value) -> None:
        self.__getattribute__(name)  # raises

    def __repr__(self) -> str:
        what = object.__getattribute__(self, "__dict__").get("_destroyed_what", "object")
        return f"<{what} (destroyed)>"


def _destroy(obj, what: str) -> None:
    """Turns ``obj`` into a :class:`_Destroyed` that names itself ``what``."""
    obj.__dict__["_destroyed_what"] = what
    obj.__class__ = _Destroyed


# --- plain structs ------------------------------------------------------------------------------


class _Struct:
    """A C struct as SWIG shows it: fields as attributes."""

    def __init__(self, **fields):
        self.__dict__.update(fields)

    def __repr__(self):
        inner = ", ".join(f"{k}={v!r}" for k, v in self.__dict__.items())
        return f"{type(self).__name__}({inner})"

    def __eq__(self, other):
        return type(self) is type(other) and self.__dict__ == other.__dict__


class player_pose2d_t(_Struct):
    """``player_pose2d_t``: px, py, pa."""

    def __init__(self, px=0.0, py=0.0, pa=0.0):
        super().__init__(px=px, py=py, pa=pa)


class player_pose3d_t(_Struct):
    """``player_pose3d_t``: px, py, pz, proll, ppitch, pyaw."""

    def __init__(self, px=0.0, py=0.0, pz=0.0, proll=0.0, ppitch=0.0, pyaw=0.0):
        super().__init__(px=px, py=py, pz=pz, proll=proll, ppitch=ppitch, pyaw=pyaw)


class player_point_3d_t(_Struct):
    """``player_point_3d_t``: px, py, pz."""

    def __init__(self, px=0.0, py=0.0, pz=0.0):
        super().__init__(px=px, py=py, pz=pz)


class player_orientation_3d_t(_Struct):
    """``player_orientation_3d_t``: proll, ppitch, pyaw."""

    def __init__(self, proll=0.0, ppitch=0.0, pyaw=0.0):
        super().__init__(proll=proll, ppitch=ppitch, pyaw=pyaw)


class player_actarray_actuator_t(_Struct):
    """One actuator's state: position, speed, acceleration, current, state."""


class player_actarray_actuatorgeom_t(_Struct):
    """One actuator's geometry: type, length, orientation (``player_orientation_3d_t``), axis
    (``player_point_3d_t``), min, centre, max, home, config_speed, hasbrakes."""


class player_bbox3d_t(_Struct):
    """``player_bbox3d_t``: sw, sl, sh."""

    def __init__(self, sw=0.0, sl=0.0, sh=0.0):
        super().__init__(sw=sw, sl=sl, sh=sh)


class player_point_2d_t(_Struct):
    """``player_point_2d_t``: px, py."""

    def __init__(self, px=0.0, py=0.0):
        super().__init__(px=px, py=py)


class player_color_t(_Struct):
    """``player_color_t``: alpha, red, green, blue."""

    def __init__(self, alpha=0, red=0, green=0, blue=0):
        super().__init__(alpha=alpha, red=red, green=green, blue=blue)


class playerc_blobfinder_blob_t(_Struct):
    """One blob: id, color, area, x, y, left, right, top, bottom, range."""


class player_fiducial_item_t(_Struct):
    """One fiducial: id, pose and upose (``player_pose3d_t``)."""


class player_localize_hypoth_t(_Struct):
    """One pose hypothesis: mean (``player_pose2d_t``), cov (3 doubles), alpha."""


def _value_bytes(value) -> bytes:
    """The bytes of a C value passed from Python: a buffer (``bytes``, ``bytearray``, ctypes
    objects, ``array.array``: their memory as it is) or a sequence of byte values (as SWIG's
    ``uint8_t data[]`` typemap takes them)."""
    try:
        return memoryview(value).cast("B").tobytes()
    except TypeError:
        pass
    if isinstance(value, (list, tuple)):
        try:
            return bytes(value)
        except (TypeError, ValueError) as e:
            raise TypeError(f"a value given as a list holds byte values 0..255: {e}") from None
    raise TypeError(f"a value is a buffer or a list of byte values, not {type(value).__name__}")


def _writable_bytes(value) -> _Optional[memoryview]:
    """A writable byte view of ``value``'s memory, or ``None`` when it has none (immutable
    objects such as ``bytes``, numbers or ``None``)."""
    try:
        view = memoryview(value)
    except TypeError:
        return None
    if view.readonly or not view.c_contiguous:
        return None
    return view.cast("B")


def _pose3d(v):
    return player_pose3d_t(*v)


def _bbox3d(v):
    return player_bbox3d_t(*v)


def _planar(pose, size):
    """libplayerc's planar geometry of a 2-D device (position2d, laser) from the 3-D one on
    the wire: pose ``[x, y, yaw]`` and size ``[length, width]``."""
    return [pose[0], pose[1], pose[5]], [size[1], size[0]]


# --- the client ---------------------------------------------------------------------------------


class playerc_device_info:
    """A proxy's ``info`` (``playerc_device_t``): ``id`` (what ``client.read()`` returns in
    PUSH mode for this proxy), ``datatime``, ``lasttime``, ``fresh``, ``subscribed``,
    ``drivername``, ``addr``."""

    def __init__(self, proxy, code, index):
        self.id = id(proxy)
        self.datatime = 0.0
        self.lasttime = 0.0
        self.fresh = 0
        self.freshgeom = 0
        self.subscribed = 0
        self.drivername = ""
        self.addr = _Struct(host=0, robot=0, interf=code, index=index)
        self._proxy = proxy

    # libplayerc's playerc_device_* functions, which the SWIG bindings made methods of `info`.

    def subscribe(self, access: int) -> int:
        """``playerc_device_subscribe``: the proxy's ``subscribe``. 0 / -1."""
        return self._proxy.subscribe(access)

    def unsubscribe(self) -> int:
        """``playerc_device_unsubscribe``: the proxy's ``unsubscribe``. 0 / -1."""
        return self._proxy.unsubscribe()

    def term(self) -> None:
        """``playerc_device_term``: takes the proxy off its client's device list (reads stop
        updating it), as ``destroy()`` does before freeing it; the subscription stays."""
        self._proxy.client._remove(self._proxy)

    def hascapability(self, type: int, subtype: int) -> int:
        """``playerc_device_hascapability``: 1 when the device handles messages of (``type``,
        ``subtype``), e.g. ``(PLAYER_MSGTYPE_REQ, PLAYER_LASER_REQ_GET_GEOM)``; 0 when it does
        not or the question could not be asked (as libplayerc)."""
        try:
            conn = self._proxy._conn()
            return int(conn.device_has_capability(self.addr.interf, self.addr.index, type, subtype))
        except _native.PlayerError as e:
            _fail(e)
            return 0

    def _get_prop(self, kind: str, property: str, default):
        try:
            conn = self._proxy._conn()
            value = conn.device_get_prop(self.addr.interf, self.addr.index, kind, property)
        except _native.PlayerError as e:
            return [_fail(e), default]
        return [0, value]

    def _set_prop(self, kind: str, property: str, value) -> int:
        try:
            conn = self._proxy._conn()
            conn.device_set_prop(self.addr.interf, self.addr.index, kind, property, value)
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def get_boolprop(self, property: str) -> list:
        """``playerc_device_get_boolprop``: ``[result, value]`` (the C output argument is
        returned, as SWIG's OUTPUT typemap does); ``[-1, 0]`` when the device has no such
        property (the server NACKs) or the request failed."""
        return self._get_prop("bool", property, 0)

    def set_boolprop(self, property: str, value: int) -> int:
        """``playerc_device_set_boolprop``. 0 / -1."""
        return self._set_prop("bool", property, bool(value))

    def get_intprop(self, property: str) -> list:
        """``playerc_device_get_intprop``: ``[result, value]``, as ``get_boolprop``."""
        return self._get_prop("int", property, 0)

    def set_intprop(self, property: str, value: int) -> int:
        """``playerc_device_set_intprop``. 0 / -1."""
        return self._set_prop("int", property, int(value))

    def get_dblprop(self, property: str) -> list:
        """``playerc_device_get_dblprop``: ``[result, value]``, as ``get_boolprop``."""
        return self._get_prop("dbl", property, 0.0)

    def set_dblprop(self, property: str, value: float) -> int:
        """``playerc_device_set_dblprop``. 0 / -1."""
        return self._set_prop("dbl", property, float(value))

    def get_strprop(self, property: str) -> list:
        """``playerc_device_get_strprop``: ``[result, value]``, as ``get_boolprop``."""
        return self._get_prop("str", property, "")

    def set_strprop(self, property: str, value: str) -> int:
        """``playerc_device_set_strprop``. 0 / -1."""
        return self._set_prop("str", property, str(value))


class playerc_device_t(_Struct):
    """One entry of ``client.devinfos`` after ``get_devlist()``."""


class playerc_client:
    """``playerc_client_t``: ``playerc_client(None, host, port)``; the first argument (an
    mclient) is accepted and ignored."""

    def __init__(self, mclient, host, port):
        self.host = host
        self.port = int(port)
        self.id = id(self)
        self.mode = PLAYER_DATAMODE_PULL
        self.datatime = 0.0
        self.lasttime = 0.0
        self.devinfos = []
        self.devinfo_count = 0
        self.request_timeout = 5.0
        self.retry_limit = 0
        self.retry_time = 2.0
        self.transport = PLAYERC_TRANSPORT_TCP
        self._conn = None
        self._proxies = {}  # (code, index) -> [proxy, ...] subscribed through this client

    def destroy(self) -> None:
        """``playerc_client_destroy``: frees the client. Its connection is closed (libplayerc
        leaves the socket open but unreachable); afterwards any use of the client raises a
        ``ReferenceError`` and its proxies' calls return -1 saying the client was destroyed."""
        if self._conn is not None:
            self._conn.disconnect()
            self._conn = None
        _destroy(self, f"playerc_client {self.host}:{self.port}")

    def set_transport(self, transport: int) -> None:
        """``playerc_client_set_transport``: ``PLAYERC_TRANSPORT_TCP`` (the default and the
        only one served: ``connect()`` with ``PLAYERC_TRANSPORT_UDP`` fails)."""
        self.transport = int(transport)

    def _connection(self):
        if self._conn is None:
            raise _native.ConnectionLost(f"not connected to {self.host}:{self.port}")
        return self._conn

    def connect(self):
        """Connects (PULL mode, as libplayerc). 0 on success, -1 on failure."""
        if self.transport != PLAYERC_TRANSPORT_TCP:
            return _fail(
                f"transport {self.transport} is not supported: Player servers here speak TCP"
            )
        try:
            self._conn = _native.Connection(self.host, self.port)
            self._conn.set_request_timeout(self.request_timeout)
            self.mode = PLAYER_DATAMODE_PULL
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def disconnect(self):
        """Closes the connection. 0 on success, -1 when not connected."""
        if self._conn is None:
            return _fail("not connected")
        self._conn.disconnect()
        self._conn = None
        for proxies in self._proxies.values():
            for p in proxies:
                p.info.subscribed = 0
        self._proxies.clear()
        return 0

    def set_retry_limit(self, limit: int) -> None:
        """``playerc_client_set_retry_limit``: how many times ``disconnect_retry()`` tries to
        reconnect (-1: until it succeeds; libplayerc's default 0)."""
        self.retry_limit = int(limit)

    def set_retry_time(self, time: float) -> None:
        """``playerc_client_set_retry_time``: seconds between reconnection attempts (2)."""
        self.retry_time = float(time)

    def disconnect_retry(self) -> int:
        """``playerc_client_disconnect_retry``: drops the connection and reconnects, up to
        ``retry_limit`` attempts ``retry_time`` seconds apart, subscribing again every proxy
        that was subscribed (in OPEN mode, as libplayerc). 0 once reconnected, -1 when the
        attempts ran out (libplayerc's default limit, 0, means none are made)."""
        import time

        subscribed = [p for ps in self._proxies.values() for p in ps if p.info.subscribed]
        if self._conn is not None:
            self.disconnect()
        attempt = 0
        while self.retry_limit < 0 or attempt < self.retry_limit:
            attempt += 1
            if self.connect() == 0:
                if all(p.subscribe(PLAYERC_OPEN_MODE) == 0 for p in subscribed):
                    return 0
                self.disconnect()
            time.sleep(self.retry_time)
        return _fail(f"could not reconnect to {self.host}:{self.port} "
                     f"({attempt} attempts, retry_limit {self.retry_limit})")

    def subscribe(self, code: int, index: int, access: int, drivername=None, size: int = 0) -> int:
        """``playerc_client_subscribe``: subscribes to a device without a proxy (its data is
        then read and dropped). ``drivername``, when a ``bytearray``, receives the driver's
        name, NUL-terminated and cut to ``size`` bytes (the C buffer's length; the whole
        bytearray when 0). 0 / -1."""
        if access != PLAYERC_OPEN_MODE:
            return _fail(f"unsupported access mode {access}")
        try:
            name = self._connection().subscribe(code, index)
        except _native.PlayerError as e:
            return _fail(e)
        if isinstance(drivername, bytearray):
            room = min(size or len(drivername), len(drivername))
            if room > 0:
                raw = name.encode()[: room - 1] + b"\0"
                drivername[: len(raw)] = raw
        return 0

    def unsubscribe(self, code: int, index: int) -> int:
        """``playerc_client_unsubscribe``. 0 / -1."""
        try:
            self._connection().unsubscribe(code, index)
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def adddevice(self, device) -> int:
        """``playerc_client_adddevice``: puts a proxy (given by its ``info``) back on the list
        of devices reads update. 0 / -1."""
        proxy = getattr(device, "_proxy", None)
        if proxy is None or proxy.client is not self:
            return _fail("adddevice: not the info of one of this client's proxies")
        if proxy not in self._proxies.get((proxy._code, proxy.index), []):
            self._add(proxy)
        return 0

    def deldevice(self, device) -> int:
        """``playerc_client_deldevice``: takes a proxy (given by its ``info``) off the list of
        devices reads update. 0, or -1 for a device not on the list ("unknown device")."""
        proxy = getattr(device, "_proxy", None)
        if proxy is None or proxy not in self._proxies.get((proxy._code, proxy.index), []):
            return _fail("unknown device")
        self._remove(proxy)
        return 0

    def datamode(self, mode):
        """``PLAYER_DATAMODE_PUSH`` or ``PLAYER_DATAMODE_PULL``. 0 / -1."""
        if mode not in (PLAYER_DATAMODE_PUSH, PLAYER_DATAMODE_PULL):
            return _fail(f"unknown data mode {mode}")
        try:
            self._connection().set_pull(mode == PLAYER_DATAMODE_PULL)
            self.mode = mode
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def set_replace_rule(self, interf, index, type, subtype, replace):
        """``playerc_client_set_replace_rule``: -1 is a wildcard; ``replace`` 0 accept,
        1 replace, 2 ignore. 0 / -1."""
        try:
            self._connection().set_replace_rule(interf, index, type, subtype, replace)
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def set_request_timeout(self, seconds):
        """How long requests wait for their reply (libplayerc's default, 5 s)."""
        self.request_timeout = float(seconds)
        if self._conn is not None:
            self._conn.set_request_timeout(self.request_timeout)

    def get_devlist(self):
        """Fills ``devinfos`` / ``devinfo_count``. 0 / -1."""
        try:
            devs = self._connection().device_list()
        except _native.PlayerError as e:
            return _fail(e)
        self.devinfos = [
            playerc_device_t(
                addr=_Struct(host=0, robot=self.port, interf=code, index=index),
                drivername=driver,
            )
            for code, index, driver in devs
        ]
        self.devinfo_count = len(self.devinfos)
        return 0

    def read(self):
        """One read: a PULL round or one PUSH message. Returns ``self.id`` (PULL) or the
        updated proxy's ``info.id`` (PUSH); ``None`` on error (see ``playerc_error_str``).
        A dropped connection is an error, never a hang."""
        try:
            updates = self._connection().read()
        except _native.PlayerError as e:
            _fail(e)
            return None
        last = self._dispatch(updates)
        if self.mode == PLAYER_DATAMODE_PULL or last is None:
            return self.id
        return last.info.id

    def _dispatch(self, updates: list):
        """Hands a read's updates to the proxies of their devices; the last proxy updated."""
        last = None
        for code, index, t, fields in updates:
            self.lasttime, self.datatime = self.datatime, t
            for p in self._proxies.get((code, index), ()):
                p._update(t, fields)
                last = p
        return last

    def requestdata(self) -> int:
        """``playerc_client_requestdata``: in PULL mode asks the server for a round of data,
        unless one is asked for already (``read()`` and ``peek()`` do it themselves). 0 / -1."""
        try:
            self._connection().request_data()
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def _peek(self, timeout: int, request: bool) -> int:
        seconds = None if timeout < 0 else timeout / 1000.0
        try:
            return int(self._connection().peek(seconds, request))
        except _native.PlayerError as e:
            return _fail(e)

    def peek(self, timeout: int) -> int:
        """``playerc_client_peek``: 1 when data is waiting to be read, 0 when none came within
        ``timeout`` milliseconds (negative: wait as long as it takes), -1 on error. In PULL
        mode a round of data is asked for first, as libplayerc does; nothing is consumed."""
        return self._peek(timeout, True)

    def internal_peek(self, timeout: int) -> int:
        """``playerc_client_internal_peek``: ``peek`` without asking for data."""
        return self._peek(timeout, False)

    def read_nonblock(self) -> int:
        """``playerc_client_read_nonblock``: handles the data that has arrived without
        waiting: 1 when it completed a read (a PUSH message, or a PULL round after
        ``requestdata()``), 0 when nothing that completes one is waiting, -1 on error. The
        proxies are updated as by ``read()``."""
        try:
            updates = self._connection().read_nonblock()
        except _native.PlayerError as e:
            return _fail(e)
        if updates is None:
            return 0
        self._dispatch(updates)
        return 1

    def _add(self, proxy):
        self._proxies.setdefault((proxy._code, proxy.index), []).append(proxy)

    def _remove(self, proxy):
        lst = self._proxies.get((proxy._code, proxy.index), [])
        if proxy in lst:
            lst.remove(proxy)


# --- proxies ------------------------------------------------------------------------------------


def _command(method, what):
    """A playerc function that sends the command ``what`` through the connection's
    ``method`` (``gripper_cmd``, ``simulation_cmd``) and returns 0 or -1: one line per
    command instead of a method each."""

    def send(self):
        return self._call(getattr(self._conn(), method), self.index, what)

    return send


class _device:
    """What every proxy shares (``playerc_device_t``): subscribe/unsubscribe and ``info``."""

    _code = None

    def __init__(self, client, index):
        self.client = client
        self.index = int(index)
        self.info = playerc_device_info(self, self._code, self.index)
        self._defaults()

    def _defaults(self):
        pass

    def _conn(self):
        return self.client._connection()

    def subscribe(self, access):
        """Subscribes (``PLAYERC_OPEN_MODE``). 0 / -1 (no such device: -1)."""
        if access != PLAYERC_OPEN_MODE:
            return _fail(f"unsupported access mode {access}")
        try:
            self.info.drivername = self._conn().subscribe(self._code, self.index)
        except _native.PlayerError as e:
            return _fail(e)
        self.info.subscribed = 1
        self.client._add(self)
        return 0

    def unsubscribe(self):
        """Ends the subscription. 0 / -1."""
        self.client._remove(self)
        self.info.subscribed = 0
        try:
            self._conn().unsubscribe(self._code, self.index)
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def destroy(self) -> None:
        """``playerc_<interface>_destroy``: frees the proxy, as libplayerc's does. It leaves
        its client's device list, so reads no longer update it; it is not unsubscribed (call
        ``unsubscribe()`` first for that, as in C: the server keeps sending its data, which
        reads then drop). Any later use of the proxy or its ``info`` raises a
        ``ReferenceError`` naming it, where the SWIG bindings read freed memory."""
        try:
            self.client._remove(self)
        except _DestroyedError:
            pass  # the client went first: nothing to leave
        what = f"{type(self).__name__} {playerc_lookup_name(self._code)}:{self.index}"
        _destroy(self.info, f"the info of {what}")
        _destroy(self, what)

    def _call(self, fn, *args):
        """Runs a request; 0, or -1 with the error recorded."""
        try:
            fn(*args)
            return 0
        except _native.PlayerError as e:
            return _fail(e)

    def _answer(self, request, *args):
        """Runs ``request`` (the name of a ``Connection`` method) for this device: its answer,
        or ``None`` with the error recorded (the caller then returns libplayerc's -1)."""
        try:
            return getattr(self._conn(), request)(self.index, *args)
        except _native.PlayerError as e:
            _fail(e)
            return None

    def _config(self, request, *args):
        """A request answered with a dict of libplayerc field names (a configuration), copied
        onto the proxy; the dict, or ``None`` as ``_answer``."""
        c = self._answer(request, *args)
        if c is not None:
            self.__dict__.update(c)
        return c

    def _update(self, t, fields):
        self.info.lasttime = self.info.datatime
        self.info.datatime = t
        self.info.fresh = 1
        self._apply(fields)

    def _apply(self, fields):
        self.__dict__.update(fields)

    def _take(self, fields, *names):
        """Copies the named fields a message carries; the others keep their values."""
        for name in names:
            if name in fields:
                setattr(self, name, fields[name])

    def _take_array(self, fields, name, count, make):
        """A libplayerc array and its count: when the message carries ``name``, the proxy's
        ``name`` becomes the list of its entries, each made by ``make``, and ``count`` their
        number; otherwise both keep their values."""
        if name in fields:
            items = [make(entry) for entry in fields[name]]
            setattr(self, name, items)
            setattr(self, count, len(items))


class playerc_position2d(_device):
    """``playerc_position2d_t``: px py pa (odometry), vx vy va, stall, pose/size (geometry)."""

    _code = PLAYER_POSITION2D_CODE

    def _defaults(self):
        self.px = self.py = self.pa = 0.0
        self.vx = self.vy = self.va = 0.0
        self.stall = 0
        self.pose = [0.0, 0.0, 0.0]
        self.size = [0.0, 0.0]

    def _apply(self, fields):
        fields = dict(fields)
        pose, size = fields.pop("pose", None), fields.pop("size", None)
        self.__dict__.update(fields)
        if pose is not None:  # a GEOM data message
            self.pose, self.size = _planar(pose, size)

    def enable(self, enable):
        return self._call(self._conn().position2d_enable, self.index, bool(enable))

    def get_geom(self):
        g = self._answer("position2d_get_geom")
        if g is None:
            return -1
        self.pose, self.size = _planar(g["pose"], g["size"])
        self.info.freshgeom = 1
        return 0

    def set_cmd_vel(self, vx, vy, va, state=1):
        return self._call(self._conn().position2d_set_cmd_vel, self.index, vx, vy, va, state)

    def set_cmd_vel_head(self, vx, vy, pa, state=1):
        return self._call(self._conn().position2d_set_cmd_vel_head, self.index, vx, pa)

    def set_cmd_pose_with_vel(self, pos, vel, state=1):
        pos = [pos.px, pos.py, pos.pa] if hasattr(pos, "px") else list(pos)
        vel = [vel.px, vel.py, vel.pa] if hasattr(vel, "px") else list(vel)
        return self._call(
            self._conn().position2d_set_cmd_pose_with_vel, self.index, pos, vel, state
        )

    def set_cmd_pose(self, gx, gy, ga, state=1):
        return self._call(
            self._conn().position2d_set_cmd_pose_with_vel,
            self.index,
            [gx, gy, ga],
            [0.0, 0.0, 0.0],
            state,
        )

    def set_cmd_car(self, vx, a):
        return self._call(self._conn().position2d_set_cmd_car, self.index, vx, a)

    def set_odom(self, ox, oy, oa):
        return self._call(self._conn().position2d_set_odom, self.index, [ox, oy, oa])


class playerc_ranger(_device):
    """``playerc_ranger_t``: ranges/ranges_count, intensities, bearings, points, geometry
    (element_count, device_pose, element_poses, ...) and configuration."""

    _code = PLAYER_RANGER_CODE

    def _defaults(self):
        self.element_count = 0
        self.device_pose = player_pose3d_t()
        self.device_size = player_bbox3d_t()
        self.element_poses = []
        self.element_sizes = []
        self.min_angle = self.max_angle = self.angular_res = 0.0
        self.min_range = self.max_range = self.range_res = self.frequency = 0.0
        self.ranges_count = 0
        self.ranges = []
        self.intensities_count = 0
        self.intensities = []
        self.bearings_count = 0
        self.bearings = []
        self.points_count = 0
        self.points = []

    def _apply(self, fields):
        geom = "device_pose" in fields
        self.__dict__.update(fields)
        if geom:
            self._geom(fields)
        self._derive()

    def _geom(self, g):
        self.element_count = g["element_count"]
        self.device_pose = _pose3d(g["device_pose"])
        self.device_size = _bbox3d(g["device_size"])
        self.element_poses = [_pose3d(p) for p in g["element_poses"]]
        self.element_sizes = [_bbox3d(s) for s in g["element_sizes"]]
        self.info.freshgeom = 1

    def _derive(self):
        """Bearings and points as libplayerc computes them from the configuration."""
        import math

        n = len(self.ranges)
        if n == 0:
            return
        step = self.angular_res
        if n > 1 and step == 0.0:
            step = (self.max_angle - self.min_angle) / (n - 1)
        self.bearings = [self.min_angle + i * step for i in range(n)]
        self.bearings_count = n
        self.points = [
            player_point_2d_t(r * math.cos(b), r * math.sin(b))
            for r, b in zip(self.ranges, self.bearings)
        ]
        self.points_count = n

    def get_geom(self):
        g = self._answer("ranger_get_geom")
        if g is None:
            return -1
        self._geom(g)
        return 0

    def get_config(self):
        """Fetches the configuration into the proxy's fields; returns
        ``[0, min_angle, max_angle, angular_res, min_range, max_range, range_res,
        frequency]`` as SWIG's OUTPUT typemap would (``[-1]`` on failure)."""
        c = self._config("ranger_get_config")
        if c is None:
            return [-1]
        keys = ("min_angle", "max_angle", "angular_res", "min_range", "max_range", "range_res",
                "frequency")
        return [0] + [c[k] for k in keys]

    def set_config(
        self, min_angle, max_angle, angular_res, min_range, max_range, range_res, frequency
    ):
        config = (min_angle, max_angle, angular_res, min_range, max_range, range_res, frequency)
        return -1 if self._config("ranger_set_config", *config) is None else 0

    def power_config(self, value):
        return self._call(self._conn().ranger_power_config, self.index, int(value))

    def intns_config(self, value):
        return self._call(self._conn().ranger_intns_config, self.index, int(value))


class playerc_laser(_device):
    """``playerc_laser_t``: scan_count, scan[i] = [range, bearing], ranges, intensity,
    point[i] = [x, y], min/max_angle, scan_res, max_range, robot_pose, pose/size."""

    _code = PLAYER_LASER_CODE

    def _defaults(self):
        self.pose = [0.0, 0.0, 0.0]
        self.size = [0.15, 0.15]
        self.robot_pose = [0.0, 0.0, 0.0]
        self.intensity_on = 0
        self.scan_count = 0
        self.scan_start = self.scan_res = self.range_res = 0.0
        self.min_angle = self.max_angle = self.max_range = 0.0
        self.scanning_frequency = 0.0
        self.ranges = []
        self.scan = []
        self.point = []
        self.intensity = []
        self.scan_id = 0
        self.laser_id = 0

    def _apply(self, fields):
        self.__dict__.update(fields)
        if "min_angle" in fields:
            self.scan_start = self.min_angle

    def get_geom(self):
        g = self._answer("laser_get_geom")
        if g is None:
            return -1
        self.pose, self.size = _planar(g["pose"], g["size"])
        return 0

    def get_config(self):
        """``[0, min_angle, max_angle, resolution, range_res, intensity,
        scanning_frequency]`` (``[-1]`` on failure), as SWIG's OUTPUT typemap."""
        c = self._config("laser_get_config")
        if c is None:
            return [-1]
        keys = ("min_angle", "max_angle", "scan_res", "range_res", "intensity_on",
                "scanning_frequency")
        return [0] + [c[k] for k in keys]

    def set_config(
        self, min_angle, max_angle, resolution, range_res, intensity, scanning_frequency
    ):
        config = (min_angle, max_angle, resolution, range_res, int(intensity), scanning_frequency)
        return -1 if self._config("laser_set_config", *config) is None else 0

    def get_id(self) -> int:
        """``playerc_laser_get_id``: fetches the device's serial number into ``laser_id``.
        0 / -1."""
        serial = self._answer("laser_get_id")
        if serial is None:
            return -1
        self.laser_id = serial
        return 0

    def printout(self, prefix: _Optional[str] = None) -> None:
        """``playerc_laser_printout``: the timestamp, scan id and count, then the ranges, on
        stdout in libplayerc's format."""
        if prefix:
            print(f"{prefix}: ", end="")
        print(
            f"[{self.info.datatime:14.3f}] scan_id: {self.scan_id}  "
            f"scan_count: {self.scan_count}"
        )
        print("# ranges")
        print("".join(f"{r:.3f} " for r in self.ranges[: self.scan_count]))


class playerc_sonar(_device):
    """``playerc_sonar_t``: scan_count/scan (ranges), pose_count/poses (geometry)."""

    _code = PLAYER_SONAR_CODE

    def _defaults(self):
        self.pose_count = 0
        self.poses = []
        self.scan_count = 0
        self.scan = []

    def get_geom(self):
        return -1 if self._config("sonar_get_geom") is None else 0


class playerc_blobfinder(_device):
    """``playerc_blobfinder_t``: width, height, blobs_count, blobs[i] (id, color, area, x, y,
    left, right, top, bottom, range)."""

    _code = PLAYER_BLOBFINDER_CODE

    def _defaults(self):
        self.width = self.height = 0
        self.blobs_count = 0
        self.blobs = []

    def _apply(self, fields):
        self._take(fields, "width", "height")
        self._take_array(fields, "blobs", "blobs_count", lambda b: playerc_blobfinder_blob_t(**b))


def _fiducial_item(f):
    return player_fiducial_item_t(id=f["id"], pose=_pose3d(f["pose"]), upose=_pose3d(f["upose"]))


class playerc_fiducial(_device):
    """``playerc_fiducial_t``: fiducials_count, fiducials[i] (id, pose, upose), fiducial_geom
    (pose, size, fiducial_size)."""

    _code = PLAYER_FIDUCIAL_CODE

    def _defaults(self):
        self.fiducials_count = 0
        self.fiducials = []
        self.fiducial_geom = _Struct(
            pose=player_pose3d_t(), size=player_bbox3d_t(), fiducial_size=[0.0, 0.0]
        )

    def _apply(self, fields):
        self._take_array(fields, "fiducials", "fiducials_count", _fiducial_item)

    def get_geom(self):
        g = self._answer("fiducial_get_geom")
        if g is None:
            return -1
        self.fiducial_geom = _Struct(
            pose=_pose3d(g["pose"]), size=_bbox3d(g["size"]), fiducial_size=g["fiducial_size"]
        )
        return 0


class playerc_gripper(_device):
    """``playerc_gripper_t``: state, beams, stored; pose, outer_size, inner_size, num_beams,
    capacity (geometry)."""

    _code = PLAYER_GRIPPER_CODE

    def _defaults(self):
        self.pose = player_pose3d_t()
        self.outer_size = player_bbox3d_t()
        self.inner_size = player_bbox3d_t()
        self.num_beams = 0
        self.capacity = 0
        self.state = 0
        self.beams = 0
        self.stored = 0

    open_cmd = _command("gripper_cmd", "open")
    close_cmd = _command("gripper_cmd", "close")
    stop_cmd = _command("gripper_cmd", "stop")
    store_cmd = _command("gripper_cmd", "store")
    retrieve_cmd = _command("gripper_cmd", "retrieve")

    def get_geom(self):
        g = self._answer("gripper_get_geom")
        if g is None:
            return -1
        self.pose = _pose3d(g["pose"])
        self.outer_size = _bbox3d(g["outer_size"])
        self.inner_size = _bbox3d(g["inner_size"])
        self.num_beams = g["num_beams"]
        self.capacity = g["capacity"]
        return 0

    def printout(self, prefix=""):
        names = {1: "OPEN", 2: "CLOSED", 3: "MOVING", 4: "ERROR"}
        print(
            f"{prefix}[{self.info.datatime:14.3f}] state[{names.get(self.state, '?')}] "
            f"beams[{self.beams:32X}] stored[{self.stored}]"
        )


class playerc_simulation(_device):
    """``playerc_simulation_t``: model poses and properties by name."""

    _code = PLAYER_SIMULATION_CODE

    def set_pose2d(self, name, gx, gy, ga):
        return self._call(self._conn().simulation_set_pose2d, self.index, name, [gx, gy, ga])

    def get_pose2d(self, name):
        """``[result, x, y, a]``: the C function's int and its three OUTPUT doubles."""
        p = self._answer("simulation_get_pose2d", name)
        return [-1, 0.0, 0.0, 0.0] if p is None else [0, *p]

    def set_pose3d(self, name, gx, gy, gz, groll, gpitch, gyaw):
        return self._call(
            self._conn().simulation_set_pose3d,
            self.index,
            name,
            [gx, gy, gz, groll, gpitch, gyaw],
        )

    def get_pose3d(self, name):
        """``[result, x, y, z, roll, pitch, yaw, time]``."""
        answer = self._answer("simulation_get_pose3d", name)
        if answer is None:
            return [-1] + [0.0] * 7
        p, t = answer
        return [0, *p, t]

    def set_property(
        self, name: str, property: str, value, value_len: _Optional[int] = None
    ) -> int:
        """``playerc_simulation_set_property(name, property, value, value_len)``: ``value`` is
        the property's C value as bytes, or any buffer holding it (``bytearray``, a ctypes
        object such as ``(ctypes.c_float * 4)(r, g, b, a)`` for "color", ``array.array``) or a
        list of byte values; ``value_len`` (optional) sends only its first bytes, as the C
        size argument. 0 / -1 (a property or model the simulator does not know: -1)."""
        try:
            data = _value_bytes(value)
        except TypeError as e:
            return _fail(e)
        if value_len is not None:
            if not 0 <= value_len <= len(data):
                return _fail(
                    f"set_property: value_len {value_len} but the value has {len(data)} bytes"
                )
            data = data[:value_len]
        return self._call(self._conn().simulation_set_property, self.index, name, property, data)

    def get_property(self, name: str, property: str, value=None, value_len: _Optional[int] = None):
        """``playerc_simulation_get_property``, called either way:

        * as in C, ``get_property(name, property, value, value_len)`` with ``value`` a writable
          buffer (``bytearray``, a ctypes object such as ``(ctypes.c_float * 4)()``,
          ``array.array``) of at least ``value_len`` bytes (default: all of it): the value's
          bytes are written into it and the C result (0 / -1) is returned;
        * with the value as an output, ``get_property(name, property[, value_len])`` or with
          ``value`` ``None``: ``[result, bytes]``, as SWIG's OUTPUT typemap returns output
          arguments (``value_len`` defaults to 16, a "color"'s four floats).

        Stage answers "color" (16 bytes: red, green, blue, alpha floats) and "time" (8 bytes:
        simulated microseconds); other properties, wrong sizes or unknown models give -1."""
        if value_len is None and isinstance(value, int) and not isinstance(value, bool):
            value, value_len = None, value  # get_property(name, property, value_len)
        if value is None:
            v = self._answer("simulation_get_property", name, property, value_len or 16)
            return [-1, b""] if v is None else [0, v]
        view = _writable_bytes(value)
        if view is None:
            return _fail(
                f"get_property: value must be a writable buffer (bytearray, ctypes object, "
                f"array.array) or None, not {type(value).__name__}"
            )
        size = view.nbytes if value_len is None else value_len
        if not 0 <= size <= view.nbytes:
            return _fail(f"get_property: value_len {size} but the buffer has {view.nbytes} bytes")
        v = self._answer("simulation_get_property", name, property, size)
        if v is None:
            return -1
        view[: len(v)] = v
        return 0

    pause = _command("simulation_cmd", "pause")
    reset = _command("simulation_cmd", "reset")
    save = _command("simulation_cmd", "save")


class playerc_speech(_device):
    """``playerc_speech_t``: ``say(text)``."""

    _code = PLAYER_SPEECH_CODE

    def say(self, text):
        return self._call(self._conn().speech_say, self.index, str(text))


def _color_tuple(c):
    if isinstance(c, player_color_t):
        return (c.alpha, c.red, c.green, c.blue)
    if isinstance(c, tuple) and len(c) == 4:
        return tuple(int(v) for v in c)
    raise TypeError("a colour is a tuple (alpha, red, green, blue) or a player_color_t")


def _points(pts, count=None):
    if not isinstance(pts, list):
        raise TypeError("not a list")
    out = []
    for p in pts[: count if count is not None else len(pts)]:
        if isinstance(p, player_point_2d_t):
            out.append((p.px, p.py))
        elif isinstance(p, tuple) and len(p) == 2:
            out.append((float(p[0]), float(p[1])))
        else:
            raise TypeError("list must contain (x, y) tuples")
    return out


class playerc_graphics2d(_device):
    """``playerc_graphics2d_t``: ``setcolor``, ``draw_points``, ``draw_polyline``,
    ``draw_polygon``, ``clear``; colours are ``(alpha, red, green, blue)`` tuples, points
    lists of ``(x, y)`` tuples, as the SWIG typemaps take them."""

    _code = PLAYER_GRAPHICS2D_CODE

    def _defaults(self):
        self.color = (0, 0, 0, 0)

    def setcolor(self, col):
        try:
            self.color = _color_tuple(col)
            return 0
        except TypeError as e:
            return _fail(e)

    def draw_points(self, pts, count=None):
        return self._call(self._conn().graphics2d_points, self.index, _points(pts, count), self.color)

    def draw_polyline(self, pts, count=None):
        return self._call(
            self._conn().graphics2d_polyline, self.index, _points(pts, count), self.color
        )

    def draw_polygon(self, pts, count=None, filled=0, fill_color=(0, 0, 0, 0)):
        return self._call(
            self._conn().graphics2d_polygon,
            self.index,
            _points(pts, count),
            self.color,
            bool(filled),
            _color_tuple(fill_color),
        )

    def clear(self):
        return self._call(self._conn().graphics2d_clear, self.index)


def _points3d(pts: list, count: _Optional[int] = None) -> list:
    """``[(x, y, z), ...]`` from a list of 3-tuples or ``player_point_3d_t`` (the SWIG
    typemap's list of tuples), cut to ``count``."""
    if not isinstance(pts, list):
        raise TypeError("not a list")
    out = []
    for p in pts[: count if count is not None else len(pts)]:
        if isinstance(p, player_point_3d_t):
            out.append((p.px, p.py, p.pz))
        elif isinstance(p, tuple) and len(p) == 3:
            out.append((float(p[0]), float(p[1]), float(p[2])))
        else:
            raise TypeError("list must contain (x, y, z) tuples")
    return out


class playerc_graphics3d(_device):
    """``playerc_graphics3d_t``: ``setcolor``, ``draw(mode, points, count)`` (``mode`` a
    ``PLAYER_DRAW_*`` value, points a list of ``(x, y, z)`` tuples), ``clear``,
    ``translate``, ``rotate``: 3-D figures the simulator shows in its window."""

    _code = PLAYER_GRAPHICS3D_CODE

    def _defaults(self) -> None:
        self.color = (0, 0, 0, 0)

    def setcolor(self, col) -> int:
        """The colour of the next figures, ``(alpha, red, green, blue)``. 0 / -1."""
        try:
            self.color = _color_tuple(col)
            return 0
        except TypeError as e:
            return _fail(e)

    def draw(self, mode: int, pts: list, count: _Optional[int] = None) -> int:
        """Draws ``pts`` as ``mode`` (``PLAYER_DRAW_POINTS`` ... ``PLAYER_DRAW_POLYGON``).
        0 / -1."""
        try:
            points = _points3d(pts, count)
        except TypeError as e:
            return _fail(e)
        return self._call(self._conn().graphics3d_draw, self.index, int(mode), points, self.color)

    def clear(self) -> int:
        """Removes this client's figures. 0 / -1."""
        return self._call(self._conn().graphics3d_clear, self.index)

    def translate(self, x: float, y: float, z: float) -> int:
        """Moves the drawing frame of the next figures. 0 / -1."""
        return self._call(self._conn().graphics3d_translate, self.index, x, y, z)

    def rotate(self, a: float, x: float, y: float, z: float) -> int:
        """Turns the drawing frame by ``a`` radians about the axis (x, y, z). 0 / -1."""
        return self._call(self._conn().graphics3d_rotate, self.index, a, x, y, z)


def _actuator_geom(g: dict) -> player_actarray_actuatorgeom_t:
    fields = dict(g)
    fields["orientation"] = player_orientation_3d_t(*g["orientation"])
    fields["axis"] = player_point_3d_t(*g["axis"])
    return player_actarray_actuatorgeom_t(**fields)


class playerc_actarray(_device):
    """``playerc_actarray_t``: actuators_count, actuators_data[i] (position, speed,
    acceleration, current, state), motor_state; after ``get_geom()`` actuators_geom_count,
    actuators_geom[i], base_pos, base_orientation. Joint commands take the joint's index."""

    _code = PLAYER_ACTARRAY_CODE

    def _defaults(self) -> None:
        self.actuators_count = 0
        self.actuators_data = []
        self.motor_state = 0
        self.actuators_geom_count = 0
        self.actuators_geom = []
        self.base_pos = player_point_3d_t()
        self.base_orientation = player_orientation_3d_t()

    def _apply(self, fields: dict) -> None:
        self._take(fields, "motor_state")
        self._take_array(
            fields, "actuators_data", "actuators_count", lambda a: player_actarray_actuator_t(**a)
        )

    def get_actuator_data(self, index: int) -> player_actarray_actuator_t:
        """``playerc_actarray_get_actuator_data``: actuator ``index``'s state (libplayerc
        asserts the index; here a bad one raises ``IndexError``)."""
        if not 0 <= index < self.actuators_count:
            raise IndexError(f"actuator {index} of {self.actuators_count}")
        return self.actuators_data[index]

    def get_actuator_geom(self, index: int) -> player_actarray_actuatorgeom_t:
        """``playerc_actarray_get_actuator_geom``: actuator ``index``'s geometry (after
        ``get_geom()``; a bad index raises ``IndexError``)."""
        if not 0 <= index < self.actuators_geom_count:
            raise IndexError(f"actuator geometry {index} of {self.actuators_geom_count}")
        return self.actuators_geom[index]

    def get_geom(self) -> int:
        """``playerc_actarray_get_geom``: fills actuators_geom, base_pos, base_orientation.
        0 / -1."""
        g = self._answer("actarray_get_geom")
        if g is None:
            return -1
        self.actuators_geom = [_actuator_geom(a) for a in g["actuators_geom"]]
        self.actuators_geom_count = len(self.actuators_geom)
        self.base_pos = player_point_3d_t(*g["base_pos"])
        self.base_orientation = player_orientation_3d_t(*g["base_orientation"])
        return 0

    def _cmd(self, what: str, joint: int, value: float = 0.0) -> int:
        return self._call(self._conn().actarray_cmd, self.index, what, int(joint), float(value))

    def _multi(self, what: str, values: list, count: _Optional[int]) -> int:
        try:
            values = [float(v) for v in list(values)[: count if count is not None else None]]
        except (TypeError, ValueError) as e:
            return _fail(f"a list of numbers, one per joint: {e}")
        return self._call(self._conn().actarray_multi_cmd, self.index, what, values)

    def _setting(self, what: str, joint: int, value: float) -> int:
        return self._call(
            self._conn().actarray_config, self.index, what, int(joint), float(value)
        )

    def position_cmd(self, joint: int, position: float) -> int:
        """Moves ``joint`` to ``position``. 0 / -1."""
        return self._cmd("position", joint, position)

    def multi_position_cmd(self, positions: list, positions_count: _Optional[int] = None) -> int:
        """Moves every joint, ``positions`` one per joint. 0 / -1."""
        return self._multi("position", positions, positions_count)

    def speed_cmd(self, joint: int, speed: float) -> int:
        """Moves ``joint`` at ``speed``. 0 / -1."""
        return self._cmd("speed", joint, speed)

    def multi_speed_cmd(self, speeds: list, speeds_count: _Optional[int] = None) -> int:
        """Moves every joint at its speed. 0 / -1."""
        return self._multi("speed", speeds, speeds_count)

    def home_cmd(self, joint: int) -> int:
        """Sends ``joint`` (-1: all) to its home position. 0 / -1."""
        return self._cmd("home", joint)

    def current_cmd(self, joint: int, current: float) -> int:
        """Drives ``joint`` with ``current``. 0 / -1."""
        return self._cmd("current", joint, current)

    def multi_current_cmd(self, currents: list, currents_count: _Optional[int] = None) -> int:
        """Drives every joint with its current. 0 / -1."""
        return self._multi("current", currents, currents_count)

    def power(self, enable: int) -> int:
        """Turns the array's power on or off (a request: -1 when the driver refuses)."""
        return self._setting("power", -1, 1.0 if enable else 0.0)

    def brakes(self, enable: int) -> int:
        """Sets the brakes of the joints that have them (-1 when the driver refuses)."""
        return self._setting("brakes", -1, 1.0 if enable else 0.0)

    def speed_config(self, joint: int, speed: float) -> int:
        """The speed of later moves of ``joint`` (-1: all); -1 when the driver refuses."""
        return self._setting("speed", joint, speed)

    def accel_config(self, joint: int, accel: float) -> int:
        """The acceleration of later moves of ``joint`` (-1: all); -1 when refused."""
        return self._setting("accel", joint, accel)


class playerc_log(_device):
    """``playerc_log_t``: ``type`` (``PLAYER_LOG_TYPE_READ`` for a readlog,
    ``PLAYER_LOG_TYPE_WRITE`` for a writelog) and ``state`` (1 while replaying / recording),
    both filled by ``get_state()``."""

    _code = PLAYER_LOG_CODE

    def _defaults(self) -> None:
        self.type = 0
        self.state = 0

    def _set(self, what: str, state: int = 0) -> int:
        return self._call(self._conn().log_set_state, self.index, what, bool(state))

    def set_write_state(self, state: int) -> int:
        """Starts (1) or stops (0) a writelog's recording. 0 / -1."""
        return self._set("write", state)

    def set_read_state(self, state: int) -> int:
        """Starts (1) or pauses (0) a readlog's replay. 0 / -1."""
        return self._set("read", state)

    def set_read_rewind(self) -> int:
        """Rewinds a readlog's replay to the start of its file. 0 / -1."""
        return self._set("rewind")

    def get_state(self) -> int:
        """Fetches ``type`` and ``state``. 0 / -1."""
        answer = self._answer("log_get_state")
        if answer is None:
            return -1
        self.type, self.state = answer
        return 0

    def set_filename(self, fname: str) -> int:
        """Makes a writelog record to ``fname`` from now on (refused while recording).
        0 / -1."""
        return self._call(self._conn().log_set_filename, self.index, str(fname))


class playerc_camera(_device):
    """``playerc_camera_t``: width, height, bpp, format, fdiv, compression, image_count,
    image (bytes)."""

    _code = PLAYER_CAMERA_CODE

    def _defaults(self):
        self.width = self.height = self.bpp = self.format = self.fdiv = 0
        self.compression = 0
        self.image_count = 0
        self.image = b""

    def decompress(self):
        """Images are sent raw by the simulator; JPEG images are left as they are."""
        return None

    def save(self, filename):
        """Writes the image as a binary PPM (RGB888) or PGM (MONO8)."""
        if self.format == PLAYER_CAMERA_FORMAT_RGB888:
            head = b"P6\n%d %d\n255\n" % (self.width, self.height)
        elif self.format == PLAYER_CAMERA_FORMAT_MONO8:
            head = b"P5\n%d %d\n255\n" % (self.width, self.height)
        else:
            return _fail(f"cannot save camera format {self.format}")
        with open(filename, "wb") as f:
            f.write(head + bytes(self.image))
        return 0


class playerc_map(_device):
    """``playerc_map_t``: ``get_map()`` fills resolution, width, height, origin and cells
    (one signed value per cell: -1 free, 0 unknown, +1 occupied); ``get_vector()`` fills
    segments."""

    _code = PLAYER_MAP_CODE

    def _defaults(self):
        self.resolution = 0.0
        self.width = self.height = 0
        self.origin = [0.0, 0.0]
        self.cells = []
        self.vminx = self.vmaxx = self.vminy = self.vmaxy = 0.0
        self.num_segments = 0
        self.segments = []

    def get_map(self):
        answer = self._answer("map_get_map")
        if answer is None:
            return -1
        info, cells = answer
        self.__dict__.update(info)
        self.cells = [c - 256 if c > 127 else c for c in cells]
        return 0

    def get_vector(self):
        return -1 if self._config("map_get_vector") is None else 0


class playerc_planner(_device):
    """``playerc_planner_t``: path_valid, path_done, px py pa, gx gy ga, wx wy wa,
    curr_waypoint, waypoint_count, waypoints."""

    _code = PLAYER_PLANNER_CODE

    def _defaults(self):
        self.path_valid = self.path_done = 0
        self.px = self.py = self.pa = 0.0
        self.gx = self.gy = self.ga = 0.0
        self.wx = self.wy = self.wa = 0.0
        self.curr_waypoint = -1
        self.waypoint_count = 0
        self.waypoints = []

    def set_cmd_pose(self, gx, gy, ga):
        return self._call(self._conn().planner_set_cmd_pose, self.index, [gx, gy, ga])

    def get_waypoints(self):
        waypoints = self._answer("planner_get_waypoints")
        if waypoints is None:
            return -1
        self.waypoints = waypoints
        self.waypoint_count = len(waypoints)
        return 0

    def enable(self, state):
        return self._call(self._conn().planner_enable, self.index, bool(state))


def _hypoth(h):
    return player_localize_hypoth_t(
        mean=player_pose2d_t(*h["mean"]), cov=list(h["cov"]), alpha=h["alpha"]
    )


class playerc_localize(_device):
    """``playerc_localize_t``: pending_count, pending_time, hypoth_count, hypoths[i] (mean,
    cov, alpha), mean/variance/particles after ``get_particles()``."""

    _code = PLAYER_LOCALIZE_CODE

    def _defaults(self):
        self.pending_count = 0
        self.pending_time = 0.0
        self.hypoth_count = 0
        self.hypoths = []
        self.mean = [0.0, 0.0, 0.0]
        self.variance = 0.0
        self.num_particles = 0
        self.particles = []

    def _apply(self, fields):
        self._take(fields, "pending_count", "pending_time")
        self._take_array(fields, "hypoths", "hypoth_count", _hypoth)

    def set_pose(self, pose, cov):
        return self._call(self._conn().localize_set_pose, self.index, list(pose), list(cov))

    def get_particles(self):
        d = self._answer("localize_get_particles")
        if d is None:
            return -1
        self.mean = d["mean"]
        self.variance = d["variance"]
        self.num_particles = d["num_particles"]
        self.particles = [
            _Struct(pose=player_pose2d_t(*p), alpha=a) for p, a in d["particles"]
        ]
        return 0


__all__ = [n for n in dir() if not n.startswith("_") and n != "_native"]
