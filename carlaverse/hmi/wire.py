"""What the HMI's pages and the node say to each other over the WebSocket (JSON text frames).

This is a local link between a node and the pages it serves, not a fabric message, so it is
not in carlaverse.messages (whose keys and schema docs/protocol.md describes).

Page → node, each validated by `InputCheck` (a bad one is counted and dropped, and the page
is told why in a `rejected` frame):

    {"type": "press", "action": "low_beam"}       a touchscreen tap (the node's actions)
    {"type": "cruise", "command": "set"}          set | resume | cancel
    {"type": "ping", "page_ms": 1234.5}           clock sync: the page's performance.now()

Node → page: `info` once on connect, then `telemetry` at the configured rate, `message` when
text is pushed (`HmiServer.show_message`), `pong` for each ping, `rejected` for bad input.
"""

from __future__ import annotations

from collections import Counter
from typing import Annotated, Any, Literal

import msgspec

from carlaverse.patterns import anchored

Finite = Annotated[float, msgspec.Meta(ge=-1e12, le=1e12)]  # JSON has no NaN; bounds it too
ActionName = Annotated[str, msgspec.Meta(pattern=anchored(r"[a-z0-9_]{1,32}"))]
MAX_INPUT_BYTES = 1024  # a page's input is a few dozen bytes; anything longer is not ours


class Press(msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="press", tag_field="type"):
    action: ActionName


class Cruise(
    msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="cruise", tag_field="type"
):
    command: Literal["set", "resume", "cancel"]


class Ping(msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="ping", tag_field="type"):
    page_ms: Finite  # [ms] the page's performance.now() when it sent this


PageInput = Press | Cruise | Ping
Command = Press | Cruise  # what reaches the node; pings are answered by the server


class Info(msgspec.Struct, frozen=True, tag="info", tag_field="type"):
    kind: str  # node kind: drive, bike
    node_id: str
    units: str
    rate_hz: float
    actions: list[str]  # the presses the node takes
    cruise: bool  # the node takes cruise commands
    static: dict[str, Any]  # per kind, e.g. redline_rpm


class Telemetry(msgspec.Struct, frozen=True, tag="telemetry", tag_field="type"):
    seq: int
    stamp_s: float  # [s] monotonic clock of the node's host when its loop produced this state
    values: dict[str, Any]


class Message(msgspec.Struct, frozen=True, tag="message", tag_field="type"):
    id: int
    text: str
    seconds: float  # [s] how long the page shows it


class Pong(msgspec.Struct, frozen=True, tag="pong", tag_field="type"):
    page_ms: float  # echoed from the ping
    node_s: float  # [s] the node host's monotonic clock when it answered


class Rejected(msgspec.Struct, frozen=True, tag="rejected", tag_field="type"):
    reason: str


ENCODER = msgspec.json.Encoder()


class InputCheck:
    """Decode and vet page input: the node's own action list and cruise support.

    `rejected` counts drops by reason (`json`, `schema`, `size`, `binary`, `action`,
    `cruise`); `accepted` counts the rest.
    """

    def __init__(self, actions: frozenset[str], cruise: bool) -> None:
        self.actions = actions
        self.cruise = cruise
        self._decoder = msgspec.json.Decoder(PageInput)
        self.accepted = 0
        self.rejected: Counter[str] = Counter()

    def check(self, raw: str | bytes | None) -> tuple[PageInput | None, str]:
        """The input and "", or None and why it was dropped (also counted)."""
        item, reason = self._vet(raw)
        if item is None:
            self.rejected[reason.split(":", 1)[0]] += 1
        else:
            self.accepted += 1
        return item, reason

    def _vet(self, raw: str | bytes | None) -> tuple[PageInput | None, str]:
        if not isinstance(raw, str):
            return None, "binary: send JSON text frames"
        if len(raw) > MAX_INPUT_BYTES:
            return None, f"size: {len(raw)} bytes > {MAX_INPUT_BYTES}"
        try:
            item = self._decoder.decode(raw)
        except msgspec.ValidationError as exc:
            return None, f"schema: {exc}"
        except msgspec.DecodeError as exc:
            return None, f"json: {exc}"
        if isinstance(item, Press) and item.action not in self.actions:
            return None, f"action: {item.action!r} is not one of {sorted(self.actions)}"
        if isinstance(item, Cruise) and not self.cruise:
            return None, "cruise: this node has no cruise control"
        return item, ""
