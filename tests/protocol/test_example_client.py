"""examples/thirdparty_client.py, a client written from docs/protocol.md in plain zenoh +
msgpack, against a live session: router, authority, a project scripted node, an observer."""

from __future__ import annotations

import json
import math
import signal
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from carlaverse import messages as m
from carlaverse import procs
from tests.support import Cluster, wait_until

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "thirdparty_client.py"
LEASE_S = 2.0  # the lease the example sets, as the project's nodes do
MARGIN_S = 1.0  # detection, propagation and a loaded machine
RADIUS_M = 20.0  # the example rides a circle of this radius around the origin


class Example:
    """The example as a subprocess; it prints one JSON status line a second."""

    def __init__(self, endpoint: str, node_id: str) -> None:
        argv = ["--connect", endpoint, "--session", "t", "--id", node_id]
        self.child = procs.start(argv, name=node_id, command=[sys.executable, str(EXAMPLE)])
        self.proc = self.child.proc

    @property
    def lines(self) -> list[str]:
        """What it printed so far, stdout and stderr together."""
        return self.child.log.lines()

    def status(self) -> dict[str, Any]:
        for line in reversed(self.lines):
            if line.startswith("{"):
                return json.loads(line)
        return {}

    def wait_for(self, condition: Any, timeout: float, what: str) -> dict[str, Any]:
        """The first status meeting `condition`; on timeout, fail showing what it printed."""
        try:
            return wait_until(lambda: condition(self.status()) and self.status(), timeout, what)
        except AssertionError as exc:
            printed = "\n".join(self.lines[-5:])
            raise AssertionError(f"{exc}; the example printed:\n{printed}") from None

    def kill(self) -> None:
        """SIGKILL: a crash, no clean leave."""
        if self.child.running:
            self.proc.kill()
        self.proc.wait(timeout=10)


@pytest.fixture
def example(cluster: Cluster) -> Any:
    started: list[Example] = []
    router = cluster.router()
    # a foreign client in client mode needs its router up: it fails at once otherwise
    wait_until(lambda: "listening on" in router.output(), 20, "the router to listen")

    def start(node_id: str = "partner-1") -> Example:
        started.append(Example(cluster.endpoint, node_id))
        return started[-1]

    yield start
    for proc in started:
        proc.kill()


def _decoded_everything(status: dict[str, Any]) -> bool:
    counts = status.get("counts", {})
    return bool(
        status.get("joined")
        and all(counts.get(k, 0) > 0 for k in ("poses", "npc", "lights", "weather"))
        and status.get("npcs", 0) > 0
        and "spawned:car-1" in status.get("events", [])
    )


def test_partner_client_joins_is_seen_decodes_the_world_and_is_despawned_when_killed(
    cluster: Cluster, example: Any
) -> None:
    authority = cluster.authority("--scenario", "crossing")
    partner = example()
    partner.wait_for(lambda s: s.get("joined"), 30, "the example to join")
    # Its spawn is an event the partner must decode; -v logs its despawns, which we wait on.
    node = cluster.scripted("car-1", None, "-v")
    observer = cluster.observer()
    status = partner.wait_for(_decoded_everything, 40, "the example to decode every message")
    assert not [k for k in status["counts"] if k.startswith("dropped")], status
    assert not [line for line in partner.lines if not line.startswith("{")], partner.lines
    x, y = status["egos"]["car-1"]
    assert math.isfinite(x) and math.isfinite(y)

    # The project's observer sees the partner where its poses say, stamped in session time.
    wait_until(lambda: observer.update() and "partner-1" in observer.world.egos, 10, "partner")
    view = next(v for v in observer.world.ego_views(observer.update()) if v.actor_id == "partner-1")
    assert abs(math.hypot(view.x, view.y) - RADIUS_M) < 0.2
    latency = observer.world.stats["partner-1"].summary(observer.update())
    # A clock off by more than a few ms would show here: both sides sync to the authority.
    assert -5.0 < latency.latency_p50_ms < 50.0, latency
    assert 40.0 < latency.rate_hz < 60.0, latency  # the example publishes at 50 Hz

    killed_at = time.monotonic()
    partner.kill()
    wait_until(lambda: observer.update() and "partner-1" not in observer.world.egos,
               LEASE_S + MARGIN_S, "the killed partner to be despawned")  # fmt: skip
    print(f"despawned {1e3 * (time.monotonic() - killed_at):.0f} ms after SIGKILL")
    assert [d.reason for d in observer.world.despawns if d.actor_id == "partner-1"] == [
        "liveliness"
    ]
    # The node is another process: its own view drops the partner when its subscriber hears
    # the token go, which on a loaded host can come after the observer's.
    wait_until(lambda: "despawned partner-1" in node.output(), LEASE_S + MARGIN_S, "node's despawn")
    node.stop()
    summary = node.json()
    assert "partner-1" in summary["actors_seen"] and "partner-1" not in summary["actors_now"]
    assert ["partner-1", "liveliness"] in summary["despawns"]
    authority.stop()
    assert ["partner-1", "liveliness"] in authority.json()["despawned"]


def test_a_frozen_partner_is_dropped_by_its_lease_before_the_silence_timeout(
    cluster: Cluster, example: Any
) -> None:
    cluster.authority()
    observer = cluster.observer()
    partner = example()
    wait_until(lambda: observer.update() and "partner-1" in observer.world.egos, 30, "partner")
    frozen_at = time.monotonic()
    partner.proc.send_signal(signal.SIGSTOP)  # alive, connection open, silent
    try:
        wait_until(lambda: observer.update() and "partner-1" not in observer.world.egos,
                   LEASE_S + MARGIN_S, "the frozen partner to be despawned")  # fmt: skip
        waited = time.monotonic() - frozen_at
    finally:
        partner.proc.send_signal(signal.SIGCONT)
    print(f"frozen partner despawned after {waited:.2f} s")
    # The lease, not the 3 s telemetry timeout, removed it: Zenoh's 10 s default would not.
    reasons = [d.reason for d in observer.world.despawns if d.actor_id == "partner-1"]
    assert reasons == ["liveliness"], reasons
    assert waited > LEASE_S * 0.5, f"despawned after {waited:.2f} s: not by the lease"
    # Thawed, it finds it was dropped (clock reply `known: false`) and joins again.
    wait_until(lambda: observer.update() and "partner-1" in observer.world.egos, 15, "re-join")
    # Its Zenoh session re-declares the token by itself on reconnect, so being seen again is not
    # proof of a join; the authority's roster is. (Its own second `spawned` may be published
    # before the router has re-learned its subscriber, so that is not waited for.)
    wait_until(lambda: "partner-1" in _roster(observer), 10, "the partner in the roster again")
    # Leaving on purpose (SIGTERM: `authority/leave`, then the token) reads as `left`.
    partner.proc.send_signal(signal.SIGTERM)
    assert partner.proc.wait(timeout=10) == 0
    wait_until(lambda: observer.update() and "partner-1" not in observer.world.egos, 2, "leave")
    assert [d.reason for d in observer.world.despawns if d.actor_id == "partner-1"][-1] == "left"


def _roster(observer: Any) -> set[str]:
    """Who the authority lists as joined (its snapshot)."""
    raw = observer.query("snapshot", timeout_s=2.0)
    return {e.node_id for e in m.SNAPSHOT.decode(raw).egos} if raw else set()
