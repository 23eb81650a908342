"""The motion server over real UDP on 127.0.0.1 with the `log` and `csv` platforms."""

from __future__ import annotations

import csv
import logging
import random
import struct
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from carlaverse.hal import motion_packet
from carlaverse.hal.motion_packet import NEUTRAL_FRAME, MotionFrame, MotionLimits
from carlaverse.hal.motion_server import LogPlatform, MotionServer
from carlaverse.hal.motion_server.csv_platform import CsvPlatform, CsvPlatformOptions
from carlaverse.hal.motion_server.platform import LogPlatformOptions
from tests.hal.helpers import ManualClock, Sender
from tests.support import wait_until

FAST = 0.001  # [s]


@pytest.fixture
def serve() -> Iterator[Callable[..., tuple[MotionServer, LogPlatform, Sender]]]:
    started: list[tuple[MotionServer, Sender]] = []

    def start(clock: Callable[[], float] = time.monotonic, **kw):
        platform = LogPlatform(LogPlatformOptions(), clock=clock)
        server = MotionServer(platform, "127.0.0.1", 0, clock=clock, **kw).start()
        sender = Sender(server.address)
        started.append((server, sender))
        return server, platform, sender

    yield start
    for server, sender in started:
        server.stop()
        sender.close()


def send_all(server: MotionServer, sender: Sender, packets: list[bytes], batch: int = 50) -> None:
    base = server.stats.received
    for start in range(0, len(packets), batch):
        chunk = packets[start : start + batch]
        for packet in chunk:
            sender.send(packet)
        target = base + start + len(chunk)
        wait_until(lambda t=target: server.stats.received >= t, 5, f"{target} received", FAST)


def test_frames_are_applied_in_order(serve) -> None:
    server, platform, sender = serve()
    frames = [
        MotionFrame(roll=i * 1e-3, pitch=-i * 1e-3, heave=0.001, rpm=800 + i) for i in range(200)
    ]
    send_all(server, sender, [motion_packet.encode(f) for f in frames])
    expected = [motion_packet.decode(motion_packet.encode(f)) for f in frames]  # float32
    assert platform.frames() == expected
    assert server.stats.frames == 200 and server.stats.ignored == 0


def test_short_packets_are_warned_and_ignored(serve, caplog) -> None:
    caplog.set_level(logging.WARNING, logger="carlaverse.hal.motion_server")
    server, platform, sender = serve()
    good = motion_packet.encode(MotionFrame(roll=0.1))
    send_all(server, sender, [good[:17], good[:1], b""])
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert any("ignored" in r.getMessage() and "17 bytes" in r.getMessage() for r in warnings)
    assert server.stats.short == 3 and server.stats.frames == 0
    assert platform.frames() == [] and platform.current == NEUTRAL_FRAME


def test_unknown_commands_long_packets_and_bad_values_are_counted(serve) -> None:
    server, platform, sender = serve(limits=MotionLimits(heave_m=0.1))
    packets = [
        b"\x01" + bytes(20),  # unknown command id
        b"\x7f",
        motion_packet.encode(MotionFrame()) + b"\x00",  # long
        struct.pack("<B5f", 4, 0, 0, 0.5, 0, 0),  # heave over the configured limit
        struct.pack("<B5f", 4, float("nan"), 0, 0, 0, 0),
    ]
    send_all(server, sender, packets)
    s = server.stats
    assert (s.unknown_command, s.long, s.invalid_value, s.frames) == (2, 1, 2, 0)
    assert platform.frames() == []


def test_watchdog_returns_the_platform_to_neutral(serve) -> None:
    clock = ManualClock()
    server, platform, sender = serve(clock=clock, watchdog_s=0.25)
    sender.send(motion_packet.encode(MotionFrame(roll=0.2, heave=0.05)))
    wait_until(lambda: server.stats.frames == 1, 5, "frame", FAST)
    clock.advance(0.2)
    ticks = server.ticks
    wait_until(lambda: server.ticks >= ticks + 3, 5, "ticks", FAST)
    assert platform.current.roll != 0 and server.stats.neutral_events == 0
    clock.advance(0.06)
    wait_until(lambda: server.stats.neutral_events == 1, 5, "neutral", FAST)
    assert platform.current == NEUTRAL_FRAME and platform.events[-1].kind == "neutral"
    assert platform.events[-1].t - platform.events[-2].t <= 0.25 + 0.020


def test_random_datagrams_are_counted_and_only_valid_frames_move(serve) -> None:
    server, platform, sender = serve()
    rng = random.Random(5)
    datagrams = [rng.randbytes(rng.choice([21, rng.randrange(0, 60)])) for _ in range(2000)]
    send_all(server, sender, datagrams, batch=100)
    accepted = []
    for d in datagrams:
        try:
            accepted.append(motion_packet.decode(d))
        except motion_packet.MotionPacketError:
            pass
    s = server.stats
    assert s.received == 2000 and s.frames == len(accepted) and s.frames + s.ignored == 2000
    assert platform.frames() == accepted
    assert server.running


def test_csv_platform_writes_timestamped_rows(tmp_path: Path) -> None:
    clock = ManualClock(start=10.0)
    path = tmp_path / "motion.csv"
    platform = CsvPlatform(CsvPlatformOptions(path=str(path)), clock=clock)
    server = MotionServer(platform, "127.0.0.1", 0, clock=clock, watchdog_s=0.25).start()
    sender = Sender(server.address)
    try:
        send_all(server, sender, [motion_packet.encode(MotionFrame(pitch=0.125, rpm=900))])
        clock.advance(0.3)
        wait_until(lambda: server.stats.neutral_events == 1, 5, "neutral", FAST)
    finally:
        server.stop()
        sender.close()
    rows = list(csv.DictReader(path.read_text().splitlines()))
    assert [r["kind"] for r in rows] == ["frame", "neutral", "neutral"]  # watchdog, then stop
    assert float(rows[0]["t_s"]) == 10.0 and float(rows[0]["pitch"]) == 0.125
    assert float(rows[0]["rpm"]) == 900 and float(rows[1]["t_s"]) == pytest.approx(10.3)
    assert float(rows[0]["unix_time_s"]) > 1.6e9
