"""Record every key of a session into an MCAP file (docs/architecture.md §11).

Threads and why:
- Zenoh callbacks only stamp the receive time and push the sample into a queue bounded in
  samples and in payload bytes; they never touch the file, so a slow disk cannot stall the
  fabric, and a storm of large payloads cannot grow memory. A full queue drops the sample
  and counts it (`RecorderStats.dropped`).
- One writer thread owns the `McapSink`: it drains the queue, encodes, writes, and closes
  chunks on time so a crash loses at most `flush_interval_s`. No sample can stop it: the
  sink writes what does not decode raw and rejects (counts) what it cannot write. If the
  thread stops anyway (a full disk, a bug), `stats().failure` says why, so the CLI exits
  non-zero instead of reporting a count that no longer moves.
- Which new keys become channels is the sink's admission's call (`recording/admission.py`):
  present senders first, each within its share, so forged keys cannot crowd out a real
  node's. Presence is the liveliness tokens, followed here in the order they were received.
- One archiver thread queries the authority (configs, scenario, map, snapshot) at start and
  again whenever `world/events` announces a spawn, and hands the replies to the writer as
  attachments, metadata and messages on the `authority/<query>` channels.
"""

from __future__ import annotations

import itertools
import logging
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zenoh

from carlaverse import messages
from carlaverse.keys import Keys, KeySpaceError, parse_cached
from carlaverse.recording.archive import Archive, ArchiveItem
from carlaverse.recording.encoding import UNDECODABLE
from carlaverse.recording.sink import McapSink

log = logging.getLogger(__name__)

DEFAULT_QUEUE_SIZE = 200_000  # samples; ~20 s of a busy session (10k msg/s)
DEFAULT_QUEUE_BYTES = 256 * 1024 * 1024  # [B] of queued payloads, whatever their count


@dataclass(frozen=True, slots=True)
class RecorderStats:
    received: int  # samples delivered by Zenoh
    written: int  # messages in the file (includes archived query replies)
    dropped: int  # samples lost because the writer fell behind
    bytes_in: int  # [B] payload bytes written
    channels: int
    attachments: int
    decode_errors: int  # payloads of a known type that did not decode (recorded raw)
    rejected: int  # samples the sink could not write (a key refused, a bad receive time)
    queued: int
    failure: str  # why the writer stopped early, "" while healthy
    # `rejected` by reason: bad_time, and the admission's sender_full, present_full,
    # strangers_full (recording/admission.py)
    rejected_by: dict[str, int] = field(default_factory=dict)


class ByteBudget:
    """Payload bytes the queue may hold; taken by Zenoh threads, given back by the writer."""

    def __init__(self, limit: int) -> None:
        self._limit = limit
        self._used = 0
        self._lock = threading.Lock()  # held for one addition: never blocks a callback long

    def take(self, size: int) -> bool:
        with self._lock:
            if self._used + size > self._limit:
                return False
            self._used += size
            return True

    def give_back(self, size: int) -> None:
        with self._lock:
            self._used -= size


def _channel_metadata(sample: zenoh.Sample) -> dict[str, str]:
    """Delivery settings of the first sample of a key, so replay can publish alike."""
    return {
        "zenoh.encoding": str(sample.encoding),
        "zenoh.congestion_control": str(sample.congestion_control).rsplit(".", 1)[-1],
        "zenoh.priority": str(sample.priority).rsplit(".", 1)[-1],
        "zenoh.express": "true" if sample.express else "false",
    }


