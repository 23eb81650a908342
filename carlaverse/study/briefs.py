"""The runner's side of the briefs: each participant's current brief, put every half second
on `study/<participant>/brief` under the study's name, so an agent that starts, restarts or
reconnects late hears the trial it should be in (messages.TrialBrief)."""

from __future__ import annotations

import logging
import threading

import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys

log = logging.getLogger(__name__)

REPEAT_S = 0.5  # [s] between puts of the same brief


class Briefer:
    """Holds and repeats one brief per participant; `set` from any thread."""

    def __init__(self, session: zenoh.Session, study: str, participants: list[str]) -> None:
        keys = Keys(study)
        self._pubs = {
            pid: session.declare_publisher(
                keys.study(pid, "brief"), reliability=zenoh.Reliability.RELIABLE
            )
            for pid in participants
        }
        self._briefs = {
            pid: m.TrialBrief(schema=m.SCHEMA_VERSION, study=study, participant=pid)
            for pid in participants
        }
        self._lock = threading.Lock()
        self._changed = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="study-briefs", daemon=True)

    def start(self) -> Briefer:
        self._thread.start()
        return self

    def set(self, brief: m.TrialBrief) -> None:
        with self._lock:
            self._briefs[brief.participant] = brief
        self._changed.set()  # said at once, not at the next repeat

    def idle(self) -> None:
        """No trial for anyone: every agent stops its node."""
        with self._lock:
            for pid, brief in self._briefs.items():
                self._briefs[pid] = m.TrialBrief(
                    schema=m.SCHEMA_VERSION, study=brief.study, participant=pid
                )
        self._changed.set()

    def close(self) -> None:
        self.idle()
        self._stop.set()
        self._changed.set()
        self._thread.join(timeout=3)
        for pub in self._pubs.values():
            pub.undeclare()

    def _run(self) -> None:
        while not self._stop.is_set():
            self._put_all()
            self._changed.wait(REPEAT_S)
            self._changed.clear()
        self._put_all()  # the last word: idle

    def _put_all(self) -> None:
        with self._lock:
            briefs = list(self._briefs.items())
        for pid, brief in briefs:
            try:
                self._pubs[pid].put(m.TRIAL_BRIEF.encode(brief))
            except zenoh.ZError as exc:  # a closing session: the next put tries again
                log.debug("brief for %s not put: %s", pid, exc)
