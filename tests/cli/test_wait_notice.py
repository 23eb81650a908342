"""WaitNotice: silent during the grace period, one line per new state, one line on recovery."""

from __future__ import annotations

from carlaverse.keys import Keys
from carlaverse.transport.waiting import WaitNotice


class FakeWait:
    """Stands in for SessionWait: what is missing is set by the test."""

    def __init__(self) -> None:
        self.keys = Keys("lab")
        self.now: str | None = None
        self.closed = False

    def missing(self) -> str | None:
        return self.now

    def close(self) -> None:
        self.closed = True


class ManualClock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_notice_speaks_after_the_grace_once_per_state_and_on_recovery() -> None:
    wait, clock, said = FakeWait(), ManualClock(), []
    notice = WaitNotice(wait, said.append, grace_s=1.0, clock=clock)  # type: ignore[arg-type]
    wait.now = "waiting for a router at tcp/h:1"
    assert notice.poll() == wait.now and said == []  # within the grace: a normal start
    clock.t += 1.0
    notice.poll()
    notice.poll()
    assert said == ["waiting for a router at tcp/h:1"]
    wait.now = "waiting for the authority of session 'lab'"
    notice.poll()
    assert said[-1] == wait.now and len(said) == 2
    wait.now = None
    notice.poll()
    notice.poll()
    assert said[-1] == "reached the router and the authority of session 'lab'" and len(said) == 3
    notice.close()
    assert wait.closed


def test_a_normal_start_says_nothing() -> None:
    wait, clock, said = FakeWait(), ManualClock(), []
    notice = WaitNotice(wait, said.append, grace_s=1.0, clock=clock)  # type: ignore[arg-type]
    wait.now = "waiting for a router at tcp/h:1"
    notice.poll()
    wait.now = None
    clock.t += 5.0
    notice.poll()
    assert said == []


def test_a_resolved_wait_is_said_once_and_only_if_a_wait_was_said() -> None:
    wait, clock, said = FakeWait(), ManualClock(), []
    notice = WaitNotice(wait, said.append, grace_s=1.0, clock=clock)  # type: ignore[arg-type]
    notice.resolved("admitted")
    assert said == []  # nothing was said, so nothing to take back
    wait.now = "waiting for the authority of session 'lab'"
    clock.t += 2.0
    notice.poll()
    notice.resolved("admitted")
    notice.resolved("admitted")
    assert said == [wait.now, "admitted"]
