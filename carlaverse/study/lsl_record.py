"""Record LSL streams named in a study (eye tracker, ECG, EDA, EEG) into the trial's MCAP.

    streams = resolve(pylsl, ["ECG", "Tobii"], timeout_s=10)  # StreamMissing names the absent
    recording = LslRecording(session, keys, sink, pylsl, streams).start()
    ...
    stats = recording.stop()          # before the recorder closes the sink

Time: a producer stamps each sample on its own host's `local_clock()`. The inlet's
`time_correction()` is the offset from that clock to this host's (liblsl measures it with
NTP-like probes; on one host it is ~0), and the session clock followed on this host's LSL
clock (`lsl_clock.SessionTimeFollower`) takes it on to session time:

    session t = (lsl_t + correction_s) + session offset

Both terms are recorded with every sample (`lsl_sink.LslSample`), so an analysis can redo the
mapping. The accuracy measured on loopback is in docs/benchmarks.md ("LSL to session time").

Each stream has a thread that pulls chunks; until the session clock is synced it pulls
nothing, and liblsl's own inlet buffer (`max_buflen_s`) holds what arrives meanwhile. A
sample with the wrong channel count or a timestamp that is not finite is counted and dropped.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import zenoh

from carlaverse.keys import Keys
from carlaverse.study.lsl_api import LslClock, stream_errors
from carlaverse.study.lsl_clock import SessionTimeFollower
from carlaverse.study.lsl_sink import TOPIC_PREFIX, LslSample, SharedSink

log = logging.getLogger(__name__)

CHUNK_MAX = 1024  # samples pulled at once (4 s of ECG at 250 Hz, 1 s of EEG at 1 kHz)
CORRECTION_TIMEOUT_S = 2.0  # [s] liblsl's first clock probe round on a LAN takes ~0.1 s
MAX_BUFLEN_S = 360  # [s] what liblsl holds for us while the session clock is not synced


class StreamMissing(LookupError):
    """A named LSL stream was not found before the deadline."""


@dataclass(slots=True)
class StreamStats:
    """How one stream's recording went; written to the MCAP as metadata `lsl/<name>`."""

    name: str
    topic: str
    samples: int = 0  # written
    bad_shape: int = 0  # dropped: channel count not the stream's
    bad_time: int = 0  # dropped: timestamp not finite
    first_t: float = math.nan  # [s] session time of the first sample written
    last_t: float = math.nan  # [s] of the last
    correction_s: float = math.nan  # [s] the last time correction used
    clock_bound_s: float = math.inf  # [s] the session offset's error bound at the end
    error: str = ""  # why the stream's thread stopped early, "" if it did not

    def as_metadata(self, info: Any) -> dict[str, str]:
        srate = float(info.nominal_srate())
        expected = (self.last_t - self.first_t) * srate + 1 if srate > 0 else math.nan
        return {
            "samples": str(self.samples),
            "bad_shape": str(self.bad_shape),
            "bad_time": str(self.bad_time),
            "first_t": repr(self.first_t),
            "last_t": repr(self.last_t),
            "nominal_srate": repr(srate),
            # samples written / samples the nominal rate gives between first and last
            "coverage": repr(self.samples / expected) if expected > 0 else "nan",
            "correction_s": repr(self.correction_s),
            "clock_bound_s": repr(self.clock_bound_s),
            "error": self.error,
        }


def predicate(name: str) -> str:
    """The LSL XPath query for `NAME` or `NAME@HOST`."""
    stream, _, host = name.partition("@")
    query = f"name='{stream}'"
    return f"{query} and hostname='{host}'" if host else query


