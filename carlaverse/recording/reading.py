"""Read a carlaverse recording back: samples with their original payloads, and attachments.

Finished files are read through their index in log-time order; a file a killed recorder
left behind (no summary) is read front to back with the stream reader, up to its last
complete chunk, so replay and view work on it too.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from zstandard import ZstdError

from carlaverse import messages
from carlaverse.messages import MessageError
from carlaverse.recording.encoding import payload_of
from carlaverse.recording.sink import RecordingError

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class RecordedSample:
    key: str
    payload: bytes  # exactly as it travelled on the fabric
    kind: str  # put | delete
    log_time_ns: int  # [ns since the epoch] when the recorder received it
    publish_time_ns: int  # [ns] the message's session time, or log time if it has none
    channel_metadata: Mapping[str, str]


def _open(path: Path) -> BinaryIO:
    try:
        return path.open("rb")
    except OSError as exc:
        raise RecordingError(f"cannot open recording {path}: {exc.strerror}") from exc


def is_finished(path: str | Path) -> bool:
    """True if the file has its summary (indexed reading works)."""
    with _open(Path(path)) as f:
        try:
            return make_reader(f).get_summary() is not None
        except (McapError, ValueError, struct.error):
            return False


def iter_samples(path: str | Path, topics: Iterable[str] | None = None) -> Iterator[RecordedSample]:
    """Every recorded sample (on `topics` only, when given), in receive order; bad envelopes
    are logged and skipped. A finished file skips the chunks that hold none of `topics`."""
    path = Path(path)
    finished = is_finished(path)
    wanted = None if topics is None else list(topics)
    if wanted == []:
        return  # no channel asked for (the reader would take an empty list for all of them)
    with _open(path) as f:
        records = _indexed(f, wanted) if finished else _streamed(f)
        for channel, message in records:
            if wanted is not None and channel.topic not in wanted:
                continue
            sample = _sample(channel, message)
            if sample is not None:
                yield sample


def _indexed(f: BinaryIO, topics: list[str] | None) -> Iterator[tuple[Channel, Message]]:
    reader = make_reader(f)
    for _schema, channel, message in reader.iter_messages(topics, log_time_order=True):
        yield channel, message


def _streamed(f: BinaryIO) -> Iterator[tuple[Channel, Message]]:
    channels: dict[int, Channel] = {}
    records = StreamReader(f, validate_crcs=True).records
    while True:
        try:
            record = next(records)
        except StopIteration:
            return
        except (McapError, ValueError, struct.error, ZstdError) as exc:
            log.info("unfinished recording ends at an incomplete record (%s)", exc)
            return
        if isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message) and record.channel_id in channels:
            yield channels[record.channel_id], record


def _sample(channel: Channel, message: Message) -> RecordedSample | None:
    try:
        payload, kind = payload_of(message.data)
    except MessageError as exc:
        log.warning("skipping a message on %s: %s", channel.topic, exc)
        return None
    return RecordedSample(
        channel.topic, payload, kind, message.log_time, message.publish_time, channel.metadata
    )


def read_channels(path: str | Path) -> dict[str, Mapping[str, str]]:
    """Key -> channel metadata of every channel in the recording."""
    path = Path(path)
    if is_finished(path):
        with _open(path) as f:
            summary = make_reader(f).get_summary()
            channels = summary.channels.values() if summary else ()
            return {c.topic: c.metadata for c in channels}
    return {s.key: s.channel_metadata for s in iter_samples(path)}


def read_attachments(path: str | Path) -> dict[str, bytes]:
    """Attachment name -> data (the latest one for a name attached more than once)."""
    with _open(Path(path)) as f:
        return {a.name: a.data for a in make_reader(f).iter_attachments()}


def read_metadata(path: str | Path) -> dict[str, dict[str, str]]:
    """Metadata name -> values (the latest record for a name written more than once)."""
    with _open(Path(path)) as f:
        return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}


def recorded_map(path: str | Path) -> messages.MapReply | None:
    """The first map reply kept in the recording, if any."""
    for sample in iter_samples(path):
        if sample.key.endswith("/authority/map") and sample.kind == "put":
            try:
                return messages.MAP.decode(sample.payload)
            except MessageError as exc:
                log.warning("recorded map does not decode: %s", exc)
    return None
