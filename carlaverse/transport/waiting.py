"""Saying what a process waits for: a router that does not answer, an authority that is absent.

A node, recorder or viewer started before its router or authority (or pointed at the wrong
port) must not sit silent. `SessionWait` tells, at any moment, what is missing; `WaitNotice`
turns that into one line per change of state after a short grace period, so a normal start
(the router answers within a second) prints nothing.

    wait = SessionWait(session, settings, keys)
    notice = WaitNotice(wait, say=print_to_stderr)
    while ...:
        notice.poll()          # from the caller's loop, or notice.start() for a thread
    wait.close()
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import zenoh

from carlaverse.keys import AUTHORITY_ID, Keys
from carlaverse.transport.session import FabricSettings, reaches_anyone

# open_session has already given a peer ~0.5 s to connect, and on a LAN the router answers
# within ~100 ms with the authority's liveliness token right after; so half a second more
# keeps a normal start silent while leaving most of the 5 s a user tolerates to a slow
# interpreter start on a loaded machine. (A late token costs a line and its "reached" line.)
GRACE_S = 0.5
POLL_S = 0.1


class SessionWait:
    """What a process attached to `session` is still waiting for (None: nothing)."""

    def __init__(self, session: zenoh.Session, settings: FabricSettings, keys: Keys) -> None:
        self.session = session
        self.settings = settings
        self.keys = keys
        self.authority = threading.Event()
        # Set once a router or peer was reached: a recorder that reached nothing for its
        # whole run recorded nothing because of the network, and says so (exit 3).
        self.reached = threading.Event()
        # history=True: a token declared before we subscribed is delivered at once.
        self._sub: zenoh.Subscriber | None = session.liveliness().declare_subscriber(
            keys.node(AUTHORITY_ID), self._on_authority, history=True
        )

    def _on_authority(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self.authority.set()
        else:
            self.authority.clear()

    def missing(self) -> str | None:
        """One line naming the endpoint and what is missing, or None when all is there."""
        where = ", ".join(self.settings.connect)
        if not self.reaches_anyone():
            if not where:
                return (
                    "waiting for a router or peer: none found (no --connect endpoint given and "
                    "multicast scouting is off; pass --connect tcp/HOST:PORT)"
                )
            return f"waiting for a router at {where}: none answers there (retrying)"
        if not self.authority.is_set():
            session = self.keys.session
            via = f" via {where}" if where else ""
            return (
                f"waiting for the authority of session {session!r}{via}: none is running "
                f"(start `carlaverse authority --session {session}`)"
            )
        return None

    def reaches_anyone(self) -> bool:
        """Whether a router or peer is connected now (and remember that one was)."""
        if reaches_anyone(self.session):
            self.reached.set()
            return True
        return False

    def close(self) -> None:
        if self._sub is not None:
            self._sub.undeclare()
            self._sub = None


class WaitNotice:
    """Calls `say` once per new waiting state (after the grace period) and once on recovery."""

    def __init__(
        self,
        wait: SessionWait,
        say: Callable[[str], None],
        grace_s: float = GRACE_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.wait = wait
        self.say = say
        self.grace_s = grace_s
        self.clock = clock
        self.started = clock()
        self.said: str | None = None  # the waiting line in force
        self.spoke = False  # a waiting line was said at all
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def poll(self, also: str | None = None) -> str | None:
        """Check now; return what is missing (also before the grace period ends). `also` is
        what the caller itself still waits for once the router and the authority are there
        (an unanswered join), said like the rest."""
        missing = self.wait.missing() or also
        if missing is None and self.said is not None:
            session = self.wait.keys.session
            self.say(f"reached the router and the authority of session {session!r}")
            self.said = None
        elif missing not in (None, self.said) and self.clock() - self.started >= self.grace_s:
            self.say(missing)
            self.said = missing
            self.spoke = True
        return missing

    def resolved(self, message: str) -> None:
        """Say `message` once if a waiting line was ever said: the wait is over (joined)."""
        if self.spoke:
            self.say(message)
            self.said, self.spoke = None, False

    def watch(self) -> WaitNotice:
        """From now on, poll from a thread after a fresh grace period: for a process that
        was admitted and runs on, so that a router or authority that goes mid-session is
        said, and its return. The grace restarts because a join reply can come before the
        authority's token."""
        self.started = self.clock()
        return self.start()

    def start(self) -> WaitNotice:
        """Poll from a daemon thread until close(): for processes whose loop is not ours."""
        self._thread = threading.Thread(target=self._run, name="wait-notice", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.wait(POLL_S):
            self.poll()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        self.wait.close()
