"""--json outputs are strict JSON: what was never measured is null, never NaN or Infinity."""

from __future__ import annotations

import json
import math

from carlaverse.cli.common import to_json
from carlaverse.node_runtime import NodeSummary


def test_unmeasured_figures_are_null_and_strict_parsers_accept_the_output() -> None:
    summary = NodeSummary(node_id="a", kind="scripted", session="s", joined=False)
    text = to_json({"node": summary, "p99": math.nan, "bound": [math.inf, 1.5]})

    def refuse(token: str) -> float:
        raise AssertionError(f"non-standard JSON token {token}")

    parsed = json.loads(text, parse_constant=refuse)
    assert parsed["p99"] is None and parsed["bound"] == [None, 1.5]
    assert parsed["node"]["clock_uncertainty_ms"] is None
