"""The FFB server over real UDP on 127.0.0.1 with the `log` actuator."""

from __future__ import annotations

import logging
import random
import time
from collections.abc import Callable, Iterator

import pytest

from carlaverse.hal import ffb_packet
from carlaverse.hal.ffb_packet import ZERO_COMMAND, FfbCommand
from carlaverse.hal.ffb_server import FfbServer, LogActuator
from carlaverse.hal.ffb_server.actuator import LogActuatorOptions
from tests.hal.helpers import ManualClock, Sender
from tests.support import wait_until

FAST = 0.001  # [s] condition poll period


def push(command: FfbCommand) -> bytes:
    return ffb_packet.encode(command)


@pytest.fixture
def serve() -> Iterator[Callable[..., tuple[FfbServer, LogActuator, Sender]]]:
    started: list[tuple[FfbServer, Sender]] = []

    def start(clock: Callable[[], float] = time.monotonic, watchdog_s: float = 0.25, **kw):
        actuator = LogActuator(LogActuatorOptions(), clock=clock)
        server = FfbServer(actuator, "127.0.0.1", 0, watchdog_s=watchdog_s, clock=clock, **kw)
        server.start()
        sender = Sender(server.address)
        started.append((server, sender))
        return server, actuator, sender

    yield start
    for server, sender in started:
        server.stop()
        sender.close()


def send_all(server: FfbServer, sender: Sender, packets: list[bytes], batch: int = 50) -> None:
    """Send in batches, waiting until the server has read each batch, so none is lost to a
    full socket buffer and the counters can be compared exactly."""
    base = server.stats.received
    for start in range(0, len(packets), batch):
        chunk = packets[start : start + batch]
        for packet in chunk:
            sender.send(packet)
        target = base + start + len(chunk)
        wait_until(lambda t=target: server.stats.received >= t, 5, f"{target} received", FAST)


def test_packets_are_applied_in_order(serve) -> None:
    server, actuator, sender = serve()
    commands = [FfbCommand(constant_force=i * 37 - 5000, damper=i) for i in range(300)]
    send_all(server, sender, [push(c) for c in commands])
    assert actuator.applied() == commands
    assert server.stats.applied == 300
    assert server.stats.invalid == 0


def test_watchdog_zeroes_all_forces_on_a_manual_clock(serve) -> None:
    clock = ManualClock()
    server, actuator, sender = serve(clock=clock, watchdog_s=0.25)
    strong = FfbCommand(
        spring_stiffness=8000, spring_offset=3000, spring_deadband=100, spring_saturation=9000,
        constant_force=-4000, damper=2000, friction=1500, inertia=1000,
        vibration_magnitude=3000, vibration_frequency_hz=40,
    )  # fmt: skip
    sender.send(push(strong))
    wait_until(lambda: server.stats.applied == 1, 5, "first packet", FAST)
    last_packet_t = clock()

    clock.advance(0.249)
    ticks = server.ticks
    wait_until(lambda: server.ticks >= ticks + 3, 5, "the loop to look again", FAST)
    assert actuator.current == strong and server.stats.watchdog_trips == 0

    clock.advance(0.002)
    wait_until(lambda: server.stats.watchdog_trips == 1, 5, "watchdog", FAST)
    assert actuator.current == ZERO_COMMAND and actuator.current.is_zero()
    zero_event = actuator.events[-1]
    assert zero_event.kind == "zero"
    assert zero_event.t - last_packet_t <= 0.25 + 0.020

    # Forces resume only with the next valid packet, and the watchdog re-arms.
    clock.advance(5.0)
    ticks = server.ticks
    wait_until(lambda: server.ticks >= ticks + 3, 5, "more ticks", FAST)
    assert server.stats.watchdog_trips == 1 and actuator.current == ZERO_COMMAND
    sender.send(push(FfbCommand(constant_force=100)))
    wait_until(lambda: server.stats.applied == 2, 5, "resume", FAST)
    assert actuator.current == FfbCommand(constant_force=100)
    clock.advance(0.3)
    wait_until(lambda: server.stats.watchdog_trips == 2, 5, "second watchdog", FAST)


