"""What a recording keeps besides the samples: configs, scenario, roster, provenance.

The paper archives the YAML with the logs; here every joined node's effective config and the
scenario are fetched from the authority (`authority/configs`, `authority/scenario`) and stored
as MCAP attachments byte-for-byte, at start and again after every spawn. The map and a world
snapshot are stored as messages on their `authority/<query>` channels, so a recording can be
viewed and replayed without the authority that produced it.

The archive never writes the file itself: it hands `ArchiveItem`s to the writer thread.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import logging
import platform
import socket
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any, Literal

import zenoh

from carlaverse import __version__, messages
from carlaverse.keys import Keys
from carlaverse.recording.encoding import UNDECODABLE
from carlaverse.zenoh_replies import reply_reason

log = logging.getLogger(__name__)

SESSION_METADATA = "carlaverse.session"
ROSTER_METADATA = "carlaverse.roster"
HOSTNAMES_METADATA = "carlaverse.hostnames"
CONFIG_ATTACHMENT = "config/{node_id}.yaml"
SCENARIO_ATTACHMENT = "scenario.yaml"
YAML_MEDIA_TYPE = "application/yaml"
# Queried once at start and stored as messages; configs are re-queried after each spawn.
STARTUP_QUERIES = ("scenario", "map", "snapshot", "configs")
RETRY_S = 1.0  # [s] between attempts while the authority has not answered a start-up query
MAX_NODES = 4096  # roster entries kept: bounded, whatever a forged reply lists


@dataclass(frozen=True, slots=True)
class ArchiveItem:
    """One thing for the writer thread to put in the file."""

    kind: Literal["attachment", "metadata", "message"]
    name: str  # attachment name, metadata name, or the key of a message
    time_ns: int = 0  # [ns since the epoch]
    data: bytes = b""
    media_type: str = ""
    values: Mapping[str, str] = field(default_factory=dict)


def _version(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def session_metadata(session: str, start_ns: int) -> dict[str, str]:
    """Provenance of a recording; MCAP metadata values are strings."""
    start = datetime.fromtimestamp(start_ns / 1e9, tz=UTC)
    return {
        "session": session,
        "start_time_ns": str(start_ns),
        "start_time_utc": start.isoformat(),
        "recorder_hostname": socket.gethostname(),
        "carlaverse_version": __version__,
        "message_schema_version": str(messages.SCHEMA_VERSION),
        "zenoh_version": _version("eclipse-zenoh"),
        "msgspec_version": _version("msgspec"),
        "mcap_version": _version("mcap"),
        "python_version": platform.python_version(),
    }


class Archive:
    """Fetches configs, scenario, map and snapshot from the authority, on demand."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        emit: Callable[[ArchiveItem], None],
        wall_ns: Callable[[], int],
        query_timeout_s: float = 2.0,
    ) -> None:
        self._session = session
        self._keys = keys
        self._emit = emit
        self._wall_ns = wall_ns
        self._timeout_s = query_timeout_s
        self._wake = threading.Event()
        self._attached: dict[str, bytes] = {}  # attachment name -> digest of what was stored
        self._roster: dict[str, dict[str, Any]] = {}
        self._hostnames: dict[str, str] = {"recorder": socket.gethostname()}
        self._last_roster: tuple[dict[str, str], dict[str, str]] | None = None
        self.errors = 0
        self._last_error: dict[str, str] = {}  # query name -> last error logged

    def request_refresh(self) -> None:
        """Ask for the configs again (a node spawned); safe from any thread."""
        self._wake.set()

    def run(self, stop: threading.Event) -> None:
        """Archiver thread body: start-up queries (retried until the authority answers),
        then the configs and a snapshot again after every spawn."""
        self._emit(ArchiveItem("metadata", SESSION_METADATA, values=self._session_values()))
        pending = list(STARTUP_QUERIES)
        while not stop.is_set():
            for name in list(pending):
                if stop.is_set():
                    return
                if self._fetch(name):
                    pending.remove(name)
            woken = self._wake.wait(timeout=RETRY_S if pending else None)
            self._wake.clear()
            if woken and not stop.is_set():
                self._fetch("configs")
                self._fetch("snapshot")

    def stop(self) -> None:
        """Wake the thread so it notices its stop event."""
        self._wake.set()

    def _session_values(self) -> dict[str, str]:
        return session_metadata(self._keys.session, self._wall_ns())

    # ------------------------------------------------------------------ queries

    def _fetch(self, name: str) -> bool:
        """Query, archive the answers; False if nobody answered."""
        answers = self._query(name)
        for key, payload in answers:
            self._emit(ArchiveItem("message", key, self._wall_ns(), payload))
            self._absorb(name, payload)
        return bool(answers)

    def _query(self, name: str) -> list[tuple[str, bytes]]:
        selector = self._keys.authority(name)
        out: list[tuple[str, bytes]] = []
        try:
            for reply in self._session.get(selector, timeout=self._timeout_s):
                if reply.ok is None:
                    self._count_error(name, f"{selector}: {reply_reason(reply.err)}")
                    continue
                out.append((str(reply.ok.key_expr), reply.ok.payload.to_bytes()))
        except zenoh.ZError as exc:
            self._count_error(name, f"query {selector} failed: {exc}")
        if not out:
            log.debug("no answer to %s (no authority yet?); asking again", selector)
        return out

    def _count_error(self, query: str, message: str) -> None:
        """Count every error; log one only when it differs from the last for that query.

        Start-up queries are retried every second, and an authority without a scenario
        refuses `map` each time for the same reason: that is one fact, logged once.
        """
        self.errors += 1
        if self._last_error.get(query) != message:
            self._last_error[query] = message
            log.warning("%s", message)

    def _absorb(self, name: str, payload: bytes) -> None:
        codec = messages.CHANNEL_CODECS[("authority", name)]
        try:
            reply = codec.decode(payload)
        except UNDECODABLE as exc:
            self._count_error(name, f"authority/{name} reply did not decode: {exc}"[:500])
            return
        if isinstance(reply, messages.ConfigsReply):
            self._absorb_configs(reply)
        elif isinstance(reply, messages.ScenarioReply):
            self._attach(SCENARIO_ATTACHMENT, reply.yaml.encode())
        elif isinstance(reply, messages.Snapshot):
            self._absorb_snapshot(reply)

    def _absorb_configs(self, reply: messages.ConfigsReply) -> None:
        for node_id, config_yaml in sorted(reply.nodes.items()):
            entry = self._entry(node_id)
            if entry is not None:
                self._attach(CONFIG_ATTACHMENT.format(node_id=node_id), config_yaml.encode())
                entry["config"] = True
        if reply.scenario_yaml:
            self._attach(SCENARIO_ATTACHMENT, reply.scenario_yaml.encode())
        # Node hostnames arrive only if the authority reports them (a later ConfigsReply field).
        hostnames = getattr(reply, "hostnames", None) or {}
        self._hostnames.update((n, h) for n, h in hostnames.items() if n in self._roster)
        self._emit_roster()

    def _absorb_snapshot(self, snapshot: messages.Snapshot) -> None:
        for ego in snapshot.egos:
            entry = self._entry(ego.node_id)
            if entry is not None:
                entry.update(kind=ego.kind, actor_kind=ego.actor_kind, site=ego.site)
        self._emit_roster()

    def _entry(self, node_id: str) -> dict[str, Any] | None:
        """The roster entry of `node_id`; None past MAX_NODES (forged replies cannot grow it)."""
        entry = self._roster.get(node_id)
        if entry is None and len(self._roster) < MAX_NODES:
            entry = self._roster[node_id] = {}
        return entry

    def _attach(self, name: str, data: bytes) -> None:
        """Attach a file unless the same bytes are already in the recording under that name."""
        digest = hashlib.blake2b(data, digest_size=16).digest()  # not the bytes: memory
        if self._attached.get(name) == digest:
            return
        self._attached[name] = digest
        self._emit(ArchiveItem("attachment", name, self._wall_ns(), data, YAML_MEDIA_TYPE))

    def _emit_roster(self) -> None:
        roster = {node: json.dumps(info, sort_keys=True) for node, info in self._roster.items()}
        if self._last_roster == (roster, self._hostnames):
            return
        self._last_roster = (roster, dict(self._hostnames))
        self._emit(ArchiveItem("metadata", ROSTER_METADATA, values=roster))
        self._emit(ArchiveItem("metadata", HOSTNAMES_METADATA, values=dict(self._hostnames)))
