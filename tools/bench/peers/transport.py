"""What every compared transport provides, and the one sample they all carry.

Each transport is a subclass of `Transport` with three hooks: `infrastructure` (processes the
transport needs besides publisher and receivers: a Zenoh router, an MQTT broker, the
authority), `open_sender` and `open_receiver`. The harness (`peers.run`) owns the timing, the
processes and the counting; a transport only moves a pose from one process to the others.

The sample is the project's own 64-byte pose (`carlaverse.messages.encode_pose`): its bench
index travels in `vz` (exact in float32 up to 2**24; not in the position, which stays put so
that no spatial filtering can tell samples apart), its send time in `t` (CLOCK_MONOTONIC,
seconds: one clock for every process of this host), and `flags` marks warm-up samples, which
are sent until every receiver has heard from the publisher and are not measured. Every
receiver decodes with `decode_pose` (size, version and finiteness checked) before it stamps
the arrival, so each path is charged for the same decoding work.
"""

from __future__ import annotations

import importlib.util
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from carlaverse.messages import Pose

WARM_UP = 0x1  # flags bit: a warm-up sample, not measured


def module_installed(name: str) -> bool:
    """Whether `name` (dotted, e.g. `paho.mqtt`) can be imported; find_spec raises instead of
    answering when a parent package (`paho`) is missing."""
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


class Deliver(Protocol):
    """Where a receiver hands what arrived (`peers.arrivals.Arrivals`)."""

    def pose(self, pose: Pose) -> None:
        """A pose the transport decoded itself (the pose path)."""

    def payload(self, payload: bytes | bytearray | memoryview) -> None:
        """Raw bytes: decoded here with the project's pose decoder."""


@dataclass(frozen=True, slots=True)
class Plan:
    """One run's layout, the same for every transport (picklable: it goes to every process)."""

    transport: str
    receivers: int  # processes that receive each pose (the measured ones and one more)
    measured: int  # receivers whose latencies are reported
    rate_hz: float  # [Hz] poses per second
    messages: int  # measured poses sent
    ports: tuple[int, ...] = ()  # free loopback ports, one per receiver plus two spare
    options: dict[str, Any] = field(default_factory=dict)


class Sender(Protocol):
    def send(self, pose: Pose) -> None: ...
    def close(self) -> None: ...


class Receiver(Protocol):
    # Whether and how often `poll()` runs on the receiver's main thread (a node's own loop);
    # None: delivery needs nothing from the main thread, which then sleeps.
    poll_period_s: float | None

    def poll(self) -> None: ...
    def close(self) -> None: ...


class Transport:
    """One compared transport; subclasses fill in the hooks."""

    label = ""  # how the tables name it
    modules: tuple[str, ...] = ()  # Python modules it imports
    programs: tuple[str, ...] = ()  # executables it starts
    install_hint = "pip install -e '.[bench]'; sudo tools/install-bench-deps.sh"
    extra_receiver = True  # False when an infrastructure process is the last receiver

    def missing(self) -> str | None:
        """Why this transport cannot run here (one line), or None when it can."""
        absent = [m for m in self.modules if not module_installed(m)]
        absent += [p for p in self.programs if find_program(p) is None]
        if not absent:
            return None
        return f"{self.label}: {', '.join(absent)} not installed ({self.install_hint})"

    def infrastructure(self, plan: Plan) -> list[Infrastructure]:
        return []

    def open_sender(self, plan: Plan) -> Sender:
        raise NotImplementedError

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> Receiver:
        raise NotImplementedError


class Infrastructure(Protocol):
    """A process a transport needs; `pid` for CPU accounting, `stop()` to end it."""

    name: str
    pid: int

    def wait_ready(self, timeout_s: float) -> bool: ...
    def stop(self) -> None: ...


class NoPoll:
    """Receivers whose delivery needs nothing from the main thread."""

    poll_period_s = None

    def poll(self) -> None:
        return None


def sample(index: int, warm_up: bool) -> Pose:
    """The pose every transport sends, stamped now."""
    t = time.monotonic()
    return Pose(index, t, 0.0, 0.0, vx=14.0, vz=float(index), flags=WARM_UP * warm_up)


def find_program(name: str) -> str | None:
    """An executable on PATH or in the sbin directories (where Debian puts daemons)."""
    import os
    import shutil

    return shutil.which(name, path=os.pathsep.join([os.environ.get("PATH", ""), *SBIN]))


SBIN = ("/usr/sbin", "/sbin", "/usr/local/sbin")


def free_ports(count: int) -> tuple[int, ...]:
    """Ports the kernel just handed out on loopback (free now; reused at once by the run)."""
    sockets = [socket.socket() for _ in range(count)]
    try:
        for s in sockets:
            s.bind(("127.0.0.1", 0))
        return tuple(int(s.getsockname()[1]) for s in sockets)
    finally:
        for s in sockets:
            s.close()


def wait_for_port(port: int, timeout_s: float) -> bool:
    """Whether something accepts TCP connections on 127.0.0.1:port within the timeout."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                return True
        except OSError:
            time.sleep(0.05)  # polling a port has no event to wait on
    return False


class ReceiveThread(NoPoll):
    """A daemon thread calling `receive_once()` until closed (for blocking-socket receivers).

    `receive_once` must return within ~0.2 s when nothing arrives (a socket timeout), so
    that `close()` ends the thread promptly.
    """

    def __init__(self, name: str) -> None:
        import threading

        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name=name, daemon=True)

    def start(self) -> ReceiveThread:
        self._thread.start()
        return self

    def _loop(self) -> None:
        while not self._stop.is_set():
            self.receive_once()

    def receive_once(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self.release()

    def release(self) -> None:
        """Free the transport's resources once the thread has ended."""


def process_context() -> Any:
    """Where the run's processes come from: a fork server that imported the heavy modules once.

    Spawning each of the ~6 processes of a run from scratch costs seconds of imports on a
    loaded 2-core host; forking them from a server that has imported the fabric (but opened
    nothing: no threads, no sockets) costs milliseconds.
    """
    import multiprocessing as mp

    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    return ctx


PRELOAD = ["peers.run", "carlaverse.transport.node_client", "carlaverse.authority.service"]


class ChildProcess:
    """An infrastructure process running `target(ready, stop, *args)`."""

    def __init__(self, name: str, target: Callable[..., None], *args: Any) -> None:
        ctx = process_context()
        self.name = name
        self._ready, self._stop = ctx.Event(), ctx.Event()
        self._proc = ctx.Process(target=target, args=(self._ready, self._stop, *args), name=name)
        self._proc.daemon = True  # a failed run must not leave it behind
        self._proc.start()
        self.pid = int(self._proc.pid or 0)

    def wait_ready(self, timeout_s: float) -> bool:
        return self._ready.wait(timeout_s)

    def stop(self) -> None:
        self._stop.set()
        self._proc.join(timeout=10)
        if self._proc.is_alive():
            self._proc.kill()
