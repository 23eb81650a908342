"""What one launcher runs on this machine: a router, an authority, nodes, a demo, one session.

Every child connects to the lab's router endpoint (loopback, a free port by default) and joins
the lab's session; the session is watched as an observer once a router runs. A node's config
and the authority's scenario are files inside the config dir or shipped ones (`launcher.files`):
a process started from the page reads nothing else. A node may serve its web HMI; one beyond
loopback prints a pairing URL, which the lab keeps in memory for the page's QR code
(`launcher.hmi_pairing`). The demo is the
one `carlaverse demo` runs — its authority and node arguments come from `demo_plan` — but each
of its processes is a child here, listed, logged and stoppable on its own.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from carlaverse.config import ConfigError
from carlaverse.demo_plan import HEADLESS_KINDS, DemoChoices, authority_argv, check_nodes, node_plan
from carlaverse.keys import check_token
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.hmi_pairing import LOOPBACK, PairingWatch, hmi_argv
from carlaverse.launcher.presence import PresenceRow, SessionWatch
from carlaverse.launcher.processes import LaunchError, Supervisor
from carlaverse.node_runtime import UnknownNodeKind, load_node_kind, node_kinds
from carlaverse.procs import Child


class Lab:
    """The launcher's children and the session they share; `close()` stops them all."""

    def __init__(
        self, session: str, endpoint: str, files: ConfigDir, supervisor: Supervisor | None = None
    ) -> None:
        check_token(session, "session name")
        self.session = session
        self.endpoint = endpoint
        self.files = files
        self.supervisor = supervisor or Supervisor()
        self.watch: SessionWatch | None = None
        # node name → the child that serves an HMI and the watch for its pairing URL
        self._pairings: dict[str, tuple[Child, PairingWatch]] = {}
        self._scratch = tempfile.TemporaryDirectory(prefix="carlaverse-launcher-")

    @property
    def node_kinds(self) -> list[str]:
        return sorted(node_kinds())

    def start_router(self) -> Child:
        child = self.supervisor.start("router", "router", ["router", "--listen", self.endpoint])
        self._watch()
        return child

    def start_authority(self, scenario: str = "town") -> Child:
        argv = authority_argv(self.session, self._scenario(scenario), self.endpoint)
        return self.supervisor.start("authority", "authority", argv)

    def start_node(
        self,
        kind: str,
        node_id: str,
        config: str = "",
        hmi_port: int | None = None,
        hmi_bind: str = LOOPBACK,
    ) -> Child:
        """`carlaverse join KIND --id NODE_ID`; a kind with devices and no config runs on sim.
        `hmi_port`: it serves its web HMI there, on `hmi_bind` (an IP address)."""
        try:
            kind_cls = load_node_kind(kind)
        except UnknownNodeKind as exc:
            raise LaunchError(str(exc)) from exc
        check_token(node_id, "node id")
        argv = ["join", kind, "--id", node_id, "--session", self.session]
        argv += ["--connect", self.endpoint]
        if config:
            argv += ["--config", str(self._file(config))]
        elif kind not in HEADLESS_KINDS:
            argv += ["--backend", "sim"]
        if hmi_port is None:
            return self.supervisor.start(node_id, "node", argv)
        argv += hmi_argv(hmi_port, hmi_bind)
        if not hasattr(kind_cls, "hmi_bridge"):
            raise LaunchError(f"node kind {kind!r} has no web HMI (drive and bike have one)")
        pairing = PairingWatch(hmi_port)
        child = self.supervisor.start(node_id, "node", argv, on_stderr=pairing.feed)
        self._pairings[node_id] = (child, pairing)
        return child

    def hmi_pairings(self) -> list[tuple[str, str]]:
        """(node, pairing URL) of each running node whose HMI printed one; memory only."""
        found = []
        for name, (child, pairing) in sorted(self._pairings.items()):
            url = pairing.url  # a child of that name started later is another process
            if url is not None and child.running and self.supervisor.get(name) is child:
                found.append((name, url))
        return found

    def start_demo(self, kinds: list[str], duration_s: float, scenario: str = "town") -> list[str]:
        """What `carlaverse demo --nodes KINDS` starts, as children here; the node ids."""
        problem = check_nodes(kinds, [])
        if problem:
            raise LaunchError(problem)
        choices = DemoChoices(self.session, self._scenario(scenario), duration_s)
        if not self._running("router"):
            self.start_router()
        if not self._running("authority"):
            self.start_authority(scenario)
        plan = node_plan(kinds, self.endpoint, choices, Path(self._scratch.name))
        for node_id, argv in plan:
            self.supervisor.start(node_id, "node", argv)
        return [node_id for node_id, _argv in plan]

    def stop(self, name: str) -> None:
        self.supervisor.stop(name)

    def stop_all(self) -> None:
        self.supervisor.stop_all()

    def presence(self) -> list[PresenceRow]:
        if self.watch is None:
            return []
        return [row for row in self.watch.rows() if row.node_id != self.watch.settings.node_id]

    def authority_line(self) -> str:
        """Whether the session's authority runs, in one line for the page."""
        if self.watch is None:
            return f"session {self.session!r} is watched once a router runs here"
        return self.watch.authority_line()

    def close(self) -> None:
        """Stop every child and the watch; nothing the launcher started is left running."""
        self.supervisor.stop_all()
        if self.watch is not None:
            self.watch.close()
            self.watch = None
        self._scratch.cleanup()

    def _file(self, name: str) -> Path:
        """A file a child will read: inside the config dir or shipped, else LaunchError."""
        try:
            return self.files.source(name)
        except ConfigError as exc:
            raise LaunchError(str(exc)) from exc

    def _scenario(self, name: str) -> str:
        return name if name == "none" else str(self._file(name))

    def _running(self, name: str) -> bool:
        child = self.supervisor.get(name)
        return child is not None and child.running

    def _watch(self) -> None:
        if self.watch is None:
            self.watch = SessionWatch(self.endpoint, self.session).start()
