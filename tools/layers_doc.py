"""The layers of docs/architecture.md §13, drawn from the import contracts that CI enforces.

    python tools/layers_doc.py            # print the generated region
    python tools/layers_doc.py --write    # rewrite it in docs/architecture.md
    python tools/layers_doc.py --check    # exit 1 when the document differs from the contracts

The contracts live in pyproject.toml's `[tool.importlinter]` and `tests/test_layers.py` runs
`lint-imports` on them; this script turns the same contracts into a Mermaid diagram (the
layers, top to bottom, each importing only those below it) and a table of every other rule,
so the picture in the docs cannot say something the checked contracts do not.
"""

from __future__ import annotations

import argparse
import itertools
import re
import sys
import tomllib
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"
NAME = "layers"
BEGIN = f"<!-- BEGIN GENERATED {NAME} (python tools/layers_doc.py --write) -->\n"
END = f"<!-- END GENERATED {NAME} -->"
_REGION = re.compile(re.escape(BEGIN) + r".*?" + re.escape(END), re.DOTALL)


def contracts(pyproject: Path = ROOT / "pyproject.toml") -> list[dict[str, Any]]:
    with pyproject.open("rb") as f:
        return list(tomllib.load(f)["tool"]["importlinter"]["contracts"])


def _short(module: str) -> str:
    """`carlaverse.render` -> `render`; the node kinds' package keeps a readable name."""
    if module == "carlaverse_nodes":
        return "node kinds (carlaverse_nodes)"
    return module.removeprefix("carlaverse.")


def _node_id(module: str) -> str:
    return re.sub(r"\W", "_", module)


def layers_diagram(layers: list[str]) -> str:
    """Mermaid: one box per layer (siblings side by side, never importing each other), an
    arrow from each layer to the next one down: imports only go that way."""
    lines = ["```mermaid", "flowchart TD"]
    ids = []
    for index, layer in enumerate(layers):
        members = [m.strip() for m in layer.split("|")]
        if len(members) == 1:
            ids.append(_node_id(members[0]))
            lines.append(f'    {ids[-1]}["{_short(members[0])}"]')
            continue
        ids.append(f"layer{index}")
        lines.append(f'    subgraph {ids[-1]}["independent siblings"]')
        lines += [f'        {_node_id(m)}["{_short(m)}"]' for m in members]
        lines.append("    end")
    lines += [f"    {upper} --> {lower}" for upper, lower in itertools.pairwise(ids)]
    lines.append("```")
    return "\n".join(lines)


def _names(modules: list[str]) -> str:
    return ", ".join(f"`{_short(m)}`" for m in modules)


def rule_rows(every: list[dict[str, Any]]) -> list[tuple[str, str, str]]:
    """(contract, who, rule) for every contract that is not the layers."""
    rows = []
    for c in every:
        kind = c["type"]
        if kind == "forbidden":
            rule = "imports none of " + _names(c["forbidden_modules"])
            if c.get("ignore_imports"):
                rule += " (except " + "; ".join(f"`{i}`" for i in c["ignore_imports"]) + ")"
            rows.append((c["name"], _names(c["source_modules"]), rule))
        elif kind == "independence":
            rows.append((c["name"], _names(c["modules"]), "never import each other"))
        elif kind == "protected":
            rule = "imported only by " + _names(c["allowed_importers"])
            rows.append((c["name"], _names(c["protected_modules"]), rule))
        elif kind == "acyclic_siblings":
            rows.append((c["name"], _names(c["ancestors"]) + " and everything in them",
                         "no two siblings import each other both ways"))  # fmt: skip
        elif kind != "layers":
            rows.append((c["name"], "", f"a `{kind}` contract"))
    return rows


def region(every: list[dict[str, Any]]) -> str:
    layered = [c for c in every if c["type"] == "layers"]
    parts = []
    for c in layered:
        parts += [f"**{c['name']}** (arrows point down: who may import whom)", "",
                  layers_diagram(c["layers"]), ""]  # fmt: skip
    table = ["| contract | modules | rule |", "|---|---|---|"]
    table += [f"| {name} | {who} | {rule} |" for name, who, rule in rule_rows(every)]
    return "\n".join([*parts, *table]) + "\n"


def rewrite(text: str, every: list[dict[str, Any]]) -> str:
    if not _REGION.search(text):
        raise SystemExit(f"{DOC}: no region between {BEGIN.strip()} and {END}")
    return _REGION.sub(lambda _m: BEGIN + region(every) + END, text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--write", action="store_true", help=f"rewrite the region in {DOC.name}")
    group.add_argument("--check", action="store_true", help="exit 1 if the document is stale")
    args = parser.parse_args(argv)
    every = contracts()
    if not (args.write or args.check):
        print(region(every), end="")
        return 0
    text = DOC.read_text()
    new = rewrite(text, every)
    if args.check:
        if new != text:
            print(f"{DOC} §13 differs from the import contracts: run python tools/layers_doc.py "
                  "--write", file=sys.stderr)  # fmt: skip
            return 1
        return 0
    DOC.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
