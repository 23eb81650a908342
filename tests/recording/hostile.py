"""Payloads that once stopped the recorder's writer (issue 20), one per way of failing."""

from __future__ import annotations

import math
import random

import msgspec

from carlaverse import messages as m
from carlaverse.keys import Keys

DEEP = 100_000  # nesting levels: far past msgspec's and Python's recursion limits


def _bad_utf8_spawned() -> bytes:
    valid = {"type": "spawned", "seq": 1, "t": 1.0, "node_id": "AB", "kind": "car"}
    return msgspec.msgpack.encode(valid).replace(b"\xa2AB", b"\xa2\xff\xfe")


def _deep_unknown_field(depth: int) -> bytes:
    """A valid LightsState map plus a field this build does not know, nested `depth` deep."""
    valid = msgspec.msgpack.encode({"seq": 1, "t": 1.0, "lights": []})
    return b"\x84" + valid[1:] + msgspec.msgpack.encode("x") + b"\x91" * depth + b"\xc0"


def _lights(seq: int, t: float | int) -> bytes:
    return msgspec.msgpack.encode({"seq": seq, "t": t, "lights": []})


def hostile_payloads(
    keys: Keys, seed: int = 7, depth: int = DEEP, garbage_bytes: int = 2_000_000
) -> list[tuple[str, bytes, str]]:
    """(key, payload, what is wrong with it); every entry is a payload the fabric can carry.

    `depth` > ~1,000 already exceeds the decoder's recursion limit; the default goes far past.
    """
    pose, lights, events = keys.pose("evil", "t0_0"), keys.world("lights"), keys.world("events")
    garbage = random.Random(seed).randbytes(garbage_bytes)
    return [
        (pose, m.encode_pose(m.Pose(1, math.nan, 0.0, 0.0)), "pose t NaN"),
        (pose, m.encode_pose(m.Pose(2, math.inf, 0.0, 0.0)), "pose t +inf"),
        (pose, m.encode_pose(m.Pose(3, -math.inf, 0.0, 0.0)), "pose t -inf"),
        (pose, m.encode_pose(m.Pose(4, 1e300, 0.0, 0.0)), "pose t beyond MCAP's ns range"),
        (lights, _lights(2**64 - 1, 1.0), "seq at the uint64 limit"),
        (lights, _lights(-(2**63), -1e308), "most negative seq and t"),
        (lights, _lights(1, 2**64 - 1), "integer t of 1.8e19 s"),
        (lights, _lights(1, math.nan), "msgpack t NaN"),
        (events, b"\x91" * depth + b"\xc0", "deeply nested arrays"),
        (events, b"\x81\xa1k" * depth + b"\xc0", "deeply nested maps"),
        (lights, _deep_unknown_field(depth), "deep nesting in an unknown field"),
        (events, _bad_utf8_spawned(), "invalid UTF-8 in a string"),
        (keys.world("weather"), b"\xc1", "a byte msgpack never uses"),
        (
            keys.impulse("evil"),
            msgspec.msgpack.encode([1, 2.0, 3, [math.inf] * 3]),
            "short impulse",
        ),
        (f"{keys.prefix}/future/key", b"\x91" * depth + b"\xc0", "nesting on an unknown key"),
        (lights, garbage, f"{garbage_bytes} random bytes"),
        (events, b"", "empty payload"),
    ]
