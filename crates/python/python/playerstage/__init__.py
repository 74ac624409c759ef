"""Player and Stage for Python 3: a Pythonic Player client and the Stage simulator in-process.

Talking to a Player server (``player worlds/bigbob.cfg``)::

    import playerstage

    with playerstage.Client("localhost", 6665) as client:
        base = client.position2d(0)
        sonar = client.ranger(0)
        for _ in range(100):
            client.read()
            if sonar.scan.ranges.min() < 0.5:      # a numpy array when numpy is installed
                base.set_velocity(0.0, 0.0, 0.5)
            else:
                base.set_velocity(0.3)
        print(base.odometry)                        # Odometry(x=..., y=..., yaw=..., ...)

Errors are exceptions: ``PlayerError`` and its subclasses ``ConnectionLost`` (the server went
away: a read on a dropped connection raises, it never hangs), ``RequestRefused`` (NACK, e.g. no
such device), ``RequestTimeout`` and ``WorldError`` (a worldfile's file:line message).

Simulating without a server, for batch experiments and learning loops::

    world = playerstage.World("simple.world", seed=1)
    world.set_velocity("r0", 0.4, 0.0, 0.2)
    world.step(100)
    print(world.pose("r0"), world.ranger("r0.ranger:0").ranges)

The same world file, seed and commands give the same run (``world.digest()``).

The drop-in modules ``playerc`` and ``playercpp`` (Player 3.0.2's SWIG bindings' names and
conventions) are installed beside this package; this layer is built on ``playerc``.
"""

from . import _native
from ._native import (
    DEFAULT_PORT,
    ConnectionLost,
    PlayerError,
    RequestRefused,
    RequestTimeout,
    WorldError,
)

__all__ = [
    "Client",
    "World",
    "PlayerError",
    "ConnectionLost",
    "RequestRefused",
    "RequestTimeout",
    "WorldError",
    "DEFAULT_PORT",
    "Pose2d",
    "Odometry",
    "RangerScan",
    "LaserScan",
    "Blob",
    "BlobfinderFrame",
    "Fiducial",
    "GripperState",
    "HAVE_NUMPY",
]


def __getattr__(name):
    """Loads the Pythonic layer on first use (see ``_layer``'s docstring for why)."""
    if name in __all__:
        from . import _layer

        return getattr(_layer, name)
    raise AttributeError(f"module 'playerstage' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
