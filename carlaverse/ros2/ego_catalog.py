"""Each ego's actor kind and extent, for the boxes and classes the ROS 2 view publishes.

A world view carries an ego's poses, not what it is; the authority's snapshot does
(`EgoInfo.actor_kind`, `.extent`). The catalogue starts from the snapshot the node got when
it joined and, when an ego appears that it does not know, asks for a new one on a thread of
its own (a query waits on the network: never on the node's loop), at most once a period.
"""

from __future__ import annotations

import logging
import threading
import time

from carlaverse import messages as m
from carlaverse.transport.node_client import NodeClient

log = logging.getLogger(__name__)

ASK_PERIOD_S = 1.0  # [s] at most one snapshot query this often
QUERY_TIMEOUT_S = 1.0  # [s]


class EgoCatalog:
    def __init__(self, client: NodeClient) -> None:
        self.client = client
        self.dropped = 0  # snapshot replies that did not decode
        self._known: dict[str, tuple[str, m.Extent]] = {}
        self._asking = threading.Event()
        self._next_ask = 0.0
        if client.snapshot is not None:
            self._take(client.snapshot)

    def lookup(self, ego_id: str) -> tuple[str, m.Extent] | None:
        """(actor kind, extent) of an ego, or None while not known (it is then asked for)."""
        info = self._known.get(ego_id)
        if info is None:
            self._ask()
        return info

    def _ask(self) -> None:
        now = time.monotonic()
        if self._asking.is_set() or now < self._next_ask:
            return
        self._asking.set()
        self._next_ask = now + ASK_PERIOD_S
        threading.Thread(target=self._fetch, name="ros2-ego-catalog", daemon=True).start()

    def _fetch(self) -> None:
        try:
            raw = self.client.query("snapshot", timeout_s=QUERY_TIMEOUT_S)
            if raw is not None:
                self._take(m.SNAPSHOT.decode(raw))
        except m.MessageError as exc:
            self.dropped += 1
            log.warning("unreadable snapshot: %s", exc)
        finally:
            self._asking.clear()

    def _take(self, snapshot: m.Snapshot) -> None:
        # one assignment: the loop thread reads the old or the new table, never half of one
        self._known = {e.node_id: (e.actor_kind, e.extent) for e in snapshot.egos}
