"""The authority's pose digest (`world/@egos`): many poses per sample for nodes that hear the
whole session. Real router, scripted nodes as processes, the authority and observers in this
process on 127.0.0.1."""

from __future__ import annotations

import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse import messages as m
from carlaverse.keys import Keys, parse
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

K = Keys("t")


def _pose(seq: int, t: float, x: float = 1.0) -> m.Pose:
    return m.Pose(seq, t, x, 2.0, 0.5, 0.0, 0.1, 1.5, 3.0, 0.0, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0)


# ------------------------------------------------------------------ the message


def test_rows_decode_as_single_poses_and_bad_rows_are_none() -> None:
    good = [m.encode_pose(_pose(i, 100.0 + i, x=i)) for i in range(3)]
    nan = bytearray(good[0])
    nan[16:20] = b"\x00\x00\xc0\x7f"  # x = NaN
    version = b"\x09" + good[0][1:]
    far = m.encode_pose(_pose(1, 2e12))
    rows = m.decode_pose_rows(b"".join([good[0], bytes(nan), good[1], version, far, good[2]]))
    assert rows[1] is None and rows[3] is None and rows[4] is None
    assert [rows[0], rows[2], rows[5]] == [m.decode_pose(p) for p in good]
    with pytest.raises(m.MessageError, match="not a multiple of 64"):
        m.decode_pose_rows(good[0][:-1])


def test_a_poses_stamp_is_read_without_decoding_it() -> None:
    assert m.pose_stamp(m.encode_pose(_pose(9, 100.0))) == (9, 100.0)


def test_rows_that_are_all_good_decode_field_for_field_as_single_poses() -> None:
    # The common case takes a path of its own (no row refused): every field, its type too.
    values = (2.25, 0.5, 0.1, -0.2, 1.5, 3.0, -1.0, 0.5, 0.25, -0.5, 1.0, 2.0, -3.0, 0.125)
    poses = [m.Pose(7 + i, 1.7e9 + i / 3, i - 0.5, *values, flags=i % 2) for i in range(5)]
    wires = [m.encode_pose(p) for p in poses]
    rows = m.decode_pose_rows(b"".join(wires))
    assert rows == [m.decode_pose(w) for w in wires]
    assert [type(p.seq) for p in rows] == [int] * 5  # type: ignore[union-attr]
    assert [type(p.flags) for p in rows] == [int] * 5  # type: ignore[union-attr]
    assert [p.flags for p in rows] == [0, 1, 0, 1, 0]  # type: ignore[union-attr]
    assert m.decode_pose_rows(b"") == []


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["good", "nan", "version", "far", "short"]), max_size=20))
def test_few_rows_and_many_rows_decode_alike_row_by_row(kinds: list[str]) -> None:
    """A handful of rows is unpacked row by row, more go through numpy (`FEW_ROWS`): either
    way each row is what `decode_pose` makes of it, or None where it refuses it."""
    good = m.encode_pose(_pose(3, 100.0, x=-7.25))
    nan = bytearray(good)
    nan[16:20] = b"\x00\x00\xc0\x7f"  # x = NaN
    bad = {"nan": bytes(nan), "version": b"\x09" + good[1:], "far": m.encode_pose(_pose(1, 2e12))}
    # a row one byte short misaligns every row after it: the whole batch is refused
    rows = [good[:-1] if k == "short" else bad.get(k, good) for k in kinds]
    if "short" in kinds:
        with pytest.raises(m.MessageError, match="not a multiple of 64"):
            m.decode_pose_rows(b"".join(rows))
        return
    assert m.decode_pose_rows(b"".join(rows)) == [
        m.decode_pose(good) if k == "good" else None for k in kinds
    ]


def test_a_digest_whose_ids_and_rows_disagree_is_refused_naming_both() -> None:
    wire = m.POSE_DIGEST.encode(m.PoseDigest(1, ["a", "b"], m.encode_pose(_pose(1, 1.0))))
    with pytest.raises(m.MessageError, match="2 ids but 64 bytes"):
        m.POSE_DIGEST.decode(wire)
    too_many = m.PoseDigest(1, ["a"] * (m.DIGEST_MAX_POSES + 1), b"")
    with pytest.raises(m.MessageError, match="length <= 4096"):
        m.POSE_DIGEST.decode(m.POSE_DIGEST.encode(too_many))


def test_the_digest_key_is_verbatim_and_parses() -> None:
    import zenoh

    digest = zenoh.KeyExpr(K.pose_digest)
    assert not zenoh.KeyExpr(K.everything).intersects(digest)  # a recorder takes no copy
    assert not zenoh.KeyExpr(K.prefix + "/world/*").intersects(digest)
    assert parse(K.pose_digest).channel == "@egos"


