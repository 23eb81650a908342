"""Ego keys declared to Zenoh as they are first heard, so that Zenoh keeps their routes.

A node hears other egos' poses through wildcard subscriptions (`ego/*/pose/**`, or
`ego/*/pose/<tile>` in an interest area), their states and walkers' skeletons too
(`ego/*/state`, `ego/*/skeleton`), and each sample comes on its sender's concrete key
(`ego/<id>/pose/<tile>`, `ego/<id>/skeleton`). Zenoh keeps the route of a sample (which local
subscribers get it) on the resource of its key in its routing tables, and a concrete key that
nothing in this process declared has no resource: every such sample is matched against the
whole table again (`Resource::get_matches` in the receiving process's profile), a cost that
grows with the session, since every node's subscriptions, tokens and queryables are in those
tables. Declaring the key here (`Session.declare_keyexpr`) makes its resource, and the samples
after it take the kept route, as they do for a subscription on the exact key. In `bench_peers`
this took 30-60 µs a pose off the pose path's receivers (five processes on one host), and a
bare subscriber among 200 other declarations spent ~110 µs a sample more without it.

Declaring takes Zenoh's tables lock, which a direct callback on Zenoh's own thread may be
under, so no callback declares: `sender` notes a new key, and this module's own thread
declares it. A key is declared when it is heard the second time (a sender at 50 Hz: 20 ms
after its first pose on a tile), so a flood of made-up keys, each sent once, costs a parse a
sample, as before, and declares nothing. The declarations are bounded (`limit`): beyond it the
oldest goes, so a long session of egos crossing tiles keeps the keys in use.
"""

from __future__ import annotations

import logging
import threading
from collections import deque

import zenoh

from carlaverse.keys import KeySpaceError, parse_cached

log = logging.getLogger(__name__)

LIMIT = 1024  # declared keys kept: every tile of 256 egos' last few tiles


class KeyRoutes:
    """The keys of the ego `channels` heard, by key -> sender id (`senders`, read without a
    lock in callbacks), each declared to the session once `attach`ed."""

    def __init__(self, channels: tuple[str, ...] = ("pose",), limit: int = LIMIT) -> None:
        self.channels = channels
        self.limit = limit
        self.senders: dict[str, str] = {}  # concrete key -> node id, declared or due
        self._once: dict[str, str] = {}  # keys heard once, not in `senders`
        self._pending: deque[str] = deque()  # in `senders`, not yet declared
        self._declared: deque[tuple[str, zenoh.KeyExpr]] = deque()  # oldest first
        self._due = threading.Event()
        self._stop = threading.Event()
        self._session: zenoh.Session | None = None
        self._thread: threading.Thread | None = None

    def sender(self, key: str) -> str:
        """The node id of `key`, which `senders` lacks; KeySpaceError if it is not a key
        `ego/<id>/<channel>[/<tile>]` of one of `channels`. Never waits: heard the second
        time, the key is queued for the declaring thread."""
        parsed = parse_cached(key)
        if parsed.area != "ego" or parsed.channel not in self.channels:
            raise KeySpaceError(f"not a key of ego {'/'.join(self.channels)}: {key!r}")
        once = self._once
        if once.pop(key, None) is None:
            if len(once) >= self.limit:
                once.clear()  # a flood of keys heard once: forget them all, keep nothing
            once[key] = parsed.node_id
        elif len(self._pending) < self.limit:
            self.senders[key] = parsed.node_id
            self._pending.append(key)
            self._due.set()
        return parsed.node_id

    def attach(self, session: zenoh.Session, name: str = "key-routes") -> None:
        """Declare the keys heard, from now on, in `session` (on a daemon thread of ours)."""
        if self._thread is not None:
            raise RuntimeError("key routes are attached to a session already")
        self._session = session
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    @property
    def declared(self) -> list[str]:
        """The keys declared now, oldest first."""
        return [key for key, _ in list(self._declared)]

    def close(self) -> None:
        """Stop declaring and undeclare every key (before the session closes)."""
        self._stop.set()
        self._due.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        session, self._session = self._session, None
        while self._declared:
            _, expr = self._declared.popleft()
            if session is not None:
                self._undeclare(session, expr)

    def _run(self) -> None:
        while True:
            self._due.wait()
            self._due.clear()
            if self._stop.is_set():
                return
            self._declare_pending()

    def _declare_pending(self) -> None:
        session = self._session
        while self._pending and session is not None and not self._stop.is_set():
            key = self._pending.popleft()
            try:
                expr = session.declare_keyexpr(key)
            except Exception as exc:  # a closing session: the samples just go unrouted
                log.debug("key %s not declared: %s", key, exc)
                continue
            self._declared.append((key, expr))
            while len(self._declared) > self.limit:
                old, old_expr = self._declared.popleft()
                self.senders.pop(old, None)  # heard again, it is noted and declared again
                self._undeclare(session, old_expr)

    @staticmethod
    def _undeclare(session: zenoh.Session, expr: zenoh.KeyExpr) -> None:
        try:
            session.undeclare(expr)
        except Exception as exc:  # the session closed under us: nothing left to undeclare
            log.debug("key %s not undeclared: %s", expr, exc)
