"""A publisher session with a synthetic world, and helpers to record it."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import zenoh

from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import SyntheticSession, SyntheticSpec
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import free_port, wait_until


@dataclass
class World:
    """The publishing side of a test: its endpoint, session and synthetic traffic."""

    endpoint: str
    session: zenoh.Session
    synthetic: SyntheticSession

    def connect(self) -> zenoh.Session:
        """Another session connected to this world (closed by the test)."""
        return open_session(FabricSettings(connect=[self.endpoint]))

    def wait_matched(self, timeout: float = 10.0) -> None:
        """Until every publisher of the world has a subscriber (the recorder is listening)."""
        wait_until(self.synthetic.all_matched, timeout, "a subscriber on every key")

    def publish_for(self, duration_s: float) -> None:
        self.synthetic.run(threading.Event(), duration_s=duration_s)

    def publish_steady(
        self, duration_s: float, steady_s: float, max_gap_s: float, timeout_s: float = 30.0
    ) -> None:
        """Publish for `duration_s` of session time and until `steady_s` of it went by in
        steps of at most `max_gap_s`, in one stretch.

        On a loaded two-core machine this process can stall for hundreds of ms, and the
        synthetic streams skip what fell due meanwhile; a test that judges how the streams are
        drawn between samples needs a stretch without such holes, however long the stalls
        make the run. (Summing the steady bits between stalls is not enough: the view draws
        a delay behind, so each bit's first frames fall in the hole before it.)"""
        synthetic = self.synthetic
        start = last = since = synthetic.now()
        longest = 0.0
        synthetic.spawn_all(start)
        while last - start < duration_s or longest < steady_s:
            t = synthetic.now()
            assert t - start < timeout_s, (
                f"no {steady_s} s in {timeout_s} s without a stall over {max_gap_s * 1e3:.0f} ms"
            )
            since = since if t - last <= max_gap_s else t
            longest = max(longest, t - since)
            synthetic.tick(t)
            last = t
            time.sleep(0.002)


@pytest.fixture
def world() -> Iterator[World]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = open_session(FabricSettings(listen=[endpoint]))
    synthetic = SyntheticSession(
        session, Keys("rec"), SyntheticSpec(egos=2, npcs=6, reliable_state=True), keep_payloads=True
    )
    synthetic.serve_queries()
    try:
        yield World(endpoint, session, synthetic)
    finally:
        synthetic.close()
        session.close()


class GatedSink(McapSink):
    """A real sink whose writes wait for the test's `gate`: the recorder's queue fills."""

    def __init__(self, path: Path) -> None:
        super().__init__(path, monotonic=time.monotonic)
        self.gate = threading.Event()

    def write(self, *args: Any, **kwargs: Any) -> bool:
        self.gate.wait(timeout=30)
        return super().write(*args, **kwargs)
