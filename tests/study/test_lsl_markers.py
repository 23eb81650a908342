"""The session's LSL marker and clock streams, read by a real inlet on loopback, for world
events published on a real Zenoh session."""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterator
from typing import Any

import pytest

from carlaverse import messages as m
from carlaverse.study.lsl_api import LslClock
from carlaverse.study.lsl_clock import SessionTimeFollower
from carlaverse.study.lsl_markers import SessionMarkers, clock_stream_name, marker_stream_name
from tests.study.lsl_support import SESSION_OFFSET_S, Fabric, lsl, open_fabric
from tests.support import wait_until

ACCURACY_S = 0.005  # [s] as for recorded samples (tests/study/test_lsl_record.py)


@pytest.fixture
def fabric() -> Iterator[Fabric]:
    with open_fabric() as fab:
        yield fab


@pytest.fixture
def markers(fabric: Fabric) -> Iterator[SessionMarkers]:
    pylsl = lsl()
    follower = SessionTimeFollower(fabric.client, fabric.keys, LslClock(pylsl)).start()
    running = SessionMarkers(fabric.client, fabric.keys, pylsl, follower, clock_period_s=0.2)
    try:
        yield running.start()
    finally:
        running.close()
        follower.close()


def _inlet(name: str) -> Any:
    pylsl = lsl()
    (info,) = pylsl.resolve_byprop("name", name, 1, 5.0)
    inlet = pylsl.StreamInlet(info)
    inlet.open_stream(timeout=5.0)
    return inlet


def _pull(inlet: Any, count: int) -> list[tuple[list[Any], float]]:
    got: list[tuple[list[Any], float]] = []

    def more() -> bool:
        values, stamps = inlet.pull_chunk(timeout=0.05)
        got.extend(zip(values, stamps, strict=True))
        return len(got) >= count

    wait_until(more, 10, f"{count} samples on the inlet")
    return got


def test_triggers_notices_and_contacts_become_markers_at_their_session_time(
    fabric: Fabric, markers: SessionMarkers
) -> None:
    inlet = _inlet(marker_stream_name("lsltest"))
    # Until the subscription reaches the authority's session, puts go nowhere: spawns (no
    # marker) are published until the first is heard.
    spawn = m.Spawned(0, fabric.session_now(), "ego1", "drive", "car")
    wait_until(lambda: fabric.publish_event(spawn) or markers.stats.ignored, 5, "a spawn heard")
    t = fabric.session_now() - 0.25  # in the past: a marker carries when it happened
    events = [
        m.TriggerFired(1, t, "brake-test", ["release waiting-car"], {"ttc_s": 2.5}),
        m.Notice(2, t + 0.01, "Please brake now", to="ego1"),
        m.ContactStarted(3, t + 0.02, 7, "ego1", "npc-3", 4.2),
        m.ContactEnded(4, t + 0.03, 7, "ego1", "npc-3"),
    ]
    for event in events:
        fabric.publish_event(event)
    fabric.authority.put(fabric.keys.world("events"), b"\xc1 not a world event")
    # The events' order on the fabric is kept; a trial marker from this process is not
    # ordered with them, so it goes once they are out.
    wait_until(lambda: markers.stats.published == 4, 5, "four event markers")
    markers.trial_started("T3", condition="fog")
    received = _pull(inlet, 5)
    correction = inlet.time_correction(timeout=5.0)

    bodies = [json.loads(values[0]) for values, _ in received]
    assert [b["type"] for b in bodies] == [
        "trigger",
        "notice",
        "contact_started",
        "contact_ended",
        "trial_start",
    ]
    assert bodies[0]["trigger_id"] == "brake-test" and bodies[0]["values"] == {"ttc_s": 2.5}
    assert bodies[1]["text"] == "Please brake now"
    assert (bodies[2]["contact_id"], bodies[2]["b"]) == (7, "npc-3")
    assert (bodies[4]["trial"], bodies[4]["condition"]) == ("T3", "fog")
    # Each event's LSL stamp is its session time on this host's LSL clock: the stand-in
    # authority's session time is local_clock() + SESSION_OFFSET_S.
    for event, (_, stamp) in zip(events, received, strict=False):
        assert abs(stamp + correction - (event.t - SESSION_OFFSET_S)) < ACCURACY_S
    # The trial marker has no time of its own: it is stamped when it was pushed, and says so.
    trial_stamp = received[4][1] + correction
    assert abs(bodies[4]["t"] - (trial_stamp + SESSION_OFFSET_S)) < ACCURACY_S
    assert (markers.stats.published, markers.stats.bad) == (5, 1)


def test_the_clock_stream_pairs_lsl_time_with_session_time(
    fabric: Fabric, markers: SessionMarkers
) -> None:
    inlet = _inlet(clock_stream_name("lsltest"))
    received = _pull(inlet, 3)
    correction = inlet.time_correction(timeout=5.0)
    for (session_t,), stamp in received:
        assert abs(session_t - (stamp + correction + SESSION_OFFSET_S)) < ACCURACY_S
    stamps = [stamp for _, stamp in received]
    assert all(0.1 < b - a < 0.4 for a, b in itertools.pairwise(stamps))  # 0.2 s


def test_a_marker_that_cannot_be_written_is_counted_and_the_next_goes(
    fabric: Fabric, markers: SessionMarkers
) -> None:
    inlet = _inlet(marker_stream_name("lsltest"))
    markers.mark("odd", {"value": object()})  # type: ignore[dict-item]  # not JSON
    end_t = fabric.session_now() - 0.5  # the runner knows when the trial ended
    markers.trial_ended("T3", end_t, outcome="completed")
    ((values, stamp),) = _pull(inlet, 1)
    body = json.loads(values[0])
    assert (body["type"], body["t"], body["outcome"]) == ("trial_end", end_t, "completed")
    correction = inlet.time_correction(timeout=5.0)
    assert abs(stamp + correction - (end_t - SESSION_OFFSET_S)) < ACCURACY_S
    assert (markers.stats.failed, markers.stats.published) == (1, 1)
