"""The replay's stand-in authority, in one process: its clock, its snapshot, who it admits,
a world view that follows a looping replay's next pass, and no replay beside a live
authority."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zenoh

from carlaverse import messages as m
from carlaverse.cli import main
from carlaverse.cli.exit_codes import Exit
from carlaverse.keys import Keys
from carlaverse.recording.reading import RecordedSample
from carlaverse.recording.replay import Replayer
from carlaverse.recording.replay_clock import ReplayClock
from carlaverse.recording.sink import McapSink
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import JoinRefused, NodeClient
from carlaverse.transport.session import FabricSettings, open_session
from carlaverse.transport.settings import NodeSettings
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.world_view import WorldView
from tests.support import free_port

RECORDED = Keys("rec")
TARGET = Keys("rec-replay")
OFFSET_NS = 1_700_000_000 * 10**9  # the recorder's log time minus session time


def test_the_clock_tells_recorded_time_held_or_running() -> None:
    local = [5.0]
    clock = ReplayClock(speed=2.0, local=lambda: local[0])
    clock.hold(100.0)
    local[0] = 9.0
    assert clock.now() == 100.0 and not clock.running  # held: local time does not count
    clock.start_pass(100.0, local_t=10.0)
    local[0] = 12.5
    assert clock.now() == pytest.approx(105.0)  # 100 s + 2.5 s of local time at 2x
    clock.stop()
    local[0] = 20.0
    assert clock.now() == pytest.approx(105.0) and clock.timeline == 1


def _pose(seq: int, t: float) -> bytes:
    """Along x at 10 m/s: x = 10 t."""
    return m.POSE.encode(m.Pose(seq, t, 10.0 * t, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0))


def _samples() -> list[RecordedSample]:
    """0.2 s of a recording: car-1 spawns and drives, at session times 50.00 ... 50.20 s."""
    spawned = m.WORLD_EVENT.encode(m.Spawned(1, 50.0, "car-1", "drive", "car"))
    out = [RecordedSample(RECORDED.world("events"), spawned, "put", OFFSET_NS + 50 * 10**9,
                          50 * 10**9, {})]  # fmt: skip
    for k in range(11):
        t_ns = 50 * 10**9 + k * 20 * 10**6
        key = RECORDED.pose("car-1", "t0_0")
        out.append(RecordedSample(key, _pose(k + 1, t_ns / 1e9), "put", OFFSET_NS + t_ns, t_ns, {}))
    return out


@pytest.fixture
def session() -> Iterator[zenoh.Session]:
    session = open_session(FabricSettings())
    try:
        yield session
    finally:
        session.close()


def _ask(session: zenoh.Session, query: str, payload: bytes = b"") -> bytes:
    for reply in session.get(TARGET.authority(query), payload=payload, timeout=2):
        assert reply.ok is not None, reply.err.payload.to_bytes()
        return reply.ok.payload.to_bytes()
    raise AssertionError(f"no answer to {query}")


def _clock(session: zenoh.Session) -> m.ClockReply:
    return m.CLOCK_REPLY.decode(_ask(session, "clock", m.CLOCK_REQUEST.encode(m.ClockRequest())))


def test_clock_and_snapshot_answer_the_recorded_moment(session: zenoh.Session) -> None:
    replayer = Replayer(session, TARGET.session, session_offset_ns=OFFSET_NS)
    try:
        replayer.prepare({}, start_t=49.5)  # the recording starts before the first pose
        held = m.CLOCK_REPLY.decode(
            _ask(session, "clock", m.CLOCK_REQUEST.encode(m.ClockRequest()))
        )
        replayer.run(_samples, threading.Event())
        ended = m.CLOCK_REPLY.decode(
            _ask(session, "clock", m.CLOCK_REQUEST.encode(m.ClockRequest()))
        )
        snapshot = m.SNAPSHOT.decode(_ask(session, "snapshot"))
    finally:
        replayer.close()
    assert held.t == 49.5
    # log time - offset = session time; the pass ended at its last sample, 50.20 s
    assert ended.t == pytest.approx(50.2, abs=0.01)
    assert snapshot.t == pytest.approx(50.2, abs=0.01)
    [ego] = snapshot.egos
    assert (ego.node_id, ego.kind, ego.actor_kind) == ("car-1", "drive", "car")
    assert (
        ego.pose is not None
        and ego.pose.t == pytest.approx(50.2)
        and ego.pose.x == pytest.approx(502.0)
    )


def _client(session: zenoh.Session, node_id: str, actor_kind: str) -> NodeClient:
    kind = "observer" if not actor_kind else "drive"
    settings = NodeSettings(node_id=node_id, session=TARGET.session, kind=kind,
                            actor_kind=actor_kind)  # fmt: skip
    return NodeClient(session, settings, MonotonicClock()).start()


def test_only_observers_join_a_replay(session: zenoh.Session) -> None:
    replayer = Replayer(session, TARGET.session, session_offset_ns=OFFSET_NS)
    replayer.prepare({}, start_t=49.5)
    watcher, driver = _client(session, "watch", ""), _client(session, "drive-1", "car")
    try:
        assert watcher.wait_joined(10)
        with pytest.raises(JoinRefused, match="only observers join it"):
            driver.wait_joined(10)
        request = m.CLOCK_REQUEST.encode(m.ClockRequest("watch"))
        assert m.CLOCK_REPLY.decode(_ask(session, "clock", request)).known
        assert watcher.join_reply is not None
        assert watcher.join_reply.authority_instance == str(session.zid())
    finally:
        watcher.close()
        driver.close()
        replayer.close()
    assert replayer.stats.published == 0


def test_a_world_view_follows_a_replay_that_starts_over() -> None:
    """Pass 1 drives car-1 from x = 0 to 30 m (t = 0 ... 3 s); pass 2 starts at t = 0 again,
    announced by a despawn and a new spawn. The view draws pass 2's car where pass 2 puts it
    (it kept pass 1's newest time before and refused every older pose), and the NPCs too."""
    view = WorldView("me", InterpolationSettings(render_mode="past"))
    intake = view.intake
    npcs = np.zeros(1, dtype=m.NPC_DTYPE)
    for lap in range(2):
        intake.present("car-1")
        for k in range(151):  # 50 Hz for 3 s, each received at its own time
            t = k / 50
            intake.pose("car-1", _pose(k + 1, t), t)
            npcs["x"] = -10.0 * t
            intake.npc(m.NpcBatch.pack(k + 1, t, ["npc-1"], npcs), t)
            view.update(t)
            if lap == 1 and k == 100:
                break
        if lap == 0:
            intake.gone("car-1", "authority", 3.0)
    [car] = list(view.ego_views(2.0))
    render_t = view.render_time(2.0)
    assert render_t < 2.0
    assert car.x == pytest.approx(10.0 * render_t, abs=0.01)  # on pass 2's path, at its time
    frame = view.npc_frame(2.0)
    assert frame is not None and frame.x[0] == pytest.approx(-10.0 * render_t, abs=0.01)


def test_a_replay_does_not_answer_beside_a_live_authority(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Both would answer every join: a live driving node could be refused by the replay."""
    path = tmp_path / "rec.mcap"
    sink = McapSink(path, monotonic=time.monotonic)
    for sample in _samples():
        sink.write(sample.key, sample.payload, sample.log_time_ns)
    sink.close()
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    live = open_session(FabricSettings(listen=[endpoint]))
    token = live.liveliness().declare_token(Keys("lab").node("authority"))
    try:
        code = main(["replay", str(path), "--session", "lab", "--connect", endpoint])
    finally:
        token.undeclare()
        live.close()
    assert code == Exit.USAGE
    said = capsys.readouterr().err.splitlines()[-1]
    assert said.startswith("carlaverse replay: session 'lab' has a live authority") and (
        "pass --no-queries" in said
    ), said
