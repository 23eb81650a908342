"""Republish a recording into a live session with its original timing (docs/architecture.md §11).

Each sample goes out at `start + (log_time - first_log_time) / speed`, with its original
payload byte for byte and its key moved under the target session. Timing is kept tight by
sleeping until ~1 ms before a deadline and spinning the rest (a plain sleep overshoots by
up to a scheduler tick). A sample that is already late is sent at once, never skipped; the
lateness is counted.

A replay is a session: the replaying process answers for the target session's authority
(`replay_authority`): observers join it, its clock tells recorded session time as the replay
plays it, its snapshot lists the world as replayed so far, and it serves the recorded map,
scenario and configs (redacted, whatever the recording holds). The world messages it
republishes carry its own session's timestamps, as a live authority's do, so every viewer,
renderer, audio renderer and analysis takes them as from the session's authority; recorded
presence (`node/<id>`) becomes liveliness tokens of the replaying session. Without queries
(`serve_queries=False`, a live authority runs in the target session) none of that is done.

Commands are withheld unless asked for (`with_commands`): `impulse/*` and `ego/*/override`
move real wheels and motion platforms, and a replay must not drive a live rig by accident.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import zenoh

from carlaverse.keys import AUTHORITY_ID, Keys, KeySpaceError, parse, parse_cached
from carlaverse.recording.reading import RecordedSample
from carlaverse.recording.replay_authority import ReplayAuthority
from carlaverse.recording.replay_clock import ReplayClock

log = logging.getLogger(__name__)

SPIN_S = 0.001  # [s] busy-wait this close to a deadline
LATE_S = 0.001  # [s] a sample sent later than this counts as late
REPLAY_SUFFIX = "-replay"
# What only the session's authority publishes: republished with the replay authority's stamp.
AUTHORITY_AREAS = ("world", "impulse", "audio")


def is_command(key: str) -> bool:
    """Keys whose samples act on hardware: collision impulses and ego overrides."""
    parsed = parse(key)
    return parsed.area == "impulse" or (parsed.area == "ego" and parsed.channel == "override")


def default_target(recorded_session: str) -> str:
    """`<recorded>-replay`: a replay never lands in the recorded session unless told to."""
    return recorded_session[: 63 - len(REPLAY_SUFFIX)] + REPLAY_SUFFIX


def wait_until(
    deadline: float,
    clock: Callable[[], float],
    sleep: Callable[[float], None],
    stop: threading.Event,
    spin_s: float = SPIN_S,
) -> bool:
    """Return at `deadline` (clock seconds), or False early if `stop` is set."""
    while True:
        remaining = deadline - clock()
        if remaining <= 0:
            return True
        if stop.is_set():
            return False
        if remaining > spin_s:
            sleep(min(remaining - spin_s, 0.05))  # wake now and then to notice `stop`


@dataclass(slots=True)
class ReplayStats:
    published: int = 0
    passes: int = 0
    late: int = 0  # samples sent more than LATE_S after their slot
    max_late_s: float = 0.0  # [s]
    skipped: int = 0  # keys outside the key space (recorded by a newer carlaverse)
    withheld: int = 0  # command samples not sent (impulse, override) without with_commands
    per_key: Counter[str] = field(default_factory=Counter)
    # what the replay's authority answered: join/accepted, join/refused, <query>/bad_request
    answered: Counter[str] = field(default_factory=Counter)


def _qos(metadata: Mapping[str, str]) -> dict[str, Any]:
    """Publisher settings from the channel metadata the recorder wrote."""
    qos: dict[str, Any] = {}
    cc = metadata.get("zenoh.congestion_control")
    if cc and hasattr(zenoh.CongestionControl, cc):
        qos["congestion_control"] = getattr(zenoh.CongestionControl, cc)
    prio = metadata.get("zenoh.priority")
    if prio and hasattr(zenoh.Priority, prio):
        qos["priority"] = getattr(zenoh.Priority, prio)
    if "zenoh.express" in metadata:
        qos["express"] = metadata["zenoh.express"] == "true"
    if metadata.get("zenoh.encoding"):
        qos["encoding"] = zenoh.Encoding(metadata["zenoh.encoding"])
    return qos


class Replayer:
    """Publishes recorded samples on a Zenoh session under `target_session`; one thread calls
    `run`. `session_offset_ns`: the recorder's log time minus session time
    (`timeline.receive_offset_ns`), which turns a sample's log time into the session time the
    replay's clock tells when it goes out."""

    def __init__(
        self,
        session: zenoh.Session,
        target_session: str,
        *,
        speed: float = 1.0,
        serve_queries: bool = True,
        with_commands: bool = False,
        session_offset_ns: int = 0,
        clock: Callable[[], float] = time.perf_counter,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if speed <= 0:
            raise ValueError(f"replay speed must be > 0, got {speed}")
        self._session = session
        self._target = target_session
        self._speed = speed
        self._with_commands = with_commands
        self._offset_ns = session_offset_ns
        self._clock = clock
        self._sleep = sleep
        self._keys: dict[str, str | None] = {}
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._tokens: dict[str, Any] = {}
        self.stats = ReplayStats()
        self.session_clock = ReplayClock(speed, clock)
        self.authority: ReplayAuthority | None = None
        if serve_queries:  # answering once `prepare` or `run` starts it (after `preload`)
            self.authority = ReplayAuthority(session, Keys(target_session), self.session_clock)

    def run(
        self,
        source: Callable[[], Iterable[RecordedSample]],
        stop: threading.Event,
        loop: bool = False,
    ) -> ReplayStats:
        """Replay `source()` once (or until `stop` with `loop`); returns the counts."""
        self._answer()
        while not stop.is_set():
            self._one_pass(source(), stop)
            self.stats.passes += 1
            if not loop:
                break
        return self.stats

    def prepare(
        self, channels: Mapping[str, Mapping[str, str]], start_t: float | None = None
    ) -> None:
        """Declare a publisher per recorded key up front, so subscribers can match early;
        the session clock holds at `start_t` [s] (the recording's start) until the replay
        starts. The authority answers from here on: call `preload` first."""
        for key, metadata in channels.items():
            target = self._target_key(key)
            if target is not None and self._publishes(target):
                self._publisher(target, metadata)
        if start_t is not None:
            self.session_clock.hold(start_t)
        self._answer()

    def _answer(self) -> None:
        """Start answering for the session's authority (once)."""
        if self.authority is not None and not self.authority.started:
            self.authority.start()

    def preload(self, samples: Iterable[RecordedSample]) -> None:
        """Serve the first recorded reply of each authority query from the start, before the
        replay reaches it (a viewer asks for the map as it joins), and know every recorded
        snapshot's nodes (what each is: kind, actor, extent). Before `prepare`: a node
        that joined before it would be told there is no map."""
        if self.authority is None:
            return
        seen: set[str] = set()
        for sample in samples:
            key = self._target_key(sample.key)
            parsed = parse_cached(key) if key is not None else None
            if parsed is None or parsed.area != "authority":
                continue
            if parsed.channel == "snapshot":  # what each recorded node is, from the start
                self.authority.world.know(sample.payload)
            if parsed.channel not in seen:
                seen.add(parsed.channel)
                self.authority.recorded_reply(parsed.channel, sample.payload)

    def wait_for_subscribers(self, stop: threading.Event, timeout_s: float = 2.0) -> bool:
        """Until some subscriber matches a prepared key (declarations have arrived)."""
        deadline = time.monotonic() + timeout_s
        # zenoh 1.10's stub types `matching_status` as bool; it is a MatchingStatus at run time.
        while not any(p.matching_status.matching for p in self._publishers.values()):  # type: ignore[attr-defined]
            if time.monotonic() > deadline or stop.wait(0.01):
                return False
        return True

    def close(self) -> None:
        for handle in self._publishers.values():
            handle.undeclare()
        self._publishers.clear()
        self._drop_tokens()
        if self.authority is not None:
            self.authority.close()
            self.stats.answered.update(self.authority.counts)
            self.authority = None

    def _one_pass(self, samples: Iterable[RecordedSample], stop: threading.Event) -> None:
        start = self._clock()
        first_ns: int | None = None
        try:
            for sample in samples:
                if first_ns is None:
                    first_ns = sample.log_time_ns
                    self._begin_pass(sample.log_time_ns, start)
                due = start + (sample.log_time_ns - first_ns) / 1e9 / self._speed
                if not wait_until(due, self._clock, self._sleep, stop):
                    return
                self._count_lateness(self._clock() - due)
                self._send(sample)
        finally:
            self.session_clock.stop()

    def _begin_pass(self, first_ns: int, start: float) -> None:
        """The session clock starts at the pass's first sample; a pass after another is a new
        timeline, which the recorded nodes leave first."""
        if self.stats.passes > 0:
            self._drop_tokens()
            if self.authority is not None:
                self.authority.new_timeline()
        self.session_clock.start_pass((first_ns - self._offset_ns) / 1e9, start)

    def _count_lateness(self, late_s: float) -> None:
        if late_s > LATE_S:
            self.stats.late += 1
            self.stats.max_late_s = max(self.stats.max_late_s, late_s)

    # ------------------------------------------------------------------ sending

    def _publishes(self, key: str) -> bool:
        """Whether samples of `key` go out as puts (not served, not presence, not withheld)."""
        area = parse(key).area
        return area not in ("authority", "node") and (self._with_commands or not is_command(key))

    def _send(self, sample: RecordedSample) -> None:
        key = self._target_key(sample.key)
        if key is None:
            self.stats.skipped += 1
            return
        if not self._with_commands and is_command(key):
            self.stats.withheld += 1
            return
        parsed = parse_cached(key)
        if parsed.area == "authority":
            if self.authority is not None:
                self.authority.recorded_reply(parsed.channel, sample.payload)
        elif parsed.area == "node":
            self._presence(key, parsed.node_id, sample.kind)
        else:
            self._publish(key, parsed.area, sample)
        if self.authority is not None:
            self.authority.world.take(parsed, sample.kind, sample.payload)
        self.stats.published += 1
        self.stats.per_key[key] += 1

    def _target_key(self, key: str) -> str | None:
        if key not in self._keys:
            try:
                parsed = parse(key)
                self._keys[key] = Keys(parsed.session).with_session(key, self._target)
            except KeySpaceError as exc:
                log.warning("not replaying %s: %s", key, exc)
                self._keys[key] = None
        return self._keys[key]

    def _publisher(self, key: str, metadata: Mapping[str, str]) -> zenoh.Publisher:
        publisher = self._publishers.get(key)
        if publisher is None:
            publisher = self._session.declare_publisher(key, **_qos(metadata))
            self._publishers[key] = publisher
        return publisher

    def _publish(self, key: str, area: str, sample: RecordedSample) -> None:
        publisher = self._publisher(key, sample.channel_metadata)
        if sample.kind == "delete":
            publisher.delete()
        elif self.authority is not None and area in AUTHORITY_AREAS:
            publisher.put(sample.payload, timestamp=self.authority.stamp())
        else:
            publisher.put(sample.payload)

    def _presence(self, key: str, node_id: str, kind: str) -> None:
        if node_id == AUTHORITY_ID and self.authority is not None:
            return  # the replay's authority holds this session's authority token
        if kind == "delete":
            token = self._tokens.pop(key, None)
            if token is not None:
                token.undeclare()
        elif key not in self._tokens:
            self._tokens[key] = self._session.liveliness().declare_token(key)

    def _drop_tokens(self) -> None:
        for token in self._tokens.values():
            token.undeclare()
        self._tokens.clear()
