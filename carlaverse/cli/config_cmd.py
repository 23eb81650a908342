"""`carlaverse config validate FILE…`: check node configs, scenarios, vehicles, rosters and router
configs before a study, each with the decoder that will read it for real."""

from __future__ import annotations

import argparse

from carlaverse.cli.common import tell
from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError
from carlaverse.config_check import FILE_KINDS, validate_file


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Validate files against their schema. The schema is chosen with --kind, else from the "
        "file: a node config by its `node.kind`, a scenario by `map:`, a vehicle by `body:` and "
        "`spec:`, a roster by `sites:` and `nodes:`, a router config by a lone `fabric:`, a "
        "camera rig by `camera:`, a trainer resistance table by `resistance_percent:`, an HMI "
        "config by `layouts:`, an audio config by `layout:`, a zenohd config by its .json5 suffix."
    )
    sub = parser.add_subparsers(dest="action", required=True)
    validate = sub.add_parser(
        "validate", help="validate files; exit 2 (a config error) if any is invalid"
    )
    validate.add_argument("files", nargs="+", help="files, or names of shipped ones (town)")
    validate.add_argument(
        "--kind",
        help=f"schema to use: a node kind (observer, scripted, ...) or one of {FILE_KINDS}",
    )


def run(args: argparse.Namespace) -> int:
    failures = 0
    for name in args.files:
        try:
            print(validate_file(name, args.kind))
        except ConfigError as exc:
            failures += 1
            tell(f"carlaverse config: {exc}")  # one line per file, as every command says it
    return Exit.USAGE if failures else Exit.OK  # as `join` with the same file
