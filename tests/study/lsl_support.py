"""What the LSL tests share: liblsl kept on this host, a session whose clock the test knows,
and a synthetic ECG outlet whose every sample has a known session time.

The session clock here is a stand-in authority's `authority/clock` queryable answering

    session time = LSL local_clock() + SESSION_OFFSET_S

so the truth for any LSL time on this host is known without the code under test: a sample
the outlet stamps `T - SESSION_OFFSET_S` happened at session time T.
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.procs import free_port
from carlaverse.study.lsl_api import LslNetwork, load
from carlaverse.transport.session import FabricSettings, open_session

# [s] far from 0 and from the wall clock (~1.8e9): a mapping that drops or flips the offset
# is off by years, not by milliseconds.
SESSION_OFFSET_S = 1.5e9 + 1234.5678
# liblsl's SessionID for this test process: another process's streams stay invisible.
NETWORK = LslNetwork("machine", f"carlaverse-test-{os.getpid()}")
ECG_RATE_HZ = 250.0
HEART_RATE_BPM = 72.0  # R-peak every 60/72 = 0.8333 s


def lsl() -> Any:
    return load(NETWORK)


@dataclass
class Fabric:
    """Two Zenoh sessions on loopback: the stand-in authority's and the recorder's."""

    keys: Keys
    endpoint: str  # the stand-in authority's, for a recorder to --connect to
    authority: zenoh.Session
    client: zenoh.Session
    clock_queries: int = 0
    handles: list[Any] = field(default_factory=list)

    def session_now(self) -> float:
        return lsl().local_clock() + SESSION_OFFSET_S

    def serve_clock(self) -> None:
        def reply(query: zenoh.Query) -> None:
            self.clock_queries += 1
            query.reply(query.key_expr, m.CLOCK_REPLY.encode(m.ClockReply(self.session_now())))

        self.handles.append(self.authority.declare_queryable(self.keys.authority("clock"), reply))

    def publish_event(self, event: Any) -> None:
        self.authority.put(self.keys.world("events"), m.WORLD_EVENT.encode(event))


@contextmanager
def open_fabric() -> Iterator[Fabric]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    authority = open_session(FabricSettings(listen=[endpoint]))
    client = open_session(FabricSettings(connect=[endpoint]))
    fab = Fabric(Keys("lsltest"), endpoint, authority, client)
    fab.serve_clock()
    try:
        yield fab
    finally:
        for handle in fab.handles:
            handle.undeclare()
        client.close()
        authority.close()


def ecg_mv(t: float) -> float:
    """A synthetic ECG [mV] at time t [s]: a 1.2 mV Gaussian R wave (σ 10 ms) every beat on
    a flat line. Only its R-peaks matter to the tests: they are at t = k · 60 / HEART_RATE."""
    period = 60.0 / HEART_RATE_BPM
    phase = (t + period / 2) % period - period / 2  # [s] from the nearest R-peak
    return 1.2 * math.exp(-0.5 * (phase / 0.010) ** 2)


class EcgOutlet:
    """An LSL outlet sending the synthetic ECG in real time (chunks of 10 samples), each
    sample stamped with the LSL time of its true session time `t0 + i / rate`."""

    def __init__(self, name: str, rate_hz: float = ECG_RATE_HZ) -> None:
        pylsl = lsl()
        info = pylsl.StreamInfo(name, "ECG", 1, rate_hz, "float32", f"test-{name}")
        info.desc().append_child("channels").append_child("channel").append_child_value(
            "unit", "mV"
        )
        self.outlet = pylsl.StreamOutlet(info)
        self.rate_hz = rate_hz
        self.truth: list[float] = []  # [s] session time of each sample pushed
        self._pylsl = pylsl

    def wait_consumer(self, timeout_s: float = 5.0) -> None:
        assert self.outlet.wait_for_consumers(timeout_s), "no inlet connected to the outlet"

    def send(self, seconds: float) -> None:
        """Push `seconds` of samples, paced by the clock (not sleeps that drift)."""
        t0 = math.ceil(self._pylsl.local_clock() * 10) / 10 + SESSION_OFFSET_S
        n = round(seconds * self.rate_hz)
        for start in range(0, n, 10):
            idx = range(start, min(start + 10, n))
            times = [t0 + i / self.rate_hz for i in idx]
            due = times[-1] - SESSION_OFFSET_S
            while self._pylsl.local_clock() < due:
                time.sleep(0.002)
            for t in times:
                self.outlet.push_sample([ecg_mv(t - t0)], t - SESSION_OFFSET_S)
            self.truth += times

    def send_in_thread(self, seconds: float) -> threading.Thread:
        thread = threading.Thread(target=self.send, args=(seconds,), daemon=True)
        thread.start()
        return thread
