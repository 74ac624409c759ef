"""A real two-node Ray cluster on this machine, for the sweep's Ray executor tests.

A head node (``ray start --head``) and a second node joined to it (``ray start --address=...``),
each with its own ``--num-cpus``, no dashboard, their temp dirs under a pytest tmp path. Ray turns
127.0.0.1 into the machine's external address, so where we may (root, ``ip netns`` works) the
cluster runs in a private network namespace whose only interface is loopback: there Ray binds
127.0.0.1 and nothing else on the machine can reach it or clash with its ports. The driver must
run in the same namespace, so tests start it through :meth:`RayCluster.driver` (a subprocess,
``ip netns exec NS python ...``). Without namespaces (non-root) the nodes run on plain loopback
with ``--node-ip-address=127.0.0.1``.

Cleanup never uses ``ray stop``: it kills every Ray process on the machine by name, other
people's clusters included. Each node's ``ray start`` runs in a session of its own, so the node's
daemons share its process group; they, and the workers they forked (Ray workers make process
groups of their own), are killed by id, then the namespace is deleted.
"""

from __future__ import annotations

import itertools
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional

import pytest

# The venv's `ray` sits beside its python (the test venv; CI builds the same one).
RAY = str(Path(sys.executable).with_name("ray"))
# A node's `ray start` env label: Ray workers inherit their raylet's environment, so a task can
# tell which node it ran on (tests read it from their marker files).
NODE_LABEL = "PLAYERSTAGE_TEST_RAY_NODE"
# Fast node-death detection by the head's GCS (defaults: ~15 s after a node stops answering),
# so a killed node's tasks are retried within a test's time budget.
_HEAD_ENV = {
    "RAY_health_check_initial_delay_ms": "1000",
    "RAY_health_check_period_ms": "500",
    "RAY_health_check_timeout_ms": "1000",
    "RAY_health_check_failure_threshold": "3",
}
# Ray 2.60 turns token authentication on for a `ray start --head` when ~/.ray/auth_token exists
# (any local `ray.init()` writes one) but not for the nodes joining it, which are then refused:
# the test cluster says what it wants. Its network is private (a namespace) or loopback.
_AUTH = {"RAY_AUTH_MODE": "disabled"}
# Ray refuses less than 75 MiB; the default (30% of RAM per node) is far more than tests need.
_OBJECT_STORE = str(100 * 1024 * 1024)
# Ray's unix socket paths (TEMP/session_<date>_<pid>/sockets/plasma_store, ~70 characters below
# the temp dir) must stay under the kernel's 107; longer pytest tmp paths fall back to /tmp.
_MAX_TEMP_DIR = 36
_names = itertools.count()


def netns_usable() -> bool:
    """Whether this process may make network namespaces (root with a working `ip netns`);
    PLAYERSTAGE_TEST_RAY_NETNS=0 says not to (to exercise the plain loopback fallback)."""
    if os.environ.get("PLAYERSTAGE_TEST_RAY_NETNS") == "0":
        return False
    if os.geteuid() != 0 or shutil.which("ip") is None:
        return False
    name = f"psprobe{os.getpid()}"
    made = subprocess.run(["ip", "netns", "add", name], capture_output=True)
    if made.returncode != 0:
        return False
    try:
        # entering one needs more (a mount namespace of its own) than making one
        entered = subprocess.run(["ip", "netns", "exec", name, "ip", "link", "set", "lo", "up"],
                                 capture_output=True)
        return entered.returncode == 0
    finally:
        subprocess.run(["ip", "netns", "del", name], capture_output=True)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _children() -> dict[int, list[int]]:
    """Every process's children, from /proc (parent pid -> child pids)."""
    kids: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        # "pid (comm) state ppid pgrp ...": comm may hold spaces, so split after its ')'.
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] != "Z":  # a zombie is dead already; its parent (or init) reaps it
            kids.setdefault(int(fields[1]), []).append(int(entry))
    return kids


def _group_members(pgid: int) -> list[int]:
    """The live (not zombie) processes of process group `pgid`."""
    members = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] != "Z" and int(fields[2]) == pgid:
            members.append(int(entry))
    return members


@dataclass
class RayNode:
    """One `ray start`ed node: its label, temp dir and the process group of its daemons."""

    label: str
    temp_dir: Path
    pgid: int
    alive: bool = True

    def processes(self) -> list[int]:
        """The node's daemons and everything they started (workers have groups of their own)."""
        kids = _children()
        found: list[int] = []
        todo = _group_members(self.pgid)
        while todo:
            pid = todo.pop()
            if pid in found or pid == os.getpid():
                continue
            found.append(pid)
            todo.extend(kids.get(pid, []))
        return found

    def kill(self) -> list[int]:
        """SIGKILL the node (a machine lost, not a clean shutdown); returns the pids killed."""
        pids = self.processes()
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self.alive = False
        return pids


