"""Which new keys a recording takes: the rules of recording/admission.py, one at a time.

Small budgets make each rule visible with a handful of keys; the numbers follow from the
rules as docs/protocol.md states them ("Recording: which keys"), not from the code.
"""

from __future__ import annotations

from carlaverse.keys import AUTHORITY_ID, Keys
from carlaverse.recording.admission import Budget, KeyAdmission, sender_of

K = Keys("s")
SMALL = Budget(max_channels=6, stranger_channels=2, per_sender=3, per_authority=4)


def test_each_key_is_charged_to_the_node_it_is_about() -> None:
    assert sender_of(K.node("a")) == "a"
    assert sender_of(K.pose("a", "t3_-2")) == "a"
    assert sender_of(K.state("a")) == "a"
    assert sender_of(K.audio("a")) == "a"  # written by the authority, about `a`
    assert sender_of(K.impulse("a")) == "a"
    assert sender_of(K.world("npc")) == AUTHORITY_ID
    assert sender_of(K.npc_in("t0_0")) == AUTHORITY_ID
    assert sender_of(K.authority("snapshot")) == AUTHORITY_ID
    for junk in (f"{K.prefix}/junk/1", f"{K.prefix}/ego/a/pose/t0_0/x", f"{K.prefix}/node/gx\n"):
        assert sender_of(junk) == "", junk


def test_strangers_share_their_own_room_and_never_a_present_senders() -> None:
    admission = KeyAdmission(SMALL)
    admission.present("real")
    forged = [K.state(f"ghost{i}") for i in range(10)] + [f"{K.prefix}/junk/{i}" for i in range(10)]
    taken = [k for k in forged if admission.admit(k)]
    assert len(taken) == SMALL.stranger_channels  # 2 of the 20
    assert admission.refused["strangers_full"] == 20 - 2
    real = [K.node("real"), K.state("real"), K.pose("real", "t0_0")]
    assert all(admission.admit(k) for k in real)  # the present sender's room is whole


def test_one_present_sender_cannot_take_the_others_room() -> None:
    admission = KeyAdmission(SMALL)
    for node in ("greedy", "other"):
        admission.present(node)
    tiles = [K.pose("greedy", f"t{i}_0") for i in range(10)]
    assert sum(admission.admit(k) for k in tiles) == SMALL.per_sender  # 3
    assert admission.refused["sender_full"] == 10 - 3
    # 6 present keys in all, 3 taken: `other` still gets the remaining 3
    assert all(admission.admit(K.pose("other", f"t{i}_0")) for i in range(3))
    admission.present("late")
    assert not admission.admit(K.state("late"))  # 6 of 6 present keys taken
    assert admission.refused["present_full"] == 1


def test_the_authority_has_its_own_larger_share() -> None:
    admission = KeyAdmission(SMALL)
    admission.present(AUTHORITY_ID)
    npc = [K.npc_in(f"t{i}_0") for i in range(8)]
    assert sum(admission.admit(k) for k in npc) == SMALL.per_authority  # 4 tiles


def test_a_sender_whose_data_beat_its_token_is_taken_once_the_token_is_there() -> None:
    admission = KeyAdmission(Budget(max_channels=4, stranger_channels=0))
    assert not admission.admit(K.pose("slow", "t0_0"))  # no token yet, no stranger room
    admission.present("slow")
    assert admission.admit(K.pose("slow", "t0_0"))  # asked again at its next sample
    admission.absent("slow")
    assert not admission.admit(K.pose("slow", "t1_0"))  # gone: its new keys are a stranger's
