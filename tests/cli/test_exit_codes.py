"""One exit-code table for every command (docs/protocol.md, "Exit codes"): the document says
what the code does, and each command, given a missing input file, a broken config or a flag
it does not know, exits with the table's code and says why in exactly one line on stderr.

Broken YAML in particular is one line, `FILE:LINE:COLUMN: invalid YAML: ...`, through
`config validate` and through `join`, instead of PyYAML's six-line message.
"""

from __future__ import annotations

import re
import signal
from pathlib import Path

import pytest

from carlaverse.cli import COMMANDS, main
from carlaverse.cli.exit_codes import Exit

REPO = Path(__file__).resolve().parents[2]


def test_the_table_holds_the_codes_the_issue_and_the_shells_agree_on() -> None:
    """2 usage/config/missing file, 3 fabric, 4 refused, 5 not admitted (issue 43); a process
    a signal N ended exits 128 + N in every POSIX shell: SIGINT is 2, SIGTERM 15."""
    expected = {"OK": 0, "USAGE": 2, "FABRIC": 3, "REFUSED": 4, "NOT_ADMITTED": 5,
                "SIGINT": 128 + 2, "SIGTERM": 128 + 15}  # fmt: skip
    assert {name: int(Exit[name]) for name in expected} == expected
    assert (signal.SIGINT, signal.SIGTERM) == (2, 15)


def test_protocol_md_lists_every_code_once() -> None:
    text = (REPO / "docs" / "protocol.md").read_text(encoding="utf-8")
    section = text.split("## Exit codes", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| (\d+) \| `(\w+)` \| (.+) \|$", section, re.M)
    assert [(int(code), name) for code, name, _ in rows] == [(int(e), e.name) for e in Exit]
    assert all(meaning.strip() for _, _, meaning in rows)


def test_readme_states_the_table() -> None:
    text = " ".join((REPO / "README.md").read_text(encoding="utf-8").split())
    paragraph = text.split("Exit codes are one table for every command", 1)[1][:1200]
    for says in ("0 done", "1 the work failed", "2 usage or input error", "3 fabric error",
                 "4 refused by the authority", "5 not admitted in time", "130/143"):  # fmt: skip
        assert says in paragraph, says


@pytest.fixture
def broken_yaml(tmp_path: Path) -> Path:
    """A flow sequence opened on line 3 and never closed: PyYAML meets the end of the text
    at line 4, column 1."""
    path = tmp_path / "broken.yaml"
    path.write_text("node:\n  kind: scripted\n  node_id: [a,\n")
    return path


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    return err.strip()


# command line with {missing} for a file that is not there -> the command's name in the line
MISSING_INPUT = {
    "config": ["config", "validate", "{missing}.yaml"],
    "join": ["join", "scripted", "--id", "a", "--config", "{missing}.yaml"],
    "authority": ["authority", "--scenario", "{missing}.yaml"],
    "router": ["router", "--config", "{missing}.yaml"],
    "stats": ["stats", "--roster", "{missing}.yaml", "--duration", "1"],
    "swarm": ["swarm", "--roster", "{missing}.yaml", "--duration", "1"],
    "record": ["record", "--recover", "{missing}.mcap", "-o", "{tmp}/out.mcap"],
    "replay": ["replay", "{missing}.mcap"],
    "view": ["view", "{missing}.mcap", "--save", "{tmp}/x.rrd"],
    "render": ["render", "{missing}.mcap", "--out", "{tmp}/x.png"],
    "analyze": ["analyze", "{missing}.mcap", "--out", "{tmp}/out"],
    "audio": ["audio", "render", "{missing}.mcap", "--listener", "a", "--out", "{tmp}/x.wav"],
    "body": ["body", "angles", "{missing}.png"],
    "certs": ["certs", "--roster", "{missing}.yaml"],
    "roster": ["roster", "check", "{missing}.yaml"],
    "schema": ["schema", "--write-doc", "{missing}.md"],
    "launcher": ["launcher", "--no-browser", "--config-dir", "{missing}"],
}


@pytest.mark.parametrize("command", sorted(MISSING_INPUT))
def test_a_missing_input_file_is_exit_2_in_one_line_naming_it(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    missing = tmp_path / "not-there"
    argv = [a.format(missing=missing, tmp=tmp_path) for a in MISSING_INPUT[command]]
    assert main(argv) == Exit.USAGE
    line = _one_line(capsys)
    assert line.startswith(f"carlaverse {command}") and str(missing) in line, line


BROKEN_CONFIG = {
    "config": ["config", "validate", "{broken}"],
    "join": ["join", "scripted", "--id", "a", "--config", "{broken}"],
    "authority": ["authority", "--scenario", "{broken}"],
    "router": ["router", "--config", "{broken}"],
    "stats": ["stats", "--roster", "{broken}", "--duration", "1"],
    "audio": [
        "audio",
        "render",
        "{tmp}/x.mcap",
        "--listener",
        "a",
        "--out",
        "{tmp}/x.wav",
        "--config",
        "{broken}",
    ],
    "certs": ["certs", "--roster", "{broken}"],
    "roster": ["roster", "check", "{broken}"],
    "render": ["render", "lab", "--rig", "{broken}", "--out", "{tmp}/x.png"],
}


@pytest.mark.parametrize("command", sorted(BROKEN_CONFIG))
def test_broken_yaml_is_exit_2_in_one_line_with_file_line_and_column(
    command: str, broken_yaml: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [a.format(broken=broken_yaml, tmp=tmp_path) for a in BROKEN_CONFIG[command]]
    assert main(argv) == Exit.USAGE
    line = _one_line(capsys)
    assert f"{broken_yaml}:4:1: invalid YAML: " in line, line
    assert "expected the node content, but found '<stream end>'" in line, line


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_flag_a_command_does_not_know_is_exit_2_in_one_line(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        main([command, "--no-such-flag"])
    assert exited.value.code == Exit.USAGE
    line = _one_line(capsys)
    assert line.startswith(f"carlaverse {command}") and ": error: " in line, line
    assert line.endswith("--help)"), line  # where to read what it takes


def test_an_unknown_command_is_exit_2_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["jion"])
    assert exited.value.code == Exit.USAGE
    assert "invalid choice: 'jion'" in _one_line(capsys)