def test_pose_digest_with_an_interest_radius_is_a_settings_error() -> None:
    with pytest.raises(ValueError, match="interest_radius_m: 0"):
        NodeSettings(node_id="n", pose_digest=True)
    NodeSettings(node_id="n", pose_digest=True, interest_radius_m=0)
    NodeSettings(node_id="n", pose_digest=True, actor_kind="")  # an observer hears it all


# ------------------------------------------------------------------ live


def _digest_observer(
    cluster: Cluster, node_id: str = "obs"
) -> tuple[NodeClient, list[int], dict[str, list[int]]]:
    """An observer on the digest; the sizes of the pose batches it was handed, and the
    sequence numbers in them by sender."""
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    settings = NodeSettings(
        node_id=node_id, session="t", kind="observer", actor_kind="", pose_digest=True
    )
    client = NodeClient(session, settings, MonotonicClock())
    sizes: list[int] = []
    seqs: dict[str, list[int]] = {}
    push_digest = client.world.intake.pose_rows

    def noted(ids: list[str], rows: bytes, rx_t: float) -> None:
        sizes.append(len(ids))
        for sender, seq in zip(ids, m.pose_stamps(rows)[0].tolist(), strict=True):
            seqs.setdefault(sender, []).append(seq)
        push_digest(ids, rows, rx_t)

    client.world.intake.pose_rows = noted  # type: ignore[method-assign]
    client.start()
    cluster.sessions.append(client)
    return client, sizes, seqs


def test_an_observer_on_the_digest_hears_every_node_and_the_relay_idles_without_one(
    cluster: Cluster,
) -> None:
    cluster.router()
    authority = cluster.in_process_authority().start()
    relay = authority.digest
    assert relay is not None
    for node_id in ("a", "b", "c"):
        cluster.scripted(node_id)
    wait_until(lambda: len(authority.roster.tracks) == 3, 30, "three nodes joined")
    assert not relay.relaying and relay.poses == 0  # nobody asks: no ring, nothing relayed
    relay.period_s = 0.05  # three nodes at 50 Hz: about 7 poses in each digest

    obs, sizes, seqs = _digest_observer(cluster)

    def heard_all() -> bool:
        obs.update()
        return all(obs.world.stats.get(n) and obs.world.stats[n].count > 50 for n in "abc")

    wait_until(heard_all, 30, "the observer to hear a, b and c through the digest")
    assert relay.relaying and relay.digests > 0
    # The relay reads the authority's one pose ring now: the tick still gets every pose.
    seen = {n: authority.roster.tracks[n].last_pose.seq for n in "abc"}  # type: ignore[union-attr]
    wait_until(
        lambda: all(authority.roster.tracks[n].last_pose.seq > seen[n] + 10 for n in "abc"),  # type: ignore[union-attr]
        10, "the tick to apply newer poses while the relay reads the ring",
    )  # fmt: skip
    # Every pose the view applied came in a digest (the observer has no pose subscriber) but
    # one of each node, from the snapshot it fetched on joining; several to a sample.
    assert sum(sizes) + 3 >= sum(obs.world.stats[n].count for n in "abc")
    assert max(sizes) >= 3 and sum(sizes) / len(sizes) > 2, sizes[:20]
    for node_id in "abc":  # none lost from the first relayed on, none twice, in order
        heard = seqs[node_id]
        assert heard == list(range(heard[0], heard[0] + len(heard))), (node_id, heard)
    assert obs.counters().handler_errors == {}

    obs.close()
    wait_until(lambda: not relay.relaying, 10, "the relay to stop once its listener left")
    seen = {n: authority.roster.tracks[n].last_pose.seq for n in "abc"}  # type: ignore[union-attr]
    wait_until(
        lambda: all(authority.roster.tracks[n].last_pose.seq > seen[n] + 10 for n in "abc"),  # type: ignore[union-attr]
        10, "the tick to drain the ring itself again",
    )  # fmt: skip


