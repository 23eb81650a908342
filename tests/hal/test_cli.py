"""`carlaverse ffb-server`, `motion-server` and `doctor`: as a real process (signals) and
in-process through `carlaverse.cli.main`."""

from __future__ import annotations

import csv
import signal
import socket
import threading
from pathlib import Path

import pytest

from carlaverse.cli import main
from carlaverse.hal import ffb_packet, motion_packet
from carlaverse.hal.diagnostics import ffb_test_sequence
from carlaverse.hal.ffb_packet import FfbCommand
from carlaverse.hal.ffb_server import FfbServer, LogActuator
from carlaverse.hal.ffb_server.actuator import LogActuatorOptions
from carlaverse.hal.motion_packet import NEUTRAL_FRAME, MotionFrame
from carlaverse.hal.motion_server import LogPlatform, MotionServer
from carlaverse.hal.motion_server.platform import LogPlatformOptions
from tests.hal.helpers import Sender
from tests.support import Proc, free_port, wait_until


def test_ffb_server_process_zeroes_forces_on_sigterm() -> None:
    port = free_port()
    proc = Proc(["ffb-server", "--port", str(port), "--watchdog-ms", "100", "-v"], "ffb")
    try:
        wait_until(lambda: "listening" in proc.output(), 20, "ffb-server to listen")
        sender = Sender(("127.0.0.1", port))
        sender.send(ffb_packet.encode(FfbCommand(constant_force=1234)))
        sender.send(b"garbage")
        wait_until(lambda: "watchdog" in proc.output(), 10, "the watchdog to zero forces")
        sender.send(ffb_packet.encode(FfbCommand(constant_force=99)))
        sender.close()
        wait_until(lambda: proc.output().count("watchdog") >= 2, 10, "second watchdog")
    finally:
        code = proc.stop(signal.SIGTERM)
    out = proc.output()
    assert code == 0, out
    assert "all forces zeroed (server stopping)" in out
    assert "3 packets, 2 applied, 1 wrong size" in out


def udp_port_taken(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind(("127.0.0.1", port))
        except OSError:
            return True
    return False


def run_in_thread(argv: list[str]) -> tuple[threading.Thread, list[int]]:
    result: list[int] = []
    thread = threading.Thread(target=lambda: result.append(main(argv)), daemon=True)
    thread.start()
    return thread, result


def test_motion_server_cli_writes_csv(tmp_path: Path) -> None:
    port, path = free_port(), tmp_path / "rig.csv"
    argv = ["motion-server", "--port", str(port), "--backend", "csv", "-o", f"path={path}",
            "--duration", "1.0"]  # fmt: skip
    thread, result = run_in_thread(argv)
    wait_until(lambda: udp_port_taken(port), 10, "motion-server to bind")
    sender = Sender(("127.0.0.1", port))
    for roll in (0.01, 0.02, 0.03):
        sender.send(motion_packet.encode(MotionFrame(roll=roll)))
    sender.send(b"\x04\x00")  # short: warned and ignored
    sender.close()
    thread.join(10)
    assert result == [0]
    rows = list(csv.DictReader(path.read_text().splitlines()))
    frames = [r for r in rows if r["kind"] == "frame"]
    assert [float(r["roll"]) for r in frames] == pytest.approx([0.01, 0.02, 0.03])
    assert rows[-1]["kind"] == "neutral"


def test_server_clis_list_backends_and_explain_bad_ones(capsys) -> None:
    assert main(["motion-server", "--list-backends"]) == 0
    assert capsys.readouterr().out.split() == ["csv", "log"]
    assert main(["ffb-server", "--list-backends"]) == 0
    assert "evdev" in capsys.readouterr().out.split()
    assert main(["ffb-server", "--backend", "lgo", "--port", "0"]) == 2
    assert "Did you mean 'log'?" in capsys.readouterr().err
    assert main(["motion-server", "--backend", "csv", "--port", "0"]) == 2
    assert "path" in capsys.readouterr().err  # the csv backend needs -o path=...
    assert main(["motion-server", "-o", "novalue", "--port", "0"]) == 2
    assert "KEY=VALUE" in capsys.readouterr().err


def test_ffb_server_reports_a_busy_port(capsys) -> None:
    with FfbServer(LogActuator(LogActuatorOptions()), "127.0.0.1", 0) as server:
        port = server.address[1]
        assert main(["ffb-server", "--port", str(port)]) == 2
    assert f"cannot listen on 127.0.0.1:{port}" in capsys.readouterr().err


def test_doctor_lists_and_watches_joysticks(virtual_wheel, capsys) -> None:
    assert main(["doctor"]) == 0
    out = capsys.readouterr().out
    assert "0: Virtual" in out and "(4 axes, 6 buttons, 1 hats)" in out
    virtual_wheel.button(1, True)
    assert main(["doctor", "--watch", "--duration", "0.05", "--rate", "200"]) == 0
    assert "buttons button1" in capsys.readouterr().out


def test_doctor_sends_the_force_sequence() -> None:
    actuator = LogActuator(LogActuatorOptions())
    with FfbServer(actuator, "127.0.0.1", 0) as server:
        argv = ["doctor", "--ffb", f"127.0.0.1:{server.address[1]}", "--step-s", "0.02",
                "--rate", "200", "--strength", "0.2"]  # fmt: skip
        assert main(argv) == 0
        expected = [command for _, command in ffb_test_sequence(0.2)]
        wait_until(lambda: server.stats.applied >= 4 * len(expected), 5, "the whole sequence")
    applied = actuator.applied()
    distinct = [c for i, c in enumerate(applied) if i == 0 or c != applied[i - 1]]
    assert distinct == expected and applied[-1].is_zero()


def test_doctor_sends_the_motion_sweep() -> None:
    platform = LogPlatform(LogPlatformOptions())
    with MotionServer(platform, "127.0.0.1", 0) as server:
        argv = ["doctor", "--motion", f"127.0.0.1:{server.address[1]}", "--step-s", "0.05",
                "--rate", "200"]  # fmt: skip
        assert main(argv) == 0
        wait_until(lambda: server.stats.frames >= 50, 5, "the sweep")
    frames = platform.frames()
    assert max(f.roll for f in frames) > 0.05 and min(f.pitch for f in frames) < -0.05
    assert max(f.rpm for f in frames) > 3000 and frames[-1] == NEUTRAL_FRAME


def test_doctor_rejects_a_bad_address(capsys) -> None:
    assert main(["doctor", "--ffb", "localhost"]) == 2
    assert "HOST:PORT" in capsys.readouterr().err
