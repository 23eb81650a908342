"""`join --hmi` mistakes end the command in one line naming the option, before any joining."""

from __future__ import annotations

import socket

import pytest

from carlaverse.cli import main


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    code = main(["join", *args, "--session", "t", "--connect", "tcp/127.0.0.1:9"])
    return code, capsys.readouterr().err.strip()


def test_a_port_in_use(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, err = _run(capsys, "drive", "--id", "car", "--hmi", str(port))
    assert code == 2
    assert err == (f"carlaverse join: drive: --hmi {port}: cannot listen on 127.0.0.1:{port} "
                   "(Address already in use); pick another port")  # fmt: skip


def test_a_kind_without_an_hmi(capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _run(capsys, "observer", "--id", "obs", "--hmi", "0")
    assert code == 2
    assert err == ("carlaverse join: observer: --hmi: node kind 'observer' has no HMI "
                   "(drive and bike have one)")  # fmt: skip


def test_a_bad_bind_address(capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _run(
        capsys, "bike", "--id", "b", "--hmi", "0", "--hmi-bind", "no.such.host.invalid"
    )
    assert code == 2 and err.count("\n") == 0
    assert err.startswith(
        "carlaverse join: bike: --hmi-bind 'no.such.host.invalid': not an address"
    )


def test_a_bad_allowed_host_name(capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _run(
        capsys, "drive", "--id", "car", "--hmi", "0", "--hmi-allow-host", "cabin-pc.lab:8080"
    )
    assert code == 2
    assert err == ("carlaverse join: drive: --hmi-allow-host 'cabin-pc.lab:8080' is not a host "
                   "name or an IP address (no port, no scheme: e.g. cabin-pc.lab or "
                   "192.168.1.20)")  # fmt: skip