def test_a_digest_not_from_the_authority_is_refused_and_bad_rows_are_counted(
    cluster: Cluster,
) -> None:
    cluster.router()
    authority = cluster.in_process_authority().start()
    cluster.scripted("a")
    wait_until(lambda: "a" in authority.roster.tracks, 30, "a joined")
    obs, _, _ = _digest_observer(cluster)
    wait_until(lambda: obs.update() and "a" in obs.world.egos, 30, "a through the digest")

    # An outsider's digest: well formed, but not stamped by the joined authority.
    outsider = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(outsider)
    ghost = m.PoseDigest(1, ["a"], m.encode_pose(_pose(9, time.time(), x=500.0)))

    def forged() -> bool:
        outsider.put(K.pose_digest, m.POSE_DIGEST.encode(ghost))
        return obs.inbound.rejected["digest/not_from_authority"] > 0

    wait_until(forged, 10, "the forged digest to be refused", poll=0.2)

    # The authority's own session puts one good row and one NaN row for `a`.
    nan = bytearray(m.encode_pose(_pose(7, time.time())))
    nan[16:20] = b"\x00\x00\xc0\x7f"
    session = authority.session
    before = obs.dropped["pose"]
    rows = m.encode_pose(_pose(8, time.time(), x=123.0)) + bytes(nan)
    mixed = m.POSE_DIGEST.encode(m.PoseDigest(1, ["a", "a"], rows))
    session.put(K.pose_digest, mixed, timestamp=session.new_timestamp())
    # counted where the rows are checked: the world view's update, on the node's thread
    wait_until(lambda: obs.update() and obs.dropped["pose"] > before, 10, "the NaN row counted")
    assert obs.dropped["pose"] == before + 1
    xs = wait_until(
        lambda: obs.update() and [p.x for p in obs.world.egos["a"]._poses if p.x == 123.0], 5,
        "the good row in a's buffer",
    )  # fmt: skip
    assert xs and 500.0 not in [p.x for p in obs.world.egos["a"]._poses]  # not the outsider's
    assert obs.counters().handler_errors == {}


def test_a_node_asking_for_the_digest_hears_poses_from_an_authority_that_relays_none(
    cluster: Cluster,
) -> None:
    cluster.router()
    authority = cluster.authority("--digest-ms", "0")
    cluster.scripted("a")
    obs, sizes, _ = _digest_observer(cluster)
    obs.wait_joined(30)
    wait_until(lambda: obs.update() and "a" in obs.world.stats, 30, "a on its own pose key")
    assert obs.inbound.pose_feed_kind == "poses" and sizes == []
    count = obs.world.stats["a"].count
    wait_until(lambda: obs.update() and obs.world.stats["a"].count > count + 25, 10, "a alive")
    assert authority.alive()


def test_stats_on_the_digest_reports_every_node(cluster: Cluster) -> None:
    cluster.router()
    cluster.authority()
    for node_id in ("car-1", "car-2"):
        cluster.scripted(node_id, None, "--duration", "8")
    stats = cluster.start("stats", "--session", "t", "--connect", cluster.endpoint,
                          "--pose-digest", "--duration", "5", "--json", name="stats")  # fmt: skip
    assert stats.wait(60) == 0, stats.output()
    observed = stats.json()
    for node_id in ("car-1", "car-2"):
        row = observed["nodes"][node_id]
        assert row["samples"] > 100 and row["rate_hz"] > 40, (node_id, row)
    assert "relays no pose digest" not in stats.output()
    assert observed["handler_errors"] == {}


def test_a_step_with_more_poses_than_a_digest_holds_puts_several_in_order() -> None:
    import zenoh

    from carlaverse.authority.pose_digest import PoseDigestRelay
    from carlaverse.authority.pose_intake import RING_CAPACITY, PoseIntake
    from carlaverse.support.tally import Tally

    session = open_session(FabricSettings(mode="peer", listen=[], connect=[]))
    try:
        got: list[m.PoseDigest] = []
        session.declare_subscriber(
            K.pose_digest, lambda s: got.append(m.POSE_DIGEST.decode(s.payload.to_bytes()))
        )
        drops = Tally()
        ring = zenoh.handlers.RingChannel(RING_CAPACITY)
        intake = PoseIntake(session.declare_subscriber(K.all_ego("pose"), ring), drops)
        relay = PoseDigestRelay(session, K, intake, drops, session.new_timestamp)  # by hand
        wait_until(lambda: relay.step() == 0 and relay.relaying, 5, "the relay to see its reader")
        total = m.DIGEST_MAX_POSES + 904
        for seq in range(total):
            session.put(K.pose(f"n{seq % 7}", "t0_0"), m.encode_pose(_pose(seq, 100.0 + seq)))
        session.put(K.pose("n0", "t0_0"), b"short")  # counted, left out
        relayed = [relay.step()]  # local puts reach the ring at once; a deadline all the same
        wait_until(lambda: sum(relayed) == total or relayed.append(relay.step()), 5, "all relayed")
        assert sum(relayed) == total and drops["pose"] == 1
        wait_until(lambda: len(got) == 2, 5, "two digests")
        assert [len(d.ids) for d in got] == [m.DIGEST_MAX_POSES, 904]
        assert [d.seq for d in got] == [1, 2]
        seqs = [p.seq for d in got for p in d.poses()]  # type: ignore[union-attr]
        assert seqs == list(range(total))
        # The tick takes the same poses, once each, in order, from what the relay handed on.
        assert [p.seq for _, p in intake.drain()] == list(range(total))
        assert intake.drain() == []
        relay.close()
    finally:
        session.close()
