"""Replay a recording into a new session: same messages, same order, original timing."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
import zenoh

from carlaverse import cli, messages
from carlaverse.keys import Keys, parse
from carlaverse.recording.reading import RecordedSample, iter_samples
from carlaverse.recording.recorder import Recorder
from carlaverse.recording.replay import Replayer, is_command
from carlaverse.recording.replay import wait_until as wait_deadline
from carlaverse.recording.sink import McapSink
from carlaverse.transport.session import FabricSettings, open_session
from tests.recording.conftest import World
from tests.support import wait_until

LATE_S = 0.02  # [s] a replayed sample this much later than the earliest did not come on time


def _record(world: World, path: Path, seconds: float) -> None:
    session = world.connect()
    recorder = Recorder(session, Keys("rec"), McapSink(path, monotonic=time.monotonic))
    try:
        recorder.start()
        world.wait_matched()
        world.publish_for(seconds)
        total = sum(world.synthetic.published.values())
        wait_until(lambda: recorder.stats().received >= total, 10, f"{total} samples")
        recorder.stop()
    finally:
        session.close()


def test_replay_keeps_payloads_order_and_timing(world: World, tmp_path: Path) -> None:
    path = tmp_path / "session.mcap"
    _record(world, path, 2.0)
    recorded = [s for s in iter_samples(path) if parse(s.key).area not in ("authority", "node")]

    arrivals: list[tuple[float, str, bytes]] = []
    observer = world.connect()
    sub = observer.declare_subscriber(
        Keys("again").everything,
        lambda s: arrivals.append((time.perf_counter(), str(s.key_expr), s.payload.to_bytes())),
    )
    code: list[int] = []
    argv = ["replay", str(path), "--session", "again", "--with-commands"]
    argv += ["--connect", world.endpoint]
    replay = threading.Thread(target=lambda: code.append(cli.main(argv)))
    try:
        replay.start()
        wait_until(lambda: arrivals, 15, "the first replayed sample")
        # while it runs, the recorded map is served to joiners of the replayed session
        map_key = Keys("again").authority("map")
        reply = wait_until(lambda: _answer(observer, map_key), 5, "the recorded map served")
        assert messages.MAP.decode(reply).lanes
        replay.join(timeout=30)
        wait_until(lambda: len(arrivals) >= len(recorded), 5, "every replayed sample")
    finally:
        sub.undeclare()
        observer.close()
    assert code == [0]

    expected = [(Keys("rec").with_session(s.key, "again"), s.payload) for s in recorded]
    assert [(k, p) for _, k, p in arrivals] == expected  # byte-identical, same order

    # Each sample's arrival minus its recorded time: the replay's schedule plus the delay of
    # that sample. A stall of this loaded process (replayer and observer both live here)
    # only ever adds to the delay: the samples due meanwhile go out and arrive late and at
    # once. So the schedule is judged on the samples that came on time (within LATE_S of the
    # earliest), and its drift on the earliest of the first and of the last third.
    offsets = np.array([t for t, _, _ in arrivals]) - [s.log_time_ns / 1e9 for s in recorded]
    on_time = offsets - offsets.min() <= LATE_S
    assert on_time.mean() >= 0.7, f"only {on_time.mean():.0%} of the samples came on time"
    original = np.diff([s.log_time_ns / 1e9 for s in recorded])
    replayed = np.diff([t for t, _, _ in arrivals])
    error = np.abs(replayed - original)[on_time[1:] & on_time[:-1]]
    assert np.percentile(error, 95) < 0.005, f"p95 timing error {np.percentile(error, 95):.4f} s"
    third = len(offsets) // 3
    drift = offsets[-third:].min() - offsets[:third].min()
    assert abs(drift) < 0.02, f"replay drifted {drift:.4f} s over {len(recorded)} samples"


def _answer(session: zenoh.Session, key: str) -> bytes | None:
    for reply in session.get(key, timeout=1):
        if reply.ok is not None:
            return reply.ok.payload.to_bytes()
    return None


def test_precise_wait_with_a_manual_clock() -> None:
    now = [0.0]
    sleeps: list[float] = []

    def sleep(dt: float) -> None:
        sleeps.append(dt)
        now[0] += dt

    def clock() -> float:
        now[0] += 0.00001  # each look at the clock costs a little time
        return now[0]

    assert wait_deadline(0.2, clock, sleep, threading.Event(), spin_s=0.001)
    assert now[0] >= 0.2
    assert max(sleeps) <= 0.05, "wakes up at least every 50 ms to notice stop"
    assert 0.001 <= 0.2 - sum(sleeps) <= 0.0012, "the last millisecond is spun, not slept"
    stop = threading.Event()
    stop.set()
    assert not wait_deadline(now[0] + 1.0, clock, sleep, stop)


def test_unknown_keys_are_skipped_and_counted() -> None:
    session = open_session(FabricSettings())
    try:
        replayer = Replayer(session, "x")
        samples = [RecordedSample("carlaverse/rec/future/thing", b"1", "put", 0, 0, {})]
        stats = replayer.run(lambda: samples, threading.Event())
        replayer.close()
    finally:
        session.close()
    assert stats.skipped == 1 and stats.published == 0


def test_by_default_a_replay_goes_to_a_new_session_and_sends_no_commands(
    world: World, tmp_path: Path
) -> None:
    path = tmp_path / "session.mcap"
    _record(world, path, 2.5)  # the synthetic world collides every 2 s: impulses recorded
    recorded = [s for s in iter_samples(path) if parse(s.key).area not in ("authority", "node")]
    commands = [s for s in recorded if is_command(s.key)]
    assert commands, "the recording holds impulses to withhold"

    arrivals: list[str] = []
    observer = world.connect()
    subs = [
        observer.declare_subscriber(
            Keys(name).everything, lambda s: arrivals.append(str(s.key_expr))
        )
        for name in ("rec", "rec-replay")
    ]
    try:
        code = cli.main(["replay", str(path), "--connect", world.endpoint])
        wait_until(lambda: len(arrivals) >= len(recorded) - len(commands), 5, "the replay")
    finally:
        for sub in subs:
            sub.undeclare()
        observer.close()
    assert code == 0
    expected = [Keys("rec").with_session(s.key, "rec-replay") for s in recorded]
    assert arrivals == [k for k in expected if not is_command(k)]  # only rec-replay, no commands


def test_help_says_how_to_replay_into_the_recorded_session(capsys: Any) -> None:
    with pytest.raises(SystemExit):
        cli.main(["replay", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "default: <recorded>-replay" in text and "name it here explicitly" in text
    assert "--with-commands" in text


def test_served_configs_are_redacted_even_from_an_old_recording() -> None:
    secret = "pw-from-an-old-node-42"
    config = yaml.safe_dump({"fabric": {"zenoh": {"transport/auth/usrpwd/password": secret}}})
    payload = messages.CONFIGS.encode(messages.ConfigsReply(messages.SCHEMA_VERSION, {"n": config}))
    key = Keys("rec").authority("configs")
    session = open_session(FabricSettings())
    try:
        replayer = Replayer(session, "served")
        replayer.run(lambda: [RecordedSample(key, payload, "put", 0, 0, {})], threading.Event())
        served = _answer(session, Keys("served").authority("configs"))
        replayer.close()
    finally:
        session.close()
    assert served is not None and secret.encode() not in served
    assert "<redacted>" in messages.CONFIGS.decode(served).nodes["n"]
