from __future__ import annotations

import msgspec

from carlaverse.authority.membership import Roster
from carlaverse.messages import SCHEMA_VERSION, JoinRequest, Pose

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


def test_expiry_by_telemetry_age_spares_observers() -> None:
    roster = Roster(despawn_timeout_s=3.0)
    roster.join(REQ, 0.0)
    roster.join(JoinRequest(SCHEMA_VERSION, "obs", "i", "observer", actor_kind=""), 0.0)
    roster.pose("tum-drive-1", Pose(1, 1.0, 0, 0), 1.0)
    assert roster.expired(3.9) == []
    assert roster.expired(4.1) == ["tum-drive-1"]


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
