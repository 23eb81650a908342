from __future__ import annotations

import math

import msgspec
import pytest

from carlaverse.authority.membership import MAX_NODES, Roster
from carlaverse.messages import ACTOR_KINDS, SCHEMA_VERSION, Extent, JoinRequest, Pose

REQ = JoinRequest(SCHEMA_VERSION, "tum-drive-1", "inst-a", "drive", hostname="cabin-pc")


def test_duplicate_id_is_refused_while_the_holder_lives() -> None:
    roster = Roster(despawn_timeout_s=3.0)
    assert roster.join(REQ, 0.0).new
    roster.token("tum-drive-1", True)
    other = msgspec.structs.replace(REQ, instance="inst-b")
    decision = roster.join(other, 10.0)
    assert not decision.accepted and "already in use" in decision.reason
    assert "cabin-pc" in decision.reason
    # the same process re-joining (authority restart, partition) is welcome, and not "new"
    again = roster.join(REQ, 11.0)
    assert again.accepted and not again.new


def test_id_is_free_again_once_the_holder_is_gone() -> None:
    roster = Roster(despawn_timeout_s=3.0)
    roster.join(REQ, 0.0)
    roster.pose("tum-drive-1", Pose(1, 0.5, 0, 0), 0.5)
    assert roster.join(msgspec.structs.replace(REQ, instance="b"), 4.0).accepted


OBSERVER = JoinRequest(SCHEMA_VERSION, "obs", "i", "observer", actor_kind="")


def test_expiry_by_telemetry_age_spares_observers_that_hold_a_token() -> None:
    roster = Roster(despawn_timeout_s=3.0)
    roster.join(REQ, 0.0)
    roster.join(OBSERVER, 0.0)
    roster.token("obs", True)
    roster.pose("tum-drive-1", Pose(1, 1.0, 0, 0), 1.0)
    assert roster.expired(3.9) == []
    assert roster.expired(4.1) == ["tum-drive-1"]
    assert roster.expired(100.0) == ["tum-drive-1"]


def test_a_join_that_never_declares_a_token_is_despawned_for_silence() -> None:
    roster = Roster(despawn_timeout_s=3.0)
    roster.join(OBSERVER, 10.0)
    assert roster.expired(12.9) == []  # the grace to declare it
    assert roster.expired(13.1) == ["obs"]


def test_a_pose_far_from_session_time_is_refused() -> None:
    roster = Roster(despawn_timeout_s=3.0)
    roster.join(REQ, 0.0)
    assert roster.pose("tum-drive-1", Pose(1, 100.0 + 3600, 0, 0), 100.0) == "implausible_time"
    assert roster.pose("tum-drive-1", Pose(1, 100.0 - 60, 0, 0), 100.0) == "implausible_time"
    assert roster.pose("mallory", Pose(1, 100.0, 0, 0), 100.0) == "not_joined"
    assert "mallory" not in roster.tracks


def test_a_forged_pose_from_the_near_future_cannot_starve_a_live_node() -> None:
    roster = Roster(despawn_timeout_s=3.0)
    roster.join(REQ, 0.0)
    assert roster.pose("tum-drive-1", Pose(1, 1.0 + 4.9, 66.0, 0), 1.0) == ""  # forged
    for i in range(2, 80):  # the real stream carries on at 20 Hz, older than the forgery
        t = 1.0 + i * 0.05
        assert roster.pose("tum-drive-1", Pose(i, t, float(i), 0), t) == ""
    assert roster.expired(5.0) == []
    track = roster.tracks["tum-drive-1"]
    assert track.last_pose is not None and track.last_pose.x == 79.0  # the real one won back


def test_a_new_process_taking_over_a_gone_id_replaces_it() -> None:
    roster = Roster(3.0)
    roster.join(REQ, 0.0)
    decision = roster.join(msgspec.structs.replace(REQ, instance="inst-b"), 10.0)
    assert decision.accepted and decision.new and decision.replaced
    assert not roster.join(REQ, 10.5).accepted  # the old process is not let back in now