def test_watchdog_with_the_real_clock(serve) -> None:
    server, actuator, sender = serve(watchdog_s=0.100)
    for i in range(5):
        sender.send(push(FfbCommand(constant_force=1000 + i)))
    wait_until(lambda: server.stats.applied == 5, 5, "packets", FAST)
    wait_until(lambda: server.stats.watchdog_trips == 1, 5, "watchdog", FAST)
    events = list(actuator.events)
    last_apply = [e for e in events if e.kind == "apply"][-1]
    zero = events[-1]
    assert zero.kind == "zero"
    assert 0.100 <= zero.t - last_apply.t <= 0.100 + 0.020


def test_a_client_that_zeroes_itself_trips_no_watchdog(serve) -> None:
    clock = ManualClock()
    server, actuator, sender = serve(clock=clock)
    sender.send(push(FfbCommand(damper=10)))
    sender.send(push(ZERO_COMMAND))
    wait_until(lambda: server.stats.applied == 2, 5, "packets", FAST)
    clock.advance(1.0)
    ticks = server.ticks
    wait_until(lambda: server.ticks >= ticks + 3, 5, "ticks", FAST)
    assert server.stats.watchdog_trips == 0 and actuator.current == ZERO_COMMAND


def random_datagrams(count: int, seed: int) -> list[bytes]:
    rng = random.Random(seed)
    out = []
    for _ in range(count):
        size = 40 if rng.random() < 0.5 else rng.randrange(0, 120)
        out.append(rng.randbytes(size))
    return out


def test_ten_thousand_random_datagrams_apply_nothing(serve, caplog) -> None:
    caplog.set_level(logging.WARNING, logger="carlaverse.hal.ffb_server")
    server, actuator, sender = serve()
    datagrams = random_datagrams(10_000, seed=3)
    valid = 0
    for d in datagrams:
        try:
            ffb_packet.decode(d)
            valid += 1
        except ffb_packet.FfbPacketError:
            pass
    assert valid == 0  # random int32s land in 0..10000 with p ≈ 2e-6 per field
    send_all(server, sender, datagrams, batch=100)

    s = server.stats
    assert s.received == 10_000 and s.applied == 0
    assert s.wrong_size == sum(len(d) != 40 for d in datagrams)
    assert s.out_of_range == sum(len(d) == 40 for d in datagrams)
    assert s.invalid == 10_000 and s.device_errors == 0
    assert actuator.applied() == [] and actuator.current == ZERO_COMMAND
    assert server.running
    rejected = [r for r in caplog.records if "rejected" in r.getMessage()]
    assert 1 <= len(rejected) <= 20  # rate-limited, not 10^4 lines

    sender.send(push(FfbCommand(friction=42)))  # still serving
    wait_until(lambda: server.stats.applied == 1, 5, "valid packet after the flood", FAST)


def test_bad_packets_are_logged_at_a_bounded_rate(serve, caplog) -> None:
    caplog.set_level(logging.WARNING, logger="carlaverse.hal.ffb_server")
    clock = ManualClock()
    server, _, sender = serve(clock=clock)
    send_all(server, sender, [b"short"] * 30)
    clock.advance(1.5)
    send_all(server, sender, [b"short"] * 30 + [b"\xff" * 40])
    messages = [r.getMessage() for r in caplog.records if "rejected" in r.getMessage()]
    assert len(messages) == 3  # one per size burst per interval, one for the range error
    assert "29 more like this" in messages[1]
    assert server.stats.wrong_size == 60 and server.stats.out_of_range == 1


def test_stop_zeroes_and_closes_the_actuator(serve) -> None:
    server, actuator, sender = serve()
    sender.send(push(FfbCommand(constant_force=500)))
    wait_until(lambda: server.stats.applied == 1, 5, "packet", FAST)
    server.stop()
    assert not server.running
    assert actuator.events[-1].kind == "zero" and actuator.current == ZERO_COMMAND
    assert actuator.closed


class FailingActuator(LogActuator):
    """A device that has been unplugged: every write fails as the kernel would report it."""

    def _apply(self, command: FfbCommand) -> None:
        raise OSError(19, "No such device")


def test_device_errors_are_counted_not_raised(caplog) -> None:
    actuator = FailingActuator(LogActuatorOptions())
    with FfbServer(actuator, "127.0.0.1", 0) as server:
        sender = Sender(server.address)
        send_all(server, sender, [push(FfbCommand(damper=1))] * 5)
        assert server.stats.device_errors == 5 and server.stats.applied == 0
        assert server.running
        sender.close()
