"""The MCAP file a recorder writes: crash-tolerant, chunked, compressed and indexed.

Crash tolerance comes from two choices. The file is written without a user-space buffer,
so every record the MCAP writer emits reaches the kernel at once and survives a SIGKILL of
the recorder. And chunks are closed both when they reach `chunk_size` and at least every
`flush_interval_s`, so at most that much data is lost. What is left after a crash has no
summary section: `mcap`'s stream reader reads it, and `recover()` rewrites it indexed.

What goes in passes the redaction rule (`recording.scrub`): `authority/configs` payloads,
YAML attachments and metadata keep no login or key, whoever sent them.

Not thread-safe: one writer thread owns a sink.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from mcap.writer import CompressionType, IndexType, Writer

from carlaverse.recording.admission import KeyAdmission
from carlaverse.recording.encoding import MESSAGE_ENCODING, SCHEMA_ENCODING, KeyFormat
from carlaverse.recording.scrub import (
    holds_configs,
    scrub_attachment,
    scrub_configs,
    scrub_metadata,
)

Compression = Literal["zstd", "lz4", "none"]
PROFILE = "carlaverse"
DEFAULT_CHUNK_SIZE = 256 * 1024  # [B] uncompressed; small enough to lose little on a crash
_U64_END = 1 << 64
# No message indexes: the writer keeps each chunk's index in memory until the file is closed,
# and with them an entry per channel per chunk: at 256 egos (a chunk every 70 ms, ~256 pose
# channels each) that grew the recorder by 1.4 GB an hour. Chunk indexes stay (time seeks
# still skip to the right chunk); readers of a chunk without message indexes decompress it
# whole, which is what this project's readers do anyway. `recover()` writes full indexes.
INDEX_TYPES = IndexType.ALL & ~IndexType.MESSAGE

_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


def _fits_u64(value: int) -> bool:
    return isinstance(value, int) and 0 <= value < _U64_END


def _publish_ns(t: float | None, log_time_ns: int) -> int:
    """The message's own session time [ns] if it is one MCAP can hold, else the receive time."""
    if t is None or not 0.0 <= t < 1.8e10:  # [s] past year 2500 is not a session time
        return log_time_ns
    return round(t * 1e9)


class RecordingError(OSError):
    """A recording file that cannot be created, written or read."""


class UnbufferedFile:
    """A write-only file whose writes go straight to the kernel (no Python buffer).

    Deliberately not a `RawIOBase`: the MCAP writer would wrap one in a BufferedWriter,
    and buffered bytes die with the process.
    """

    def __init__(self, path: Path) -> None:
        try:
            self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        except OSError as exc:
            raise RecordingError(f"cannot create recording {path}: {exc.strerror}") from exc
        self._path = path
        self._pos = 0

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data)
        while view:
            try:
                written = os.write(self._fd, view)
            except OSError as exc:  # a full disk or a file size limit: name the file
                raise RecordingError(f"cannot write {self._path}: {exc.strerror}") from exc
            view = view[written:]
        self._pos += len(data)
        return len(data)

    def tell(self) -> int:
        """Bytes written so far: the MCAP writer records offsets with it (file protocol)."""
        return self._pos

    def flush(self) -> None:
        """Nothing is buffered here; the kernel owns the bytes already."""

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


@dataclass(slots=True)
class _Channel:
    id: int
    format: KeyFormat
    scrub: bool = False  # payloads carry node configs: redact before writing
    messages: int = 0
    errors: int = 0


@dataclass(slots=True)
class SinkStats:
    messages: int = 0
    bytes_in: int = 0  # [B] payload bytes as received
    decode_errors: int = 0
    rejected: int = 0  # samples not written: a key refused by the admission or a bad time
    bad_times: int = 0  # of them, receive times MCAP cannot hold
    channels: int = 0
    attachments: int = 0
    per_key: dict[str, int] = field(default_factory=dict)