GOOD = JoinRequest(SCHEMA_VERSION, "n1", "i", "drive", config_yaml="a: 1\n")
BAD_JOINS = {
    "pose rate 0": ({"pose_rate_hz": 0.0}, "pose_rate_hz"),
    "pose rate nan": ({"pose_rate_hz": math.nan}, "pose_rate_hz"),
    "pose rate negative": ({"pose_rate_hz": -50.0}, "pose_rate_hz"),
    "pose rate huge": ({"pose_rate_hz": 1e9}, "pose_rate_hz"),
    "extent inf": ({"extent": Extent(math.inf, 1.8, 1.5)}, "extent.length"),
    "extent negative": ({"extent": Extent(4.5, -1.8, 1.5)}, "extent.width"),
    "mass nan": ({"mass_kg": math.nan}, "mass_kg"),
    "mass zero": ({"mass_kg": 0.0}, "mass_kg"),
    "spaceship": ({"actor_kind": "spaceship"}, "unknown actor_kind 'spaceship'"),
    "no actor, not observer": ({"actor_kind": ""}, "only observers"),
    "yaml": ({"config_yaml": "a: [1, 2\n  b: }"}, "does not parse as YAML"),
    "yaml flow nesting": ({"config_yaml": "[" * 60_000}, "nests deeper"),
    "yaml block nesting": ({"config_yaml": "- " * 30_000 + "x"}, "nests deeper"),
    "yaml size": ({"config_yaml": "a: " + "x" * 70_000}, "bytes"),
    "reserved": ({"node_id": "authority"}, "reserved"),
    "wildcard": ({"node_id": "*"}, "invalid node id"),
    "separator": ({"node_id": "a/b"}, "invalid node id"),
    "long kind": ({"kind": "k" * 40}, "kind is 40 characters"),
    "bad kind": ({"kind": "dr ive"}, "invalid node kind"),
    "no instance": ({"instance": ""}, "instance is empty"),
    "long hostname": ({"hostname": "h" * 300}, "hostname"),
}


@pytest.mark.parametrize("change,reason", BAD_JOINS.values(), ids=list(BAD_JOINS))
def test_an_impossible_join_is_refused_naming_the_field(change: dict, reason: str) -> None:
    roster = Roster(3.0)
    decision = roster.join(msgspec.structs.replace(GOOD, **change), 0.0)
    assert not decision.accepted and reason in decision.reason
    assert "\n" not in decision.reason and roster.tracks == {}


def test_every_actor_kind_and_an_observer_are_accepted() -> None:
    roster = Roster(3.0)
    for i, kind in enumerate(ACTOR_KINDS):
        assert roster.join(
            msgspec.structs.replace(GOOD, node_id=f"n{i}", actor_kind=kind), 0
        ).accepted
    assert roster.join(OBSERVER, 0.0).accepted


def test_token_loss_reports_only_joined_nodes() -> None:
    roster = Roster(3.0)
    roster.join(REQ, 0.0)
    assert roster.token("tum-drive-1", False) is True
    assert roster.token("stranger", False) is False


def test_schema_mismatch_and_reserved_ids_are_refused() -> None:
    roster = Roster(3.0)
    old = msgspec.structs.replace(REQ, schema=SCHEMA_VERSION + 1)
    assert "schema version" in roster.join(old, 0).reason
    assert "reserved" in roster.join(msgspec.structs.replace(REQ, node_id="authority"), 0).reason
    assert "invalid node id" in roster.join(msgspec.structs.replace(REQ, node_id="a/b"), 0).reason


def test_the_roster_is_bounded() -> None:
    roster = Roster(3.0)
    for i in range(MAX_NODES):
        assert roster.join(msgspec.structs.replace(GOOD, node_id=f"n{i}"), 0.0).accepted
    full = roster.join(msgspec.structs.replace(GOOD, node_id="one-more"), 0.0)
    assert not full.accepted and "full" in full.reason
    for i in range(10_000):
        roster.token(f"flood-{i}", True)
    assert len(roster.tokens) <= 4096


def test_a_config_sent_unredacted_is_kept_redacted() -> None:
    """An older or foreign node may send its login; the authority never keeps it to serve."""
    secret = "pw-7f3a9c"
    config = (
        "node: {node_id: tum-drive-1}\n"
        f"fabric:\n  zenoh:\n    transport/auth/usrpwd/password: {secret}\n"
    )
    roster = Roster(despawn_timeout_s=3.0)
    decision = roster.join(msgspec.structs.replace(REQ, config_yaml=config), 0.0)
    assert decision.accepted
    kept = roster.tracks["tum-drive-1"].config_yaml
    assert secret not in kept
    assert "transport/auth/usrpwd/password" in kept  # that a login was set stays visible
