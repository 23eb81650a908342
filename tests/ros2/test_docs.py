"""docs/protocol.md's ROS 2 section says what the code does: its type hashes, its
carlaverse_msgs definitions, its topics."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from carlaverse.ros2 import types as t

DOC = Path(__file__).parents[2] / "docs" / "protocol.md"
DOCUMENTED = [t.CLOCK, t.TF_MESSAGE, t.ODOMETRY, t.DETECTION_3D_ARRAY, t.MARKER_ARRAY,
              t.TRAFFIC_LIGHT_ARRAY, t.COLLISION_IMPULSE]  # fmt: skip


def section() -> str:
    text = DOC.read_text()
    start = text.index("## ROS 2 over Zenoh")
    return text[start : text.index("\n## ", start + 1)]


@pytest.mark.parametrize("definition", DOCUMENTED, ids=lambda d: d.name)
def test_each_documented_hash_is_the_codes(definition: t.MsgDef) -> None:
    name = re.escape(definition.name)
    row = re.search(rf"\| `{name}` \| `(RIHS01_[0-9a-f]{{64}})` \|", section())
    assert row is not None, f"{definition.name} has no row in the hash table"
    assert row[1] == t.type_hash(definition)


OURS = [t.TRAFFIC_LIGHT, t.TRAFFIC_LIGHT_ARRAY, t.COLLISION_IMPULSE]


@pytest.mark.parametrize("definition", OURS, ids=lambda d: d.name)
def test_each_carlaverse_msgs_file_is_the_codes(definition: t.MsgDef) -> None:
    short = definition.name.rsplit("/", 1)[1]
    match = re.search(rf"# carlaverse_msgs/msg/{short}\.msg\n(.*?)(?:\n\n|\n```)", section(), re.S)
    assert match is not None
    assert match[1] + "\n" == t.msg_text(definition)
