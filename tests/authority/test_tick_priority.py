"""The authority's tick thread, and only it, runs real-time when `tick_priority` asks."""

from __future__ import annotations

import gc
import os
import threading
from collections.abc import Mapping

import pytest

from carlaverse.authority.domain import EgoTrack, EmptyDomain, Outbox
from carlaverse.authority.service import Authority, AuthoritySettings
from carlaverse.transport.clock import WallAlignedClock
from carlaverse.transport.session import FabricSettings, open_session


class SchedulingProbe(EmptyDomain):
    """Notes how the thread that ticks it is scheduled."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: list[tuple[int, int]] = []

    def tick(self, t: float, egos: Mapping[str, EgoTrack], out: Outbox) -> None:
        self.seen.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))


def ticked(priority: int) -> tuple[Authority, SchedulingProbe]:
    session = open_session(FabricSettings(listen=["tcp/127.0.0.1:0"]))
    domain = SchedulingProbe()
    settings = AuthoritySettings(session="t", tick_priority=priority)
    authority = Authority(session, settings, WallAlignedClock(), domain)
    try:
        thread = threading.Thread(target=authority.run, kwargs={"duration_s": 0.2})
        thread.start()
        thread.join(10)
    finally:
        authority.close()
        session.close()
    assert domain.seen, "the authority never ticked"
    return authority, domain


def test_the_tick_thread_runs_fifo_and_the_rest_of_the_process_does_not() -> None:
    authority, domain = ticked(7)
    if authority.scheduling != "SCHED_FIFO 7":  # no CAP_SYS_NICE here: the fallback, said
        assert authority.scheduling in ("nice -10", "normal")
        pytest.skip(f"real-time scheduling not permitted here ({authority.scheduling})")
    assert set(domain.seen) == {(os.SCHED_FIFO, 7)}
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # this thread, the query threads' kin


def test_priority_zero_leaves_the_tick_as_it_was() -> None:
    authority, domain = ticked(0)
    assert authority.scheduling == "unchanged"
    assert set(domain.seen) == {(os.SCHED_OTHER, 0)}


def test_a_priority_out_of_range_is_refused_by_name() -> None:
    import msgspec

    with pytest.raises(msgspec.ValidationError, match="tick_priority"):
        msgspec.convert({"tick_priority": 120}, AuthoritySettings)


class FreezeProbe(EmptyDomain):
    def __init__(self) -> None:
        super().__init__()
        self.frozen: list[int] = []

    def tick(self, t: float, egos: Mapping[str, EgoTrack], out: Outbox) -> None:
        self.frozen.append(gc.get_freeze_count())


def test_what_lives_at_the_start_is_kept_from_the_collector_while_it_ticks() -> None:
    session = open_session(FabricSettings(listen=["tcp/127.0.0.1:0"]))
    domain = FreezeProbe()
    authority = Authority(session, AuthoritySettings(session="t"), WallAlignedClock(), domain)
    try:
        authority.run(duration_s=0.1)
    finally:
        authority.close()
        session.close()
    assert domain.frozen and min(domain.frozen) > 1000  # the process's objects, frozen
    assert gc.get_freeze_count() == 0  # and given back when the ticking ends
