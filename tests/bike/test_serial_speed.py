"""The ESP32 wheel-speed line protocol, through a real pty pair; unplug and replug."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.hal import open_speed_sensor

pytest.importorskip("serial", reason="pip install 'carlaverse[bike]'")
from carlaverse.hal.speed_sensor.serial_esp32 import (
    LineError,
    SerialSpeedSensor,
    format_line,
    parse_line,
)
from tests.support import wait_until


def test_a_line_field_by_field() -> None:
    raw = format_line(17, 5230, 102.25, 6944)
    body = "WS,17,5230,102.250,6944"
    xor = 0
    for byte in body.encode():
        xor ^= byte
    assert raw == f"${body}*{xor:02X}\n".encode()
    line = parse_line(raw)
    assert (line.seq, line.t_ms, line.revolutions, line.speed_mps) == (17, 5230, 102.25, 6.944)


@pytest.mark.parametrize(
    ("raw", "why"),
    [
        (b"WS,1,2,3.0,4*00\n", "no \\$"),
        (b"$WS,1,2,3.000,4*00\n", "checksum"),
        (format_line(1, 2, 3.0, 4).replace(b"WS", b"XS"), "checksum"),
        (b"\xff\xfe\n", "ASCII"),
    ],
)
def test_bad_lines_say_why(raw: bytes, why: str) -> None:
    with pytest.raises(LineError, match=why):
        parse_line(raw)


@given(st.integers(0, 2**32 - 1), st.integers(0, 2**32 - 1), st.integers(0, 10**6),
       st.integers(0, 40000))  # fmt: skip
def test_lines_round_trip(seq: int, t_ms: int, milli_revs: int, speed_mm_s: int) -> None:
    line = parse_line(format_line(seq, t_ms, milli_revs / 1000, speed_mm_s))
    assert (line.seq, line.t_ms, line.speed_mps) == (seq, t_ms, speed_mm_s / 1000)
    assert line.revolutions == pytest.approx(milli_revs / 1000, abs=1e-9)


@given(st.binary(max_size=60))
def test_any_bytes_parse_or_raise_line_error(raw: bytes) -> None:
    try:
        parse_line(raw)
    except LineError:
        pass


class FakeEsp32:
    """The microcontroller's end of a pty pair, reachable under a stable symlink as udev's
    /dev/serial/by-id links are; `unplug` closes it, `replug` makes a new pty behind the link."""

    def __init__(self, link: Path) -> None:
        self.link = link
        self.master = -1
        self.slave = -1
        self.seq = 0
        self.replug()

    def replug(self) -> None:
        self.master, self.slave = os.openpty()
        if self.link.is_symlink():
            self.link.unlink()
        self.link.symlink_to(os.ttyname(self.slave))
        self.seq = 0  # it rebooted

    def unplug(self) -> None:
        os.close(self.master)
        os.close(self.slave)
        self.link.unlink()

    def send(self, revolutions: float, speed_mm_s: int, garbage: bytes = b"") -> None:
        self.seq += 1
        os.write(
            self.master, garbage + format_line(self.seq, self.seq * 5, revolutions, speed_mm_s)
        )


@pytest.fixture
def esp32(tmp_path: Path) -> Iterator[FakeEsp32]:
    device = FakeEsp32(tmp_path / "usb-Espressif_ESP32-if00")
    yield device
    for fd in (device.master, device.slave):
        try:
            os.close(fd)
        except OSError:
            pass


def test_reads_speed_and_survives_unplug_and_replug(esp32: FakeEsp32) -> None:
    sensor = open_speed_sensor(
        {"backend": "serial", "options": {"port": str(esp32.link), "stale_s": 0.3}}
    )
    assert isinstance(sensor, SerialSpeedSensor)
    try:
        wait_until(lambda: sensor.counters["opens"] == 1, 5, "the port open")
        esp32.send(10.0, 5000)
        esp32.send(10.5, 5200, garbage=b"$WS,noise*00\n")  # one bad line, then a good one
        wait_until(lambda: sensor.read().speed_mps == 5.2, 5, "5.2 m/s from the ESP32")
        assert sensor.read().revolutions == pytest.approx(10.5)
        assert sensor.counters["bad_lines"] == 1
        esp32.unplug()
        wait_until(lambda: sensor.counters["disconnects"] == 1, 5, "the unplug noticed")
        assert sensor.read().speed_mps == 0.0  # no sensor: the wheel is not assumed to turn
        esp32.replug()
        wait_until(lambda: sensor.counters["opens"] == 2, 5, "the port reopened")
        esp32.send(0.5, 3000)  # it counts from 0 again after its reboot
        wait_until(lambda: sensor.read().speed_mps == 3.0, 5, "3 m/s after the replug")
        assert sensor.read().revolutions == pytest.approx(11.0)  # 10.5 before + 0.5 after
        wait_until(lambda: sensor.read().speed_mps == 0.0, 5, "a stale sample read as still")
    finally:
        sensor.close()