class McapSink:
    """Writes samples, attachments and metadata of one session to an MCAP file."""

    def __init__(
        self,
        path: str | Path,
        *,
        compression: Compression = "zstd",
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        flush_interval_s: float = 1.0,
        monotonic: Callable[[], float],
        admission: KeyAdmission | None = None,
    ) -> None:
        self.path = Path(path)
        # which new keys become channels: present senders first (recording/admission.py)
        self.admission = admission or KeyAdmission()
        self._file = UnbufferedFile(self.path)
        self._writer = Writer(
            self._file,  # type: ignore[arg-type]  # mcap types it IO; it calls write, tell, flush
            chunk_size=chunk_size,
            compression=_COMPRESSION[compression],
            index_types=INDEX_TYPES,
        )
        self._writer.start(profile=PROFILE, library="carlaverse-recorder")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, _Channel] = {}
        self._monotonic = monotonic
        self._flush_interval_s = flush_interval_s
        self._last_flush = monotonic()
        self._unflushed = 0
        self._closed = False
        self.stats = SinkStats()

    def write(
        self,
        key: str,
        payload: bytes,
        log_time_ns: int,
        kind: str = "put",
        channel_metadata: Mapping[str, str] | None = None,
    ) -> bool:
        """Append one sample; `log_time_ns` is when it was received [ns since the epoch].

        Never raises for what a sample holds: a payload that does not decode is written raw
        with its error; a sample that cannot be written at all (a new key the admission
        refuses, a receive time outside MCAP's range) is counted in `stats.rejected` and False
        returned.
        Everything handed to the MCAP writer is checked first, because a value it refuses
        half-way through a record would leave a corrupt chunk behind.
        """
        if not _fits_u64(log_time_ns):
            self.stats.rejected += 1
            self.stats.bad_times += 1
            return False
        channel = self._channels.get(key) or self._add_channel(key, channel_metadata or {})
        if channel is None:
            self.stats.rejected += 1
            return False
        if channel.scrub and kind == "put":
            payload = scrub_configs(payload)
        encoded = channel.format.encode(payload, kind)
        publish_ns = _publish_ns(encoded.t, log_time_ns)
        sequence = (channel.messages if encoded.seq is None else encoded.seq) & 0xFFFFFFFF
        self._writer.add_message(channel.id, log_time_ns, encoded.data, publish_ns, sequence)
        self._count(key, channel, len(payload), bool(encoded.error))
        return True

    def _count(self, key: str, channel: _Channel, size: int, undecodable: bool) -> None:
        channel.messages += 1
        self.stats.messages += 1
        self.stats.bytes_in += size
        self.stats.per_key[key] = channel.messages
        if undecodable:
            channel.errors += 1
            self.stats.decode_errors += 1
        self._unflushed += 1

    def has_channel(self, key: str) -> bool:
        return key in self._channels

    def attach(self, name: str, media_type: str, data: bytes, log_time_ns: int) -> None:
        """Store a file (a node's config, the scenario); YAML with its secrets blanked."""
        data = scrub_attachment(name, media_type, data)
        self._writer.add_attachment(log_time_ns, log_time_ns, name, media_type, data)
        self.stats.attachments += 1

    def metadata(self, name: str, values: Mapping[str, str]) -> None:
        """A named string map (MCAP metadata values must be strings), secrets blanked."""
        self._writer.add_metadata(name, scrub_metadata(values))

    def maybe_flush(self) -> bool:
        """Close the open chunk if it has aged `flush_interval_s`; True if it did."""
        if not self._unflushed or self._monotonic() - self._last_flush < self._flush_interval_s:
            return False
        self.flush()
        return True

    def flush(self) -> None:
        self._writer.flush()
        self._last_flush = self._monotonic()
        self._unflushed = 0

    def close(self) -> None:
        """Write the summary and indexes; the file is then readable by the indexed reader."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
        finally:
            self._file.close()

    def _add_channel(self, key: str, metadata: Mapping[str, str]) -> _Channel | None:
        if not self.admission.admit(key):
            return None  # a storm of made-up keys must not grow the file's index without end
        fmt = KeyFormat(key)
        schema_id = self._schemas.get(fmt.schema_name)
        if schema_id is None:
            schema_id = self._writer.register_schema(
                fmt.schema_name, SCHEMA_ENCODING, fmt.schema_bytes()
            )
            self._schemas[fmt.schema_name] = schema_id
        channel_id = self._writer.register_channel(key, MESSAGE_ENCODING, schema_id, dict(metadata))
        channel = _Channel(channel_id, fmt, scrub=holds_configs(key))
        self._channels[key] = channel
        self.stats.channels = len(self._channels)
        return channel
