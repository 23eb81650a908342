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
from carlaverse.transport.node_client import NodeSettings


class HmiBridge(Protocol):
    kind: str  # selects the shipped config hmi/<kind>.yaml
    node_id: str
    actions: frozenset[str]  # the `press` actions the node takes
    cruise: bool  # it takes cruise set/resume/cancel
    torn_reads: int  # telemetry reads that met the loop mid-write (that frame is skipped)

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


class StateBridge:
    """The usual bridge: telemetry from the loop's state block, stamped on monotonic time.

    A node kind's bridge names its `kind`, picks its values from the state record
    (`_values`) and, when it takes commands, overrides `submit`.
    """

    kind: str
    actions: frozenset[str] = frozenset()
    cruise = False

    def __init__(self, settings: NodeSettings, state: Callable[[], SharedBlock | None]) -> None:
        self.node_id = settings.node_id
        self._reader = StateReader(state)
        self.clock_offset = 0.0  # [s] session time − monotonic, kept by the node's step

    @property
    def torn_reads(self) -> int:
        return self._reader.torn_reads

    def static_info(self) -> dict[str, Any]:
        return {}

    def telemetry(self) -> tuple[float, dict[str, Any]] | None:
        s = self._reader.read()
        if s is None:
            return None
        t = float(s["t"])  # [s] session time of the loop tick, as in its poses
        values = {"t": t, "speed_mps": float(s["speed_mps"]), **self._values(s)}
        return t - self.clock_offset, values

    def _values(self, s: np.void) -> dict[str, Any]:
        """The kind's own values from the state record (beside `t` and `speed_mps`)."""
        raise NotImplementedError

    def submit(self, command: Command) -> None:
        raise ValueError(f"the {self.kind} HMI takes no commands, got {command!r}")

    def close(self) -> None:
        pass  # the node owns and closes its state block


class QuestionnaireOnlyBridge:
    """A bridge for a participant's node kind without pages of its own (walk, scripted): no
    telemetry, no commands; its HMI shows only the study's questionnaires."""

    actions: frozenset[str] = frozenset()
    cruise = False
    torn_reads = 0

    def __init__(self, kind: str, node_id: str) -> None:
        self.kind = kind
        self.node_id = node_id

    def static_info(self) -> dict[str, Any]:
        return {}

    def telemetry(self) -> tuple[float, dict[str, Any]] | None:
        return None

    def submit(self, command: Command) -> None:
        raise ValueError(f"the {self.kind} HMI takes no commands, got {command!r}")

    def close(self) -> None:
        pass
