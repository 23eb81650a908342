"""A trial's end condition hears the authority's world events as they travel (MessagePack
bytes): a named trigger or a contact ends it, anything else or garbage does not."""

from __future__ import annotations

from carlaverse import messages as m
from carlaverse.study.end_condition import EndCondition


def _bytes(event: m.WorldEvent) -> bytes:
    return m.WORLD_EVENT.encode(event)


def test_the_named_trigger_ends_the_trial() -> None:
    end = EndCondition(["cyclist-crossed"], contact=False)
    end.on_event(b"\xc1 not msgpack")
    end.on_event(_bytes(m.TriggerFired(seq=1, t=10.0, trigger_id="van-pulls-out", actions=[])))
    end.on_event(_bytes(m.ContactStarted(seq=2, t=11.0, contact_id=1, a="P01", b="P02")))
    assert not end.met.is_set() and end.dropped == 1
    end.on_event(_bytes(m.TriggerFired(seq=3, t=12.5, trigger_id="cyclist-crossed", actions=[])))
    assert end.met.is_set()
    assert end.reason == "trigger cyclist-crossed fired at session time 12.500 s"


def test_a_contact_ends_the_trial_when_asked() -> None:
    end = EndCondition([], contact=True)
    assert end.wanted and not EndCondition([], contact=False).wanted
    end.on_event(_bytes(m.ContactStarted(seq=2, t=11.0, contact_id=1, a="P01", b="npc-4")))
    assert end.reason == "contact of P01 and npc-4 at session time 11.000 s"
