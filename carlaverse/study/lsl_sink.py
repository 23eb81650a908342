"""LSL samples in a session's MCAP file: one channel per stream, beside the fabric's keys.

A `McapSink` has one writer thread, the recorder's. `SharedSink` is the same sink with a lock
around every write, so the LSL inlets' threads can add their channels to the very file the
recorder writes (the trial's one MCAP). Each hold is one record: the recorder's writer never
waits longer than one LSL sample's write.

Every LSL sample is one message on topic `lsl/<stream name>`, in the recording's envelope
(`recording/encoding.py`): JSON `{"msg": <LslSample as an object>, "raw": <base64 of its
MessagePack>}` under the JSON Schema `carlaverse.LslSample`; so `recording.reading` yields
`raw` as the payload (`decode_sample` reads it) and Foxglove plots `msg.values[0]` over time.
Log time is when it was received (wall clock, as for every key); publish time is the
sample's session time. The channel's metadata is the stream's LSL info (`lsl.*`).
"""

from __future__ import annotations

import json
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import msgspec

from carlaverse.recording.encoding import MESSAGE_ENCODING, SCHEMA_ENCODING, message_schema
from carlaverse.recording.reading import iter_samples, read_metadata
from carlaverse.recording.sink import McapSink

TOPIC_PREFIX = "lsl/"
_U64_END = 1 << 64


class LslSample(msgspec.Struct, frozen=True):
    """One LSL sample as recorded. Not a fabric message (it never travels on Zenoh), so it
    lives beside the recording of LSL rather than in `carlaverse.messages`."""

    seq: int  # index of the sample in this recording of the stream, from 0
    t: float  # [s] session time of the sample
    lsl_t: float  # [s] the producer's timestamp, on the producing host's LSL local_clock()
    correction_s: float  # [s] inlet.time_correction(): on this host's clock = lsl_t + this
    values: list[float | str | None]  # one per channel; None: NaN (a missing value)


SCHEMA_NAME = "carlaverse.LslSample"
_ENCODER = msgspec.msgpack.Encoder()
_DECODER = msgspec.msgpack.Decoder(LslSample)


def decode_sample(payload: bytes) -> LslSample:
    """An `LslSample` from a recorded payload (`RecordedSample.payload` of an `lsl/` topic)."""
    return _DECODER.decode(payload)


def read_lsl(path: str | Path) -> dict[str, list[LslSample]]:
    """Every LSL channel of a recording: topic (`lsl/<name>`) -> its samples, in order."""
    streams: dict[str, list[LslSample]] = {}
    for recorded in iter_samples(path):
        if recorded.key.startswith(TOPIC_PREFIX):
            streams.setdefault(recorded.key, []).append(decode_sample(recorded.payload))
    return streams


def lsl_summaries(path: str | Path) -> dict[str, dict[str, str]]:
    """Topic -> what its recording ended with (`lsl_record.StreamStats.as_metadata`: samples,
    bad_shape, bad_time, first_t, last_t, nominal_srate, coverage, correction_s,
    clock_bound_s, error); a stream cut off by a crash has none."""
    return {k: v for k, v in read_metadata(path).items() if k.startswith(TOPIC_PREFIX)}


def sample_schema() -> bytes:
    return json.dumps(message_schema(LslSample), separators=(",", ":")).encode()


class SharedSink(McapSink):
    """A `McapSink` the recorder's writer and LSL inlet threads write to together."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # Reentrant: maybe_flush() calls flush(), both locked.
        self._lock = threading.RLock()
        self._json = msgspec.json.Encoder()
        self._sample_schema_id: int | None = None

    # The recorder's calls, each under the lock.
    def write(self, *args: Any, **kwargs: Any) -> bool:
        with self._lock:
            return super().write(*args, **kwargs)

    def attach(self, *args: Any, **kwargs: Any) -> None:
        with self._lock:
            super().attach(*args, **kwargs)

    def metadata(self, name: str, values: Mapping[str, str]) -> None:
        with self._lock:
            super().metadata(name, values)

    def maybe_flush(self) -> bool:
        with self._lock:
            return super().maybe_flush()

    def flush(self) -> None:
        with self._lock:
            super().flush()

    def close(self) -> None:
        with self._lock:
            super().close()

    # The LSL side.
    def add_lsl_channel(self, topic: str, metadata: Mapping[str, str]) -> int:
        """Register channel `topic` for LslSample messages; its id."""
        with self._lock:
            if self._sample_schema_id is None:
                self._sample_schema_id = self._writer.register_schema(
                    SCHEMA_NAME, SCHEMA_ENCODING, sample_schema()
                )
            return self._writer.register_channel(
                topic, MESSAGE_ENCODING, self._sample_schema_id, dict(metadata)
            )

    def write_lsl(self, channel_id: int, sample: LslSample, log_time_ns: int) -> None:
        """Append one sample; `log_time_ns` is when it was received [ns since the epoch]."""
        raw = _ENCODER.encode(sample)
        data = self._json.encode({"msg": sample, "raw": raw})
        publish_ns = round(sample.t * 1e9) if 0.0 <= sample.t < 1.8e10 else log_time_ns
        with self._lock:
            if self._closed:
                return
            self._writer.add_message(
                channel_id, log_time_ns, data, publish_ns, sample.seq & 0xFFFFFFFF
            )
            self.stats.messages += 1
            self._unflushed += 1
