"""Write ground truth as an ASAM OSI multi-channel trace file (MCAP), and export a recording.

The OSI trace file specification ("OSI trace file formats", multi channel) asks for: an
indexed MCAP file with every message in a chunk (zstd, lz4 or uncompressed); one metadata
record `net.asam.osi.trace` with `version` (the OSI release the file conforms to),
`min/max_osi_version` and `min/max_protobuf_version`; a schema per top-level message named
with its package (`osi3.GroundTruth`), encoding `protobuf`, holding the FileDescriptorSet of
its file and every file it imports; channels with message encoding `protobuf` and the
metadata `net.asam.osi.trace.channel.osi_version` and `...protobuf_version`; and each
message's log time its OSI timestamp. An OSI trace holds OSI messages only, so the export is
a file of its own beside the recording, not a channel in it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import google.protobuf
from google.protobuf.descriptor import FileDescriptor
from google.protobuf.descriptor_pb2 import FileDescriptorSet
from mcap.writer import CompressionType, Writer
from osi3 import osi_groundtruth_pb2
from osi3.osi_version_pb2 import InterfaceVersion

from carlaverse.recording.osi_ground_truth import (
    GroundTruth,
    Options,
    ground_truths,
    interface_version,
)
from carlaverse.recording.recorded_world import read_world
from carlaverse.recording.sink import RecordingError

TRACE_METADATA = "net.asam.osi.trace"
CHANNEL_OSI_VERSION = "net.asam.osi.trace.channel.osi_version"
CHANNEL_PROTOBUF_VERSION = "net.asam.osi.trace.channel.protobuf_version"
CHANNEL_DESCRIPTION = "net.asam.osi.trace.channel.description"
TOPIC = "ground_truth"
SCHEMA_NAME = "osi3.GroundTruth"


def osi_version(v: InterfaceVersion) -> str:
    return f"{v.version_major}.{v.version_minor}.{v.version_patch}"


def sibling_path(recording: Path) -> Path:
    """NAME.osi.mcap beside NAME.mcap: where `record --osi` puts the ground truth."""
    stem = recording.name.removesuffix(".mcap")
    return recording.with_name(f"{stem}.osi.mcap")


def descriptor_set(file: FileDescriptor) -> bytes:
    """The FileDescriptorSet of `file` and everything it imports, dependencies first."""
    out = FileDescriptorSet()
    seen: set[str] = set()

    def add(fd: FileDescriptor) -> None:
        if fd.name not in seen:
            seen.add(fd.name)
            for dependency in fd.dependencies:
                add(dependency)
            fd.CopyToProto(out.file.add())

    add(file)
    return out.SerializeToString()


@dataclass(frozen=True, slots=True)
class TraceReport:
    frames: int
    moving_objects: int  # distinct actors written
    lanes: int
    traffic_lights: int  # bulbs in the last frame


def write_trace(
    path: Path, frames: Iterable[GroundTruth], description: str, source: str = ""
) -> TraceReport:
    """Write `frames` (in time order) to an OSI MCAP trace at `path`."""
    try:
        with path.open("wb") as f:
            return _write(Writer(f, compression=CompressionType.ZSTD), frames, description, source)
    except OSError as exc:
        raise RecordingError(f"cannot write OSI trace {path}: {exc.strerror}") from exc


def _write(
    writer: Writer, frames: Iterable[GroundTruth], description: str, source: str
) -> TraceReport:
    writer.start(profile="", library="carlaverse-osi")
    protobuf = google.protobuf.__version__
    schema = writer.register_schema(
        SCHEMA_NAME, "protobuf", descriptor_set(osi_groundtruth_pb2.DESCRIPTOR)
    )
    channel: int | None = None
    count, lanes, lights = 0, 0, 0
    actors: set[int] = set()
    for gt in frames:
        version = osi_version(gt.version)
        if channel is None:
            meta = {CHANNEL_OSI_VERSION: version, CHANNEL_PROTOBUF_VERSION: protobuf,
                    CHANNEL_DESCRIPTION: description}  # fmt: skip
            channel = writer.register_channel(TOPIC, "protobuf", schema, meta)
        ns = gt.timestamp.seconds * 10**9 + gt.timestamp.nanos
        writer.add_message(channel, ns, gt.SerializeToString(), ns, count & 0xFFFFFFFF)
        count += 1
        actors.update(o.id.value for o in gt.moving_object)
        lanes = max(lanes, len(gt.lane))
        lights = len(gt.traffic_light)
    version = osi_version(interface_version())
    writer.add_metadata(TRACE_METADATA, {
        "version": version, "min_osi_version": version, "max_osi_version": version,
        "min_protobuf_version": protobuf, "max_protobuf_version": protobuf,
        "creation_time": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "description": description, "data_sources": source,
    })  # fmt: skip
    writer.finish()
    return TraceReport(count, len(actors), lanes, lights)


def export(recording: Path, out: Path, options: Options | None = None) -> TraceReport:
    """The recording's ground truth, one frame per tick, as an OSI trace at `out`."""
    options = options or Options()
    world = read_world(recording)
    if not world.samples:
        raise RecordingError(f"{recording}: no poses or NPC batches to export")
    if options.host is not None and options.host not in world.humans:
        egos = ", ".join(sorted(world.humans)) or "none"
        raise RecordingError(f"--host {options.host}: no such ego in {recording} (egos: {egos})")
    description = f"carlaverse ground truth at {options.rate_hz:g} Hz"
    return write_trace(
        out, ground_truths(world, options), description, f"carlaverse recording {recording.name}"
    )
