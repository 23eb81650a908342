"""The OpenSCENARIO coverage table of docs/openscenario.md, from the importer's own table.

    python tools/openscenario_coverage.py                              # print the table
    python tools/openscenario_coverage.py --write docs/openscenario.md # replace it in the doc
    python tools/openscenario_coverage.py --check docs/openscenario.md # exit 1 when stale

The table lists every element of the OpenSCENARIO 1.0–1.3 schemas that scenariogeneration
installs (carlaverse/traffic/openscenario_coverage.py says how each status is found);
tests/traffic/test_openscenario_coverage_*.py hold it to the importer's behaviour.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from carlaverse.traffic.openscenario_coverage import coverage, markdown

NAME = "openscenario-coverage"
BLOCK = re.compile(
    rf"(<!-- BEGIN GENERATED {NAME} \(.*?\) -->\n)(.*?)(<!-- END GENERATED {NAME} -->)", re.S
)


def replaced(text: str, table: str) -> str | None:
    """`text` with the generated block's inside replaced by `table`; None without markers."""
    if not BLOCK.search(text):
        return None
    return BLOCK.sub(lambda m: m[1] + table + m[3], text, count=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--write", type=Path, metavar="DOC", help="replace the table in DOC")
    group.add_argument("--check", type=Path, metavar="DOC", help="exit 1 if DOC's is stale")
    args = parser.parse_args(argv)
    table = markdown(coverage())
    doc = args.write or args.check
    if doc is None:
        sys.stdout.write(table)
        return 0
    text = doc.read_text(encoding="utf-8")
    new = replaced(text, table)
    if new is None:
        print(f"{doc}: no <!-- BEGIN/END GENERATED {NAME} --> markers", file=sys.stderr)
        return 2
    if args.check:
        stale = new != text
        if stale:
            print(f"{doc}: stale: run python tools/openscenario_coverage.py --write {doc}",
                  file=sys.stderr)  # fmt: skip
        return int(stale)
    doc.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
