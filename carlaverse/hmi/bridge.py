"""What a node kind gives the HMI: telemetry to show and a way to take the pages' commands.

A node kind with an HMI has a method `hmi_bridge() -> HmiBridge`. The server calls
`telemetry()` at its frame rate and `submit()` for each validated command, both on the HMI's
own thread: neither may block. The usual shape: `telemetry()` reads the control loop's
shared-memory state block (the loop's latest-value slot: a seqlock, so the loop never waits
on it), and `submit()` puts the command on a queue the node's step drains into the loop's
event queue, the same way impulses and overrides travel.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from carlaverse.hmi.wire import Command
from carlaverse.shm import SharedBlock, TornRead


class HmiBridge(Protocol):
    kind: str  # selects the shipped config hmi/<kind>.yaml
    node_id: str
    actions: frozenset[str]  # the `press` actions the node takes
    cruise: bool  # it takes cruise set/resume/cancel

    def static_info(self) -> dict[str, Any]: ...

    def telemetry(self) -> tuple[float, dict[str, Any]] | None:
        """(monotonic stamp [s] of the loop tick, values), or None before the loop runs."""
        ...

    def submit(self, command: Command) -> None: ...

    def close(self) -> None: ...


class StateReader:
    """Reads the node's shared state block from the HMI thread.

    It takes the node's own block (`block()`: None until the node has made it) rather than
    attaching a second time: in the creating process a second attachment would confuse the
    resource tracker's bookkeeping of the block.
    """

    def __init__(self, block: Callable[[], SharedBlock | None]) -> None:
        self._block = block
        self.torn_reads = 0

    def read(self) -> np.void | None:
        """The loop's latest record, or None before its first tick."""
        block = self._block()
        if block is None:
            return None
        try:
            record = block.read()
        except TornRead:
            self.torn_reads += 1
            return None
        return record if record["running"] else None
