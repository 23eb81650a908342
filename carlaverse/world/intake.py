"""The one way into a world view: its `WorldIntake` (docs/architecture.md §7).

Whatever feeds a view writes through its intake and nothing else: a live session (the node
client's Zenoh callbacks, `transport.inbound`), a recording or a synthetic feed
(`world.source.SampleFeed`). One representation for all of them: a pose as it travels (its
64 bytes, checked and decoded once, by the view's update, with every other pose the update
drains), every other message decoded, and an actor's departure named by one `Departure`.

Every method only appends to a deque (atomic under the GIL), so a Zenoh callback never waits;
the view's owner applies what came, in order, in `WorldView.update`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any, Literal

from carlaverse.messages import (
    POSE_SIZE,
    EgoState,
    LightsState,
    Notice,
    NpcBatch,
    Skeleton,
    Snapshot,
    Weather,
)
from carlaverse.support.tally import Tally

INBOX_LIMIT = 100_000  # beyond this the owner is not draining; oldest input is dropped
WHOLE_WORLD = ""  # the tile name of the `world/npc` stream (NPCs of the whole session)

# Why an actor left a view, whoever noticed. The first four are the authority's own reasons
# (`messages.DespawnReason`, which its `despawned` events carry); a view also notices two of
# them itself, and one the authority cannot know of:
#   left        the node left on purpose
#   liveliness  its presence token went (the DELETE heard here, or the authority's word)
#   timeout     silent for longer than the despawn timeout (here, or at the authority)
#   authority   the authority removed it
#   far         out of this view's interest area: alive, only out of earshot (not a loss)
Departure = Literal["left", "liveliness", "timeout", "authority", "far"]

# Inbox tags (compared by identity in `WorldView.update`: the poses, nearly every item).
POSE = "pose"  # one node's pose: (tag, node id, 64 bytes, arrival)
ROWS = "rows"  # poses relayed together: (tag, node ids, their rows, arrival)


class WorldIntake:
    """What a world view has been handed and not yet applied. Safe from any thread."""

    def __init__(self, own_id: str) -> None:
        self.own_id = own_id  # this node's id: its own poses and skeleton are not taken
        self.inbox: deque[tuple[Any, ...]] = deque(maxlen=INBOX_LIMIT)
        # Malformed input by channel: what a source could not decode, and the poses the
        # view's update refuses, so a channel's count is in one place.
        self.dropped = Tally()
        # Poses' arrival stamps are session time, unless a source stamps them on a clock of
        # its own and gives this to turn them into session time when the update drains them:
        # the live session does (`transport.inbound`), with its host's monotonic clock, one C
        # call in the Zenoh callback, which runs cold, where each Python frame costs µs.
        self.pose_stamp_to_session: Callable[[float], float] | None = None

    # ------------------------------------------------------------ egos

    def pose(self, node_id: str, wire: bytes, rx_t: float) -> None:
        """A pose of `node_id` in its 64-byte wire form as it came, unchecked, received at
        `rx_t` [s] (session time, or see `pose_stamp_to_session`): the view's update checks
        and decodes it (a bad one is counted in `dropped` under `pose`). The callback that
        received it then costs next to nothing, which matters most when it runs cold, as it
        does at 50 Hz."""
        if len(wire) != POSE_SIZE:  # joined with the others it would shift every row after it
            self.dropped.add("pose")
        elif node_id != self.own_id:
            self.inbox.append((POSE, node_id, wire, rx_t))

    def pose_rows(self, ids: list[str], rows: bytes, rx_t: float) -> None:
        """Many nodes' poses received together (a `PoseDigest`'s ids and rows), unchecked like
        `pose`'s; this node's own row among them is skipped by the update."""
        if len(rows) != POSE_SIZE * len(ids):
            self.dropped.add("pose", len(ids))
        elif ids:
            self.inbox.append((ROWS, ids, rows, rx_t))

    def skeleton(self, node_id: str, skeleton: Skeleton) -> None:
        if node_id != self.own_id:
            self.inbox.append(("skeleton", node_id, skeleton))

    def state(self, node_id: str, state: EgoState) -> None:
        self.inbox.append(("state", node_id, state))

    # ------------------------------------------------------------ membership

    def present(self, node_id: str) -> None:
        """`node_id` is in the session (its token, a spawn event): its poses count."""
        self.inbox.append(("present", node_id))

    def gone(self, node_id: str, reason: Departure, t: float) -> None:
        """`node_id` left the session at session time `t` [s], for `reason`."""
        self.inbox.append(("gone", node_id, reason, t))

    def snapshot(self, snapshot: Snapshot, rx_t: float) -> None:
        """Everything present when the authority answered: seeds a view that joins late."""
        self.inbox.append(("snapshot", snapshot, rx_t))

    def interest(self, tiles: frozenset[str]) -> None:
        """The tiles this view now hears (its node moved)."""
        self.inbox.append(("interest", tiles))

    # ------------------------------------------------------------ the authority's

    def npc(self, batch: NpcBatch, rx_t: float, tile: str = WHOLE_WORLD) -> None:
        self.inbox.append(("npc", batch, rx_t, tile))

    def lights(self, lights: LightsState) -> None:
        self.inbox.append(("lights", lights))

    def weather(self, weather: Weather) -> None:
        self.inbox.append(("weather", weather))

    def notice(self, notice: Notice) -> None:
        """A scenario message for this participant (or for everyone)."""
        self.inbox.append(("notice", notice))
