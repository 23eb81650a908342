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

from carlaverse.fabric.session import FabricSettings, open_session
from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import SyntheticSession, SyntheticSpec
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
