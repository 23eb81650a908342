"""A participant's study agent: hears the runner's briefs and runs the participant's node.

It runs on the participant's machine (`carlaverse study agent`), or beside the runner when the
study is launched locally. It listens on `study/<participant>/brief` under the study's name;
when a brief names a trial (an attempt) it is not running, it stops the node it runs and
starts `carlaverse join <kind>` in the trial's session with the brief's node config; when the
brief names none, or no brief has come for `STALE_S` (the runner went away), it stops the node.
The Zenoh callback only keeps the newest brief; the agent's own loop does the rest.
"""

from __future__ import annotations

import logging
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.procs import Child, stop_children
from carlaverse.procs import start as start_child

log = logging.getLogger(__name__)

STALE_S = 3.0  # [s] without a brief: the runner is gone, the node is stopped
POLL_S = 0.1  # [s] how often the loop looks at the newest brief
HMI_SAYS = "HMI at "  # how the node's line naming its HMI's URL goes on
NODE_STOP_GRACE_S = 5.0  # [s] from SIGINT (the node leaves the session) to SIGTERM


class StudyAgent:
    """Runs one participant's node as the briefs say; `run` until `stop` is set."""

    def __init__(
        self,
        session: zenoh.Session,
        study: str,
        participant: str,
        connect: str,
        say: Callable[[str], None],
        monotonic: Callable[[], float] = time.monotonic,
        hmi_port: int | None = None,
    ) -> None:
        self.participant = participant
        self.hmi_port = hmi_port  # the node serves its HMI (questionnaires) here; None: none
        self.connect = connect
        self.say = say
        self.monotonic = monotonic
        self.dropped = 0  # briefs that did not decode, or were not for us
        self.nodes_started = 0
        self._study = study
        self._newest: tuple[m.TrialBrief, float] | None = None
        self._node: Child | None = None
        self._running: tuple[str, int] | None = None  # (trial, attempt) of the node
        self._tmp = tempfile.TemporaryDirectory(prefix=f"carlaverse-agent-{participant}-")
        key = Keys(study).study(participant, "brief")
        self._sub = session.declare_subscriber(key, self._on_brief)

    def _on_brief(self, sample: zenoh.Sample) -> None:
        try:
            brief = m.TRIAL_BRIEF.decode(sample.payload.to_bytes())
        except m.MessageError as exc:
            self.dropped += 1
            log.debug("undecodable brief dropped: %s", exc)
            return
        if brief.participant != self.participant or brief.study != self._study:
            self.dropped += 1
            return
        self._newest = (brief, self.monotonic())  # one reference swap: no lock needed

    def run(self, stop: threading.Event) -> None:
        try:
            while not stop.wait(POLL_S):
                self.step()
        finally:
            self._stop_node("the agent stops")
            self._sub.undeclare()
            self._tmp.cleanup()

    def step(self) -> None:
        """Bring the node in line with the newest brief."""
        wanted = self._wanted()
        if wanted is not None and (wanted.trial, wanted.attempt) == self._running:
            if self._node is not None and not self._node.running:
                self._node_ended()
            return
        if self._running is not None:
            self._stop_node("the trial ended" if wanted is None else "a new trial begins")
        if wanted is not None:
            self._start_node(wanted)

    def _wanted(self) -> m.TrialBrief | None:
        newest = self._newest
        if newest is None or self.monotonic() - newest[1] > STALE_S:
            return None
        return newest[0] if newest[0].active else None

    def _start_node(self, brief: m.TrialBrief) -> None:
        argv = ["join", brief.kind, "--id", self.participant, "--session", brief.session,
                "--connect", self.connect, "--mode", "client", "--json"]  # fmt: skip
        if brief.node_config_yaml:
            config = Path(self._tmp.name) / f"{brief.trial}-{brief.attempt}.yaml"
            config.write_text(brief.node_config_yaml)
            argv += ["--config", str(config)]
        if brief.backend:
            argv += ["--backend", brief.backend]
        if self.hmi_port is not None:
            argv += ["--hmi", str(self.hmi_port)]
        self._node = start_child(argv, name=f"node {self.participant}", role="node",
                                 on_stderr=self._relay_hmi)  # fmt: skip
        self._running = (brief.trial, brief.attempt)
        self.nodes_started += 1
        self.say(f"{self.participant}: joining trial {brief.trial} (session {brief.session})")

    def _relay_hmi(self, line: str) -> None:
        """Where the node's HMI is (its port may be any free one): the participant's page.
        Only that line: the pairing URL's token (an HMI beyond loopback) stays on the node."""
        if HMI_SAYS in line:
            self.say(f"{self.participant}: {line[line.index(HMI_SAYS) :].strip()}")

    def _node_ended(self) -> None:
        assert self._node is not None
        self.say(f"{self.participant}: the node ended ({self._node.exit_code}): "
                 f"{self._node.last_error()}")  # fmt: skip
        self._node = None

    def _stop_node(self, why: str) -> None:
        if self._node is not None:
            stop_children([self._node], NODE_STOP_GRACE_S)
            self.say(f"{self.participant}: node stopped ({why})")
        self._node = None
        self._running = None
