"""Page input is validated by msgspec Structs: a bad frame is counted by reason and dropped."""

from __future__ import annotations

import json

from hypothesis import given
from hypothesis import strategies as st

from carlaverse.hmi.wire import MAX_INPUT_BYTES, Cruise, InputCheck, Ping, Press


def check() -> InputCheck:
    return InputCheck(frozenset({"low_beam", "gear_drive"}), cruise=True)


def test_good_inputs_decode_to_their_structs() -> None:
    inputs = check()
    assert inputs.check('{"type": "press", "action": "low_beam"}') == (Press("low_beam"), "")
    assert inputs.check('{"type": "cruise", "command": "resume"}') == (Cruise("resume"), "")
    assert inputs.check('{"type": "ping", "page_ms": 12.5}') == (Ping(12.5), "")
    assert inputs.accepted == 3 and not inputs.rejected


def test_each_bad_input_is_counted_under_its_reason() -> None:
    inputs = check()
    bad = {
        "json": "{not json",
        "schema": '{"type": "cruise", "command": "fly"}',
        "binary": b'{"type": "ping", "page_ms": 1}',
        "size": json.dumps({"type": "ping", "page_ms": 1, "pad": "x" * MAX_INPUT_BYTES}),
        "action": '{"type": "press", "action": "eject_seat"}',
    }
    for reason, raw in bad.items():
        item, why = inputs.check(raw)
        assert item is None and why.startswith(reason + ":"), (reason, why)
    assert inputs.check('{"type": "press", "action": "low_beam", "extra": 1}')[0] is None
    assert inputs.check('{"type": "ping", "page_ms": 1e300}')[0] is None  # out of bounds
    assert inputs.rejected == {"json": 1, "schema": 3, "binary": 1, "size": 1, "action": 1}
    assert inputs.accepted == 0


def test_a_node_without_cruise_control_rejects_cruise_commands() -> None:
    inputs = InputCheck(frozenset(), cruise=False)
    item, why = inputs.check('{"type": "cruise", "command": "set"}')
    assert item is None and why.startswith("cruise:")
    assert inputs.rejected == {"cruise": 1}


@given(st.one_of(st.text(max_size=200), st.binary(max_size=200), st.none()))
def test_arbitrary_frames_never_raise(raw: str | bytes | None) -> None:
    inputs = check()
    item, why = inputs.check(raw)
    assert (item is None) == bool(why)
    assert inputs.accepted + sum(inputs.rejected.values()) == 1
