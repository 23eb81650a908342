"""Which new keys a recording takes while keys are scarce: present senders first (issue 39).

Every key a recording holds costs a channel record and index entries, and in an open session
anyone can invent keys, so their number is bounded. First come, first served would let a flood
of made-up keys take the room a real node's next tile needs (the attack that filled 4096 keys
and refused 1002 samples), so the room is shared out by sender:

- Each key is charged to the node it is about (`sender_of`): `node/<id>`, `ego/<id>/…`,
  `impulse/<id>` and `audio/<id>` to `<id>`; `world/…` and `authority/…` to the authority; a
  key of no known shape (`carlaverse.keys.parse` refuses it) to nobody ("").
- A sender is *present* while its liveliness token `node/<id>` is (the recorder follows the
  tokens as the authority does; at most `MAX_PRESENT` ids, more are not tracked).
- Present senders share `max_channels` keys. Everyone else -- ids without a token, keys of no
  known shape -- shares `stranger_channels` more, apart: they can never take a present
  sender's room.
- No sender holds more than `per_sender` keys (the authority `per_authority`: its NPC batches
  take a key per tile), so one present node cannot crowd out the others either.
- A key once taken stays; one refused is asked about again at its next sample, so a node whose
  first sample beat its token into the recorder is recorded from its next sample on.

What this cannot tell apart: without a roster anyone may declare any token and put under any
id, so a forger who names a present id spends that id's share (never another's), and forged
tokens make forged senders present. With a roster (docs/architecture.md §12) the routers let a
node declare only its own token and put only under its own `ego/<id>/`, and only the
authority write `world/`: each share is then spent by its owner alone.

Pure bookkeeping, no I/O; used by the one writer thread that owns the sink.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from carlaverse.keys import AUTHORITY_ID, KeySpaceError, parse_cached

DEFAULT_MAX_CHANNELS = 4096  # keys of present senders: ~600 nodes' worth of channels
MAX_PRESENT = 4096  # ids followed as present; as many tokens as the authority remembers
REASONS = ("sender_full", "present_full", "strangers_full")  # why a new key was refused


def sender_of(key: str) -> str:
    """The id a key is charged to: the node it is about, the authority for the world, or ""
    for a key of no known shape."""
    try:
        parsed = parse_cached(key)
    except KeySpaceError:
        return ""
    return parsed.node_id or AUTHORITY_ID


@dataclass(frozen=True, slots=True)
class Budget:
    """How many keys a recording takes, and from whom."""

    max_channels: int = DEFAULT_MAX_CHANNELS  # keys of present senders, together
    stranger_channels: int = DEFAULT_MAX_CHANNELS // 8  # keys of everyone else, together
    per_sender: int = DEFAULT_MAX_CHANNELS // 8  # one node: 512 tiles of poses and the rest
    per_authority: int = DEFAULT_MAX_CHANNELS // 2  # the world: an NPC batch per tile


class KeyAdmission:
    """Decides, for each new key, whether the recording takes it (`admit`)."""

    def __init__(self, budget: Budget = Budget()) -> None:
        self.budget = budget
        self._present: set[str] = set()
        self._held: Counter[str] = Counter()  # keys taken, by sender
        self._present_keys = 0  # keys taken while their sender was present
        self._stranger_keys = 0  # keys taken from the strangers' share
        # samples of new keys refused, by reason; fixed keys: read by other threads as is
        self.refused: dict[str, int] = dict.fromkeys(REASONS, 0)

    def present(self, node_id: str) -> None:
        """`node_id`'s liveliness token appeared."""
        if len(self._present) < MAX_PRESENT:
            self._present.add(node_id)

    def absent(self, node_id: str) -> None:
        """`node_id`'s liveliness token went."""
        self._present.discard(node_id)

    def is_present(self, node_id: str) -> bool:
        return node_id in self._present

    def admit(self, key: str) -> bool:
        """Whether a new `key` may become a channel; taken into account if so, the refusal
        counted in `refused` by reason if not."""
        reason = self._refusal(key)
        if reason:
            self.refused[reason] += 1
            return False
        return True

    def _refusal(self, key: str) -> str:
        sender = sender_of(key)
        budget = self.budget
        cap = budget.per_authority if sender == AUTHORITY_ID else budget.per_sender
        if sender and self._held[sender] >= cap:
            return "sender_full"
        if sender in self._present:
            if self._present_keys >= budget.max_channels:
                return "present_full"
            self._present_keys += 1
        else:
            if self._stranger_keys >= budget.stranger_channels:
                return "strangers_full"
            self._stranger_keys += 1
        if sender:
            self._held[sender] += 1
        return ""