def resolve(pylsl: Any, names: Sequence[str], timeout_s: float) -> list[Any]:
    """The StreamInfo of each named stream (`NAME` or `NAME@HOST`), all found within
    `timeout_s` [s] in total; StreamMissing names those that were not, and what was seen."""
    for name in names:
        if not name or "'" in name:
            raise StreamMissing(f"--lsl {name!r}: not a stream name (empty, or a quote in it)")
    deadline = time.monotonic() + timeout_s
    # Listens meanwhile, so the error can say what *was* there without a second wait
    # (resolve_streams() sometimes takes seconds beyond its wait time).
    everything = pylsl.ContinuousResolver()
    found: dict[str, Any] = {}
    for name in names:
        left = max(0.0, deadline - time.monotonic())
        infos = pylsl.resolve_bypred(predicate(name), 1, left)
        if infos:
            found[name] = infos[0]
    missing = [n for n in names if n not in found]
    if missing:
        seen = sorted({f"{i.name()}@{i.hostname()}" for i in everything.results()})
        raise StreamMissing(
            f"LSL stream(s) {', '.join(missing)} not found within {timeout_s:g} s "
            f"(streams seen: {', '.join(seen) or 'none'}); start the device's LSL app, or "
            "check its name, host and the LSL scope (--lsl-scope lab reaches other hosts)"
        )
    return [found[n] for n in names]


def stream_metadata(info: Any) -> dict[str, str]:
    """A stream's LSL info as MCAP channel metadata (all strings)."""
    return {
        "lsl.name": info.name(),
        "lsl.type": info.type(),
        "lsl.channel_count": str(info.channel_count()),
        "lsl.nominal_srate": repr(float(info.nominal_srate())),
        "lsl.channel_format": str(info.channel_format()),
        "lsl.source_id": info.source_id(),
        "lsl.hostname": info.hostname(),
        "lsl.uid": info.uid(),
        "lsl.session_id": info.session_id(),
        "lsl.created_at": repr(float(info.created_at())),
        "lsl.info_xml": info.as_xml(),
    }


class SampleMapper:
    """Checks a pulled chunk and turns each good sample into an `LslSample` (no I/O)."""

    def __init__(self, channel_count: int, stats: StreamStats) -> None:
        self.channel_count = channel_count
        self.stats = stats
        self._seq = 0

    def map(
        self,
        values: Sequence[Sequence[Any]],
        stamps: Sequence[float],
        correction_s: float,
        to_session: Callable[[float], float],
    ) -> list[LslSample]:
        out = []
        for row, lsl_t in zip(values, stamps, strict=False):
            if len(row) != self.channel_count:
                self.stats.bad_shape += 1
                continue
            if not math.isfinite(lsl_t):
                self.stats.bad_time += 1
                continue
            t = to_session(lsl_t + correction_s)
            out.append(LslSample(self._seq, t, lsl_t, correction_s, [_value(v) for v in row]))
            self._seq += 1
        return out


def _value(v: Any) -> float | str | None:
    if isinstance(v, str):
        return v
    f = float(v)
    return f if math.isfinite(f) else None  # NaN: the device's "no value" (a blink)


