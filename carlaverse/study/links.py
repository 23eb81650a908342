"""Each participant's link to the router, through the link emulator (issue 44.5).

A participant's agent, node and view probe reach the router through a relay of their own
(`carlaverse.transport.link_emulator`), so a trial can give that participant's link delay,
jitter and loss, both directions alike: what the participant publishes reaches everyone late,
and what everyone publishes reaches the participant late. Between trials the link is clear.
"""

from __future__ import annotations

import re

from carlaverse.study.study_file import LinkCondition, Participant
from carlaverse.transport.link_emulator import LinkEmulator, LinkProfile

_TCP = re.compile(r"tcp/(?P<host>[^:/]+):(?P<port>[0-9]{1,5})")
CLEAR = LinkCondition()


def profile(condition: LinkCondition) -> LinkProfile:
    """The emulator's profile of one direction (the study file keeps jitter within delay)."""
    return LinkProfile(condition.delay_ms / 1e3, condition.jitter_ms / 1e3, condition.loss)


def router_address(endpoint: str) -> tuple[str, int]:
    """(host, port) of a `tcp/HOST:PORT` router endpoint; ValueError for any other."""
    match = _TCP.fullmatch(endpoint)
    if match is None:
        raise ValueError(f"the link emulator relays TCP: expected tcp/HOST:PORT, got {endpoint!r}")
    return match["host"], int(match["port"])


class ParticipantLinks:
    """One relay per participant, listening on loopback (or the participant's `link_port`
    on `bind`), relaying to the router."""

    def __init__(
        self, participants: list[Participant], router: str, bind: str = "127.0.0.1", seed: int = 0
    ) -> None:
        target = router_address(router)
        self.bind = bind
        self._relays = {
            p.id: LinkEmulator((bind, p.link_port), target, seed=seed + i, name=f"link-{p.id}")
            for i, p in enumerate(participants)
        }
        self.current: dict[str, LinkCondition] = dict.fromkeys(self._relays, CLEAR)

    def start(self) -> ParticipantLinks:
        for relay in self._relays.values():
            relay.start()
        return self

    def endpoint(self, participant: str) -> str:
        """Where this participant's processes connect: `tcp/HOST:PORT` of their relay."""
        host, port = self._relays[participant].address
        return f"tcp/{host}:{port}"

    def apply(self, conditions: dict[str, LinkCondition]) -> None:
        """Give each participant's link its condition (those not named: clear)."""
        for pid, relay in self._relays.items():
            condition = conditions.get(pid, CLEAR)
            relay.set_profile(profile(condition))
            self.current[pid] = condition

    def counts(self) -> dict[str, dict[str, int]]:
        """Per participant: what the relay counted (connections accepted, errors)."""
        return {pid: dict(relay.counts) for pid, relay in self._relays.items()}

    def close(self) -> None:
        for relay in self._relays.values():
            relay.close()
