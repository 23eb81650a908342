"""The authority's outbox knows, from Zenoh's matching status, which listeners anything
subscribes to, so audio scenes are built only for those (real sessions over loopback TCP)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from carlaverse import messages as m
from carlaverse.authority.outbox import ZenohOutbox
from carlaverse.keys import Keys
from tests.support import linked_peers, wait_until

K = Keys("t")


@pytest.fixture
def sessions() -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    with linked_peers() as (authority, node):  # the node connects to the authority
        yield authority, node


def test_a_listener_is_heard_while_something_subscribes_to_its_audio(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    authority, node = sessions
    out = ZenohOutbox(authority, K)
    assert not out.hears("n1")  # nothing subscribes yet
    received: list[m.AudioScene] = []
    sub = node.declare_subscriber(
        K.audio("n1"), lambda s: received.append(m.AUDIO_SCENE.decode(s.payload.to_bytes()))
    )
    wait_until(lambda: out.hears("n1"), 10, "the subscriber to audio/n1 to be seen")
    assert not out.hears("n2")  # another listener's key does not match
    out.audio("n1", m.AudioScene(1, 0.5, "n1", []))
    wait_until(lambda: received, 10, "the scene on audio/n1")
    assert received[0].listener == "n1"
    sub.undeclare()
    wait_until(lambda: not out.hears("n1"), 10, "the subscriber's undeclaration to be seen")


def test_a_recorder_of_everything_hears_every_listener(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    authority, node = sessions
    out = ZenohOutbox(authority, K)
    node.declare_subscriber(K.everything, lambda s: None)
    wait_until(lambda: out.hears("n1") and out.hears("n2"), 10, "both listeners heard")
    out.forget("n1")  # the node left: its publisher and matching listener go
    assert "n1" not in out._audio
    wait_until(lambda: out.hears("n1"), 10, "a rejoin declaring again and seeing the recorder")
