from __future__ import annotations

import pytest

from carlaverse.keys import EGO_CHANNELS, WORLD_CHANNELS, Keys, KeySpaceError, check_token, parse


def test_every_built_key_parses_back() -> None:
    k = Keys("tum-study")
    for channel in EGO_CHANNELS:
        p = parse(k.ego("tum-drive-1", channel))
        assert (p.session, p.area, p.channel, p.node_id) == (
            "tum-study",
            "ego",
            channel,
            "tum-drive-1",
        )
    for channel in WORLD_CHANNELS:
        assert parse(k.world(channel)).channel == channel
    assert parse(k.impulse("x")).node_id == "x"
    assert parse(k.node("x")).area == "node"
    assert parse(k.authority("join")).channel == "join"
    for key in (
        k.pose("n1", "t0_0"),
        k.world("npc"),
        k.impulse("n1"),
        k.authority("clock"),
        k.node("n"),
    ):
        assert f"{k.prefix}/{parse(key).path}" == key


def test_session_rewrite_keeps_the_path() -> None:
    k = Keys("a")
    assert k.with_session(k.pose("n", "t0_0"), "b") == Keys("b").pose("n", "t0_0")


@pytest.mark.parametrize("bad", ["", "*", "a/b", "a*", "$x", "-lead", "x" * 64, "a b", "**", "é"])
def test_ids_that_could_widen_a_key_are_refused(bad: str) -> None:
    with pytest.raises(KeySpaceError, match="invalid node id"):
        check_token(bad)


@pytest.mark.parametrize(
    "key",
    [
        "carlaverse/s/ego/n/teleport",
        "other/s/ego/n/pose",
        "carlaverse/s/world/nope",
        "carlaverse/s/ego/*/pose",
        "carlaverse/s",
        "carlaverse/s/authority/x",
        "carlaverse/s/node/a/b",
    ],
)
def test_foreign_keys_do_not_parse(key: str) -> None:
    with pytest.raises(KeySpaceError, match="not a carlaverse key"):
        parse(key)


def test_unknown_channels_are_named() -> None:
    with pytest.raises(KeySpaceError, match="unknown ego channel 'posture'"):
        Keys("s").ego("n", "posture")
