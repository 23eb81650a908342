"""The README's command table, key space and schema version say what the code does."""

from __future__ import annotations

import argparse
import importlib
import re
import shlex
from pathlib import Path

import pytest

from carlaverse import messages as m
from carlaverse.cli import COMMANDS
from carlaverse.cli import wire_catalog as wc

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
FABRIC_COMMANDS = ("authority", "join", "stats", "record", "replay", "view")


def section(title: str) -> str:
    return README.split(f"## {title}\n", 1)[1].split("\n## ", 1)[0]


def command_rows() -> dict[str, str]:
    """First cell of each command-table row, by the command it names first."""
    cells = re.findall(r"^\| `carlaverse ([^`]*)`", section("Command line"), re.M)
    return {cell.split()[0]: cell for cell in cells}


def option_strings(command: str) -> set[str]:
    parser = argparse.ArgumentParser()
    importlib.import_module(COMMANDS[command][0]).add_arguments(parser)
    parsers = [parser]  # and its roles' own flags (`ros2 view|av`, `study run|plan`)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            parsers += list(action.choices.values())
    return {opt for p in parsers for action in p._actions for opt in action.option_strings}


def test_every_command_has_a_row() -> None:
    rows = re.findall(r"^\| (.*?) \| ", section("Command line"), re.M)
    named = {w for row in rows for w in re.findall(r"`(?:carlaverse )?([a-z0-9-]+)", row)}
    assert set(COMMANDS) <= named, f"commands missing from the README: {set(COMMANDS) - named}"


@pytest.mark.parametrize("command", sorted(command_rows()))
def test_every_flag_in_a_row_exists(command: str) -> None:
    flags = set(re.findall(r"--[a-z][a-z-]*", command_rows()[command]))
    missing = flags - option_strings(command)
    assert not missing, f"README lists {sorted(missing)} for `carlaverse {command}`; see --help"


def test_the_shared_fabric_flags_exist_on_every_fabric_command() -> None:
    sentence = section("Command line").split("share", 1)[1].split("; those", 1)[0]
    shared = set(re.findall(r"--[a-z][a-z-]*", sentence))
    assert {"--session", "--connect", "--listen", "--mode", "--roster"} <= shared
    for command in FABRIC_COMMANDS:
        assert shared <= option_strings(command), command


def test_named_scenarios_are_shipped() -> None:
    row = command_rows()["authority"]
    names = re.search(r"--scenario ([\w\\|]+)", row)[1].split("\\|")  # type: ignore[index]
    for name in set(names) - {"FILE", "none"}:
        assert (ROOT / "scenarios" / f"{name}.yaml").is_file(), name


def test_the_key_space_section_names_every_key() -> None:
    text = section("Key space")
    for key in wc.key_space_paths():
        assert f"`{key}`" in text, f"README key space lacks `{key}`"


def test_the_schema_version_in_the_readme_is_the_code_s() -> None:
    assert f"`SCHEMA_VERSION` (now {m.SCHEMA_VERSION})" in section("Message schemas")


def test_the_web_hmi_example_is_a_complete_join() -> None:
    """The Web HMI section's example is what a newcomer copies first (issue 43.8): it must parse
    as `carlaverse join` does, name the node (`--id`, unique in a session), say which session and
    router to reach, and say before it that a router and an authority must be running (a node
    is admitted by the authority, docs/architecture.md), else the node waits forever."""
    text = README.split("### Web HMI\n", 1)[1].split("\n### ", 1)[0]
    found = re.search(r"(?:^|`)(carlaverse join [^`\n]*)", text, re.M)
    assert found, "the Web HMI section has no `carlaverse join` example"
    argv = shlex.split(found[1])[2:]
    parser = argparse.ArgumentParser(exit_on_error=False)
    importlib.import_module(COMMANDS["join"][0]).add_arguments(parser)
    args = parser.parse_args(argv)  # raises on an unknown flag or a bad value
    assert args.node_id, f"the example lacks --id: {found[1]}"
    assert args.hmi and args.session and args.connect, found[1]
    before = text[: found.start()]
    assert "router" in before and "authority" in before, "say what must run before the node"