@dataclass
class RayCluster:
    """A head and worker nodes on this machine; `address` is what drivers pass to Ray."""

    base: Path
    namespace: Optional[str]
    port: int
    nodes: list[RayNode] = field(default_factory=list)

    @property
    def address(self) -> str:
        return f"127.0.0.1:{self.port}"

    def prefix(self) -> list[str]:
        """The argv prefix that runs a command in the cluster's network (namespace or none)."""
        return ["ip", "netns", "exec", self.namespace] if self.namespace else []

    def _start(self, label: str, args: list[str], cpus: int, extra_env: dict[str, str]) -> RayNode:
        temp = self.base / f"{label}{len(self.nodes)}"
        temp.mkdir()
        env = dict(os.environ, **_AUTH, **extra_env, **{NODE_LABEL: label})
        env["PYTHONPATH"] = os.pathsep.join(
            p for p in (str(Path(__file__).parent), env.get("PYTHONPATH", "")) if p
        )
        argv = self.prefix() + [
            RAY,
            "start",
            *args,
            f"--num-cpus={cpus}",
            f"--temp-dir={temp}",
            f"--object-store-memory={_OBJECT_STORE}",
            "--disable-usage-stats",
        ]
        if not self.namespace:
            argv.append("--node-ip-address=127.0.0.1")
        log = temp.with_suffix(".log")
        with open(log, "wb") as out:
            proc = subprocess.Popen(
                argv, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True
            )
        node = RayNode(label, temp, proc.pid)
        # Before waiting: if `ray start` fails half-way its daemons must still be cleaned up.
        self.nodes.append(node)
        try:
            code = proc.wait(timeout=90)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = None
        if code != 0:
            raise RuntimeError(f"`{' '.join(argv)}` failed ({code}):\n{log.read_text()[-3000:]}")
        return node

    def start_head(self, cpus: int) -> RayNode:
        return self._start(
            "head",
            ["--head", f"--port={self.port}", "--include-dashboard=false"],
            cpus,
            _HEAD_ENV,
        )

    def add_node(self, cpus: int, label: str = "worker") -> RayNode:
        node = self._start(label, [f"--address={self.address}"], cpus, {})
        self.wait_for_nodes(sum(1 for n in self.nodes if n.alive))
        return node

    def driver(self, argv: list[str], **kwargs) -> subprocess.Popen:
        """Start a driver (any command) in the cluster's network, in a session of its own."""
        env = dict(kwargs.pop("env", None) or os.environ, **_AUTH)
        env["PYTHONPATH"] = os.pathsep.join(
            p for p in (str(Path(__file__).parent), env.get("PYTHONPATH", "")) if p
        )
        return subprocess.Popen(self.prefix() + argv, env=env, start_new_session=True, **kwargs)

    def wait_for_nodes(self, count: int, timeout: float = 60.0) -> None:
        """Block until the cluster's GCS lists `count` live nodes."""
        script = (
            "import sys, time, ray\n"
            "ray.init(address=sys.argv[1], logging_level='ERROR', log_to_driver=False)\n"
            "end = time.monotonic() + float(sys.argv[3])\n"
            "while sum(n['Alive'] for n in ray.nodes()) != int(sys.argv[2]):\n"
            "    if time.monotonic() > end: sys.exit('nodes: %s' % ray.nodes())\n"
            "    time.sleep(0.2)\n"
        )
        proc = self.driver(
            [sys.executable, "-c", script, self.address, str(count), str(timeout)],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
        )
        out, _ = proc.communicate(timeout=timeout + 30)
        if proc.returncode != 0:
            raise RuntimeError(f"cluster never had {count} live nodes:\n{out.decode()[-3000:]}")

    def close(self) -> None:
        """Kill every node's processes (workers too), then delete the namespace."""
        for node in self.nodes:
            node.kill()
        if self.namespace:
            # Processes die asynchronously; a namespace with members left cannot go away cleanly.
            deadline = time.monotonic() + 10
            while any(n.processes() for n in self.nodes) and time.monotonic() < deadline:
                time.sleep(0.1)
            subprocess.run(["ip", "netns", "del", self.namespace], capture_output=True)


def _short_base(tmp: Path) -> tuple[Path, Optional[Path]]:
    """`tmp` when short enough for Ray's socket paths, else a short dir to remove afterwards."""
    if len(str(tmp)) <= _MAX_TEMP_DIR:
        return tmp, None
    short = Path(tempfile.mkdtemp(prefix="psray"))
    return short, short


def start_cluster(base: Path, head_cpus: int = 1, worker_cpus: int = 1) -> RayCluster:
    """A head with `head_cpus` and one worker node with `worker_cpus` under `base` (short:
    see `_MAX_TEMP_DIR`); close() it when done."""
    namespace = None
    if netns_usable():
        namespace = f"psray{os.getpid()}x{next(_names)}"
        subprocess.run(["ip", "netns", "add", namespace], check=True)
        subprocess.run(
            ["ip", "netns", "exec", namespace, "ip", "link", "set", "lo", "up"], check=True
        )
    # In a fresh namespace every port is free; on shared loopback ask the kernel for one.
    cluster = RayCluster(base, namespace, 6379 if namespace else _free_port())
    try:
        cluster.start_head(head_cpus)
        cluster.add_node(worker_cpus)
    except BaseException:
        cluster.close()
        raise
    return cluster


@pytest.fixture(scope="module")
def ray_cluster(tmp_path_factory) -> Iterator[RayCluster]:
    """A two-node cluster (1 CPU each) for one test module; torn down even when tests fail."""
    tmp = tmp_path_factory.mktemp("r")
    base, remove = _short_base(tmp)
    cluster = None
    try:
        cluster = start_cluster(base)
        yield cluster
    finally:
        if cluster is not None:
            cluster.close()
        if remove is not None:
            shutil.rmtree(remove, ignore_errors=True)
