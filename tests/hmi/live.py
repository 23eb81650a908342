"""A live session for HMI tests: router, authority and one node with `--hmi 0`, in processes."""

from __future__ import annotations

import re
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tests.support import Cluster, Proc, wait_until

HMI_URL = re.compile(r"HMI at (http://127\.0\.0\.1:\d+/)")


def hmi_url(proc: Proc) -> str | None:
    """The base URL the node printed, once it has."""
    found = HMI_URL.search("".join(proc.stderr))
    if found is None and not proc.alive():
        raise AssertionError(f"{proc.name} exited: {proc.output()[-2000:]}")
    return found.group(1) if found else None


@contextmanager
def node_with_hmi(
    tmp: Path, kind: str, node_id: str, *extra: str
) -> Iterator[tuple[Cluster, Proc, str]]:
    """A session with a `kind` node on the sim backend serving its HMI; yields its base URL.
    The node is stopped at the end; its --duration only guards against an orphan, and must
    outlast a module's tests on a slow machine (120 s once ran out mid-module)."""
    cluster = Cluster(tmp)
    try:
        cluster.router()
        cluster.authority()
        node = cluster.start(
            "join", kind, "--id", node_id, "--session", "t", "--connect", cluster.endpoint,
            "--backend", "sim", "--duration", "900", "--hmi", "0", "--json", *extra,
            name=node_id,
        )  # fmt: skip
        url = wait_until(lambda: hmi_url(node), 30, f"{node_id}'s HMI URL")
        yield cluster, node, url
    finally:
        cluster.close()


class LoopRecord:
    """A node's loop state as a watcher thread reads it, by the loop's own time `t`."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._readings: list[tuple[float, dict[str, float]]] = []

    def add(self, t: float, reading: dict[str, float]) -> None:
        with self._lock:
            self._readings.append((t, reading))

    def around(self, t: float, half_width_s: float, name: str) -> list[float]:
        """Values of `name` the loop held within ±half_width_s of its time t [s]."""
        with self._lock:
            return [r[name] for at, r in self._readings if abs(at - t) <= half_width_s]

    def latest(self) -> dict[str, float] | None:
        with self._lock:
            return self._readings[-1][1] if self._readings else None

    def last_t(self) -> float:
        """The loop time [s] of the newest reading (−inf before the first)."""
        with self._lock:
            return self._readings[-1][0] if self._readings else float("-inf")


def assert_within(shown: float, readings: list[float], slack: float, what: str) -> None:
    """`shown` lies within the range of the node's own `readings`, widened by `slack`."""
    assert readings, f"no {what} readings from the node near the frame's time"
    low, high = min(readings) - slack, max(readings) + slack
    assert low <= shown <= high, f"shown {what} {shown}, the node's {low:.1f}..{high:.1f}"