class _StreamThread:
    """Pulls one stream's inlet and writes its samples to the sink."""

    def __init__(
        self,
        pylsl: Any,
        info: Any,
        sink: SharedSink,
        follower: SessionTimeFollower,
        stop: threading.Event,
        topic: str,
        wall_ns: Callable[[], int],
    ) -> None:
        self.info = info
        self.stats = StreamStats(info.name(), topic)
        self._pylsl, self._sink, self._follower = pylsl, sink, follower
        self._stop, self._wall_ns = stop, wall_ns
        self._mapper = SampleMapper(info.channel_count(), self.stats)
        # Opened now: from here liblsl buffers the stream whether or not we pull yet.
        self._inlet = pylsl.StreamInlet(info, max_buflen=MAX_BUFLEN_S, recover=True)
        try:
            self._inlet.open_stream(timeout=CORRECTION_TIMEOUT_S)
            # The full info (a resolved one lacks the description: channel labels, units).
            self.info = self._inlet.info(timeout=CORRECTION_TIMEOUT_S)
        except stream_errors(pylsl) as exc:
            raise StreamMissing(
                f"LSL stream {info.name()}@{info.hostname()} was found but did not open within "
                f"{CORRECTION_TIMEOUT_S:g} s ({exc}): is a firewall between the hosts?"
            ) from exc
        self._channel = sink.add_lsl_channel(topic, stream_metadata(self.info))
        self.thread = threading.Thread(target=self._run, name=f"lsl-{topic}", daemon=True)

    def _run(self) -> None:
        try:
            while not self._stop.is_set() and not self._follower.wait_synced(0.1):
                pass
            if not self._follower.synced:
                self.stats.error = "no authority answered a clock query: no session time"
                return
            while not self._stop.is_set():
                self._pull(timeout_s=0.1)
            while self._pull(timeout_s=0.0):  # what arrived before the stop
                pass
        except Exception as exc:  # a broken stream ends its own recording, never the others
            self.stats.error = f"{type(exc).__name__}: {exc}"
            log.error("LSL stream %s stopped: %s", self.stats.name, self.stats.error)
        finally:
            self.stats.clock_bound_s = self._follower.uncertainty_s
            self._inlet.close_stream()

    def _pull(self, timeout_s: float) -> int:
        """Pull and write one chunk; how many samples it held (bad ones included)."""
        values, stamps = self._inlet.pull_chunk(timeout=timeout_s, max_samples=CHUNK_MAX)
        if not stamps:
            return 0
        received_ns = self._wall_ns()
        correction = self._correction()
        samples = self._mapper.map(values, stamps, correction, self._follower.to_session)
        for sample in samples:
            self._sink.write_lsl(self._channel, sample, received_ns)
        if samples:
            if self.stats.samples == 0:
                self.stats.first_t = samples[0].t
            self.stats.samples += len(samples)
            self.stats.last_t = samples[-1].t
        return len(stamps)

    def _correction(self) -> float:
        """liblsl's latest estimate (it re-probes in the background); the last one if a
        probe round times out."""
        try:
            self.stats.correction_s = float(self._inlet.time_correction(CORRECTION_TIMEOUT_S))
        except stream_errors(self._pylsl):
            if math.isnan(self.stats.correction_s):
                raise
        return self.stats.correction_s


class LslRecording:
    """Records resolved LSL streams into a `SharedSink` until `stop()`."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        sink: SharedSink,
        pylsl: Any,
        streams: Sequence[Any],
        *,
        follower: SessionTimeFollower | None = None,
        wall_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        self._own_follower = follower is None
        self.follower = follower or SessionTimeFollower(session, keys, LslClock(pylsl))
        self._sink = sink
        self._stop = threading.Event()
        self._threads = [
            _StreamThread(pylsl, info, sink, self.follower, self._stop, topic, wall_ns)
            for info, topic in zip(streams, topics(streams), strict=True)
        ]

    def start(self) -> LslRecording:
        if self._own_follower:
            self.follower.start()
        for stream in self._threads:
            stream.thread.start()
        return self

    def stats(self) -> list[StreamStats]:
        return [stream.stats for stream in self._threads]

    def stop(self) -> list[StreamStats]:
        """Pull what is left, stop, write each stream's stats as metadata `lsl/<name>`."""
        self._stop.set()
        for stream in self._threads:
            stream.thread.join(timeout=5)
        for stream in self._threads:
            self._sink.metadata(stream.stats.topic, stream.stats.as_metadata(stream.info))
        if self._own_follower:
            self.follower.close()
        return self.stats()


def topics(streams: Sequence[Any]) -> list[str]:
    """`lsl/<name>`, or `lsl/<name>@<host>` where two hosts send streams of one name."""
    names = [info.name() for info in streams]
    return [
        TOPIC_PREFIX + (n if names.count(n) == 1 else f"{n}@{info.hostname()}")
        for n, info in zip(names, streams, strict=True)
    ]


def record_lsl(
    session: zenoh.Session,
    keys: Keys,
    sink: SharedSink,
    pylsl: Any,
    names: Sequence[str],
    timeout_s: float = 10.0,
) -> LslRecording:
    """Resolve `names` (StreamMissing if one is absent after `timeout_s` [s]) and start
    recording them into `sink`: the study runner's one call per trial."""
    return LslRecording(session, keys, sink, pylsl, resolve(pylsl, names, timeout_s)).start()
