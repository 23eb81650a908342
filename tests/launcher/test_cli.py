"""`carlaverse launcher` on the command line: its help, and one line for what is wrong."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from carlaverse.cli import main


def test_help_explains_what_the_launcher_does(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["launcher", "--help"])
    assert exit_info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for words in ("--port", "--bind", "--no-browser", "127.0.0.1", "strict decoder",
                  "stops every process it started", "trainer scan", "--allow-host", "?token=",
                  "launcher-PORT.token", "mode 0600", "only inside --config-dir"):  # fmt: skip
        assert words in text


def test_a_bad_session_name_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["launcher", "--no-browser", "--session", "a/b"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("carlaverse launcher: ") and "session name" in err
    assert len(err.splitlines()) == 1


def test_a_port_in_use_is_one_line_and_writes_no_token(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A second launcher on a taken port must not replace the first one's token file."""
    runtime = tmp_path / "run"
    runtime.mkdir(mode=0o700)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(runtime))
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        argv = ["launcher", "--no-browser", "--port", str(port), "--config-dir", str(tmp_path)]
        assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"carlaverse launcher: port {port} on 127.0.0.1 is in use; choose --port"
    assert not (runtime / "carlaverse").exists()
