"""The OpenSCENARIO coverage table (docs/openscenario.md) itself: the doc holds the generated
table, and the table has a row for every element of the schemas, read here with a plain
regular expression (not the table's own XSD walk).

The other files named test_openscenario_coverage_*.py hold the table to the importer: what is
read (`_read`), the conditions and actions refused by name (`_refused`), and every error
message the table quotes (`_stated`).
"""

from __future__ import annotations

import re
from pathlib import Path

from carlaverse.traffic.openscenario_coverage import markdown, schema_files
from tests.traffic.openscenario_files import ROWS

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "openscenario.md"
BEGIN = re.compile(r"<!-- BEGIN GENERATED openscenario-coverage \(.*?\) -->\n")
END = "<!-- END GENERATED openscenario-coverage -->"


def test_the_docs_hold_the_generated_table() -> None:
    text = DOC.read_text()
    begin = BEGIN.search(text)
    assert begin and END in text, "docs/openscenario.md lost its generated markers"
    inside = text[begin.end() : text.index(END)]
    assert inside == markdown(list(ROWS.values())), (
        "stale: run python tools/openscenario_coverage.py --write docs/openscenario.md"
    )


def test_every_element_of_every_1x_schema_has_a_row() -> None:
    # the schemas' element names read with a regular expression, not the table's XSD walk
    names = set()
    for version, path in schema_files():
        assert version.startswith("1.")
        names |= set(re.findall(r'<xsd?:element name="(\w+)"', path.read_text()))
    assert [v for v, _ in schema_files()] == ["1.0", "1.1", "1.2", "1.3"]
    assert set(ROWS) == names and len(names) > 290