class Recorder:
    """Subscribes to `Keys(session).everything` and writes what arrives to a sink."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        sink: McapSink,
        *,
        queue_size: int = DEFAULT_QUEUE_SIZE,
        queue_bytes: int = DEFAULT_QUEUE_BYTES,
        wall_ns: Callable[[], int] = time.time_ns,
        query_timeout_s: float = 2.0,
        archive: bool = True,
    ) -> None:
        self._session = session
        self._keys = keys
        self._sink = sink
        self._wall_ns = wall_ns
        # (receive time [ns], sample, whether it is a liveliness token's)
        self._queue: queue.Queue[tuple[int, Any, bool]] = queue.Queue(maxsize=queue_size)
        self._queue_bytes = ByteBudget(queue_bytes)
        self._control: deque[ArchiveItem] = deque()
        self._archive = Archive(session, keys, self._control.append, wall_ns, query_timeout_s)
        self._archive_enabled = archive
        self._received = itertools.count(1)
        self._dropped = itertools.count(1)
        self._n_received = 0
        self._n_dropped = 0
        self._max_queued = 0  # deepest backlog seen: how close the writer came to dropping
        self._events_key = keys.world("events")
        self._stop = threading.Event()
        self._failure = ""
        self._threads: list[threading.Thread] = []
        self._subscribers: list[Any] = []

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        self._threads.append(threading.Thread(target=self._write_loop, name="mcap-writer"))
        if self._archive_enabled:
            self._threads.append(
                threading.Thread(target=self._archive.run, args=(self._stop,), name="mcap-archive")
            )
        for thread in self._threads:
            thread.daemon = True
            thread.start()
        # Tokens first: the present nodes' tokens (history) then tend to arrive before their
        # data, whose new keys are then charged to a present sender, not to the strangers.
        self._subscribers.append(
            self._session.liveliness().declare_subscriber(
                self._keys.all_nodes, self._on_token, history=True
            )
        )
        self._subscribers.append(
            self._session.declare_subscriber(self._keys.everything, self._on_sample)
        )

    def stop(self) -> RecorderStats:
        """Stop listening, write what is queued, close the file with its indexes."""
        for sub in self._subscribers:
            sub.undeclare()
        self._subscribers.clear()
        self._stop.set()
        self._archive.stop()
        for thread in self._threads:
            thread.join()
        self._threads.clear()
        stats = self.stats()
        try:
            self._drain_control()  # whatever the archive handed over after the writer ended
            self._sink.metadata("carlaverse.summary", self._summary(stats))
            self._sink.close()
        except Exception as exc:  # an unfinished file must be reported
            self._failure = self._failure or f"closing {self._sink.path}: {exc}"
        return self.stats()

    def stats(self) -> RecorderStats:
        s = self._sink.stats
        return RecorderStats(
            received=self._n_received,
            written=s.messages,
            dropped=self._n_dropped,
            bytes_in=s.bytes_in,
            channels=s.channels,
            attachments=s.attachments,
            decode_errors=s.decode_errors,
            rejected=s.rejected,
            queued=self._queue.qsize(),
            failure=self._failure or self._writer_gone(),
            rejected_by=self._rejected_by(),
        )

    def _rejected_by(self) -> dict[str, int]:
        reasons = {"bad_time": self._sink.stats.bad_times, **self._sink.admission.refused}
        return {reason: n for reason, n in sorted(reasons.items()) if n}

    def _writer_gone(self) -> str:
        """A reason if the writer thread has ended while the recorder still runs."""
        writer = self._threads[0] if self._threads else None
        if writer is None or writer.is_alive() or self._stop.is_set():
            return ""
        return "the writer thread stopped; nothing received since is in the file"

    # ------------------------------------------------------------------ Zenoh side

    def _on_sample(self, sample: zenoh.Sample) -> None:
        """Runs on a Zenoh thread: stamp and hand over, nothing else."""
        self._hand_over(sample, token=False)

    def _on_token(self, sample: zenoh.Sample) -> None:
        """A liveliness token appeared or went (a put on `node/<id>` is no token)."""
        self._hand_over(sample, token=True)

    def _hand_over(self, sample: zenoh.Sample, token: bool) -> None:
        size = len(sample.payload)
        if not self._queue_bytes.take(size):
            self._n_dropped = next(self._dropped)
            return
        try:
            self._queue.put_nowait((self._wall_ns(), sample, token))
            self._n_received = next(self._received)
        except queue.Full:
            self._queue_bytes.give_back(size)
            self._n_dropped = next(self._dropped)

    # ------------------------------------------------------------------ writer thread

    def _write_loop(self) -> None:
        try:
            while not (self._stop.is_set() and self._queue.empty() and not self._control):
                self._drain_once()
            self._drain_control()
        except Exception as exc:  # whatever stops the writer must be reported
            self._failure = f"writing {self._sink.path} failed: {type(exc).__name__}: {exc}"
            log.error("recorder stopped: %s", self._failure, exc_info=not isinstance(exc, OSError))

    def _drain_once(self, batch_max: int = 4096) -> None:
        """Write up to `batch_max` queued samples, then archive items and a due chunk flush."""
        try:
            self._write_sample(*self._queue.get(timeout=0.05))
        except queue.Empty:
            pass
        self._max_queued = max(self._max_queued, self._queue.qsize())
        for _ in range(batch_max - 1):
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            self._write_sample(*item)
        self._drain_control()
        self._sink.maybe_flush()

    def _write_sample(self, recv_ns: int, sample: zenoh.Sample, token: bool) -> None:
        key = str(sample.key_expr)
        payload = sample.payload.to_bytes()
        self._queue_bytes.give_back(len(payload))
        kind = "delete" if sample.kind == zenoh.SampleKind.DELETE else "put"
        if token and kind == "put":
            self._presence(key, present=True)  # first: the token's own key is the node's
        metadata = None if self._sink.has_channel(key) else _channel_metadata(sample)
        written = self._sink.write(key, payload, recv_ns, kind, metadata)
        if token and kind == "delete":
            self._presence(key, present=False)
        if written and key == self._events_key and kind == "put":
            self._watch_event(payload)

    def _presence(self, key: str, present: bool) -> None:
        try:
            node_id = parse_cached(key).node_id
        except KeySpaceError:
            return  # a token of no valid id names no sender
        if present:
            self._sink.admission.present(node_id)
        else:
            self._sink.admission.absent(node_id)

    def _watch_event(self, payload: bytes) -> None:
        try:
            event = messages.WORLD_EVENT.decode(payload)
        except UNDECODABLE:
            return  # already recorded raw with its error by the sink
        if isinstance(event, messages.Spawned):
            self._archive.request_refresh()

    def _drain_control(self) -> None:
        while self._control:
            item = self._control.popleft()
            if item.kind == "attachment":
                self._sink.attach(item.name, item.media_type, item.data, item.time_ns)
            elif item.kind == "metadata":
                self._sink.metadata(item.name, item.values)
            else:
                self._sink.write(item.name, item.data, item.time_ns)

    def _summary(self, stats: RecorderStats) -> dict[str, str]:
        return {
            "end_time_ns": str(self._wall_ns()),
            "messages": str(stats.written),
            "received": str(stats.received),
            "dropped": str(stats.dropped),
            "max_queued": str(self._max_queued),
            "decode_errors": str(stats.decode_errors),
            "rejected": str(stats.rejected),
            **{f"rejected_{reason}": str(n) for reason, n in stats.rejected_by.items()},
            "archive_errors": str(self._archive.errors),
        }
