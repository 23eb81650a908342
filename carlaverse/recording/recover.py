"""Rewrite an unfinished recording (a killed recorder) into a clean, indexed MCAP file.

An unfinished file has no summary, so `mcap`'s indexed reader refuses it; its stream reader
still reads every complete record. `recover()` copies schemas, channels, messages,
attachments and metadata verbatim up to the first incomplete or corrupt record, and writes
a new file with chunk and message indexes. Message bytes are not re-encoded, except that
what could hold a login (`authority/configs` messages, YAML attachments, metadata) passes
the redaction rule on the way: a file from an older recorder comes out clean.
"""

from __future__ import annotations

import logging
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.records import Attachment, Channel, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import Writer
from zstandard import ZstdError

from carlaverse.recording.scrub import (
    holds_configs,
    scrub_attachment,
    scrub_envelope,
    scrub_metadata,
)
from carlaverse.recording.sink import _COMPRESSION, PROFILE, Compression, RecordingError

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class RecoverReport:
    messages: int
    channels: int
    attachments: int
    metadata: int
    complete: bool  # the input had its footer: nothing was lost
    stopped_by: str  # what ended the copy before the footer, "" if complete


class _Copier:
    """Feeds stream records into a Writer, renumbering schemas and channels."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.schemas: dict[int, int] = {0: 0}
        self.channels: dict[int, int] = {}
        self.configs_channels: dict[int, str] = {}  # new id -> key, for those holding configs
        self.counts = {"messages": 0, "attachments": 0, "metadata": 0}

    def add(self, record: Any) -> None:
        if isinstance(record, Schema) and record.id not in self.schemas:
            self.schemas[record.id] = self.writer.register_schema(
                record.name, record.encoding, record.data
            )
        elif isinstance(record, Channel) and record.id not in self.channels:
            self.channels[record.id] = self.writer.register_channel(
                record.topic, record.message_encoding, self.schemas.get(record.schema_id, 0),
                dict(record.metadata),
            )  # fmt: skip
            if holds_configs(record.topic):
                self.configs_channels[self.channels[record.id]] = record.topic
        elif isinstance(record, Message):
            self._message(record)
        elif isinstance(record, Attachment):
            data = scrub_attachment(record.name, record.media_type, record.data)
            self.writer.add_attachment(
                record.create_time, record.log_time, record.name, record.media_type, data
            )
            self.counts["attachments"] += 1
        elif isinstance(record, Metadata):
            self.writer.add_metadata(record.name, scrub_metadata(record.metadata))
            self.counts["metadata"] += 1

    def _message(self, record: Message) -> None:
        channel = self.channels.get(record.channel_id)
        if channel is None:
            raise RecordingError(f"message on channel {record.channel_id} before its definition")
        data = record.data
        if channel in self.configs_channels:
            data = scrub_envelope(self.configs_channels[channel], data)
        self.writer.add_message(
            channel, record.log_time, data, record.publish_time, record.sequence
        )
        self.counts["messages"] += 1


def recover(src: str | Path, dst: str | Path, compression: Compression = "zstd") -> RecoverReport:
    """Copy every complete record of `src` into a finished, indexed `dst`."""
    src, dst = Path(src), Path(dst)
    if src.resolve() == dst.resolve():
        raise RecordingError(f"--recover writes a new file: choose an output other than {src}")
    tmp = dst.with_name(dst.name + ".partial")
    try:
        with src.open("rb") as fin, tmp.open("wb") as fout:
            writer = Writer(fout, compression=_COMPRESSION[compression])
            writer.start(profile=PROFILE, library="carlaverse-recover")
            copier = _Copier(writer)
            complete, stopped_by = _copy(StreamReader(fin, validate_crcs=True), copier)
            writer.finish()
        os.replace(tmp, dst)
    except OSError as exc:
        raise RecordingError(f"cannot recover {src} into {dst}: {exc}") from exc
    return RecoverReport(
        copier.counts["messages"], len(copier.channels), copier.counts["attachments"],
        copier.counts["metadata"], complete, stopped_by,
    )  # fmt: skip


def _copy(reader: StreamReader, copier: _Copier) -> tuple[bool, str]:
    """Copy until the footer (complete) or the first unreadable record (truncated)."""
    records = reader.records
    while True:
        try:
            record = next(records)
        except StopIteration:
            return True, ""
        except (McapError, ValueError, struct.error, ZstdError) as exc:
            # CRC mismatches are ValueErrors; a torn record ends in EndOfFile (McapError)
            reason = f"{type(exc).__name__}: {exc}".rstrip(": ")
            log.info("recovery stopped at an incomplete record (%s)", reason)
            return False, reason
        if isinstance(record, Footer):
            return True, ""
        copier.add(record)
