"""A scenario trigger's message reaches the participant it names, and only that one."""

from __future__ import annotations

from pathlib import Path

from tests.support import Cluster, wait_until
from tests.traffic.helpers import CROSSING_MAP, write_scenario

SCENARIO = f"""{CROSSING_MAP}
traffic:
  vehicles: {{count: 0}}
  pedestrians: {{count: 0}}
triggers:
  - id: greet
    measure:
      v: {{type: speed, actor: scripted-1}}
    when: "v > 1"
    actions:
      - {{type: message, to: scripted-1, text: "Welcome, rider one", duration_s: 4}}
      - {{type: message, to: scripted-2, text: "Not for rider one"}}
"""


def test_a_notice_reaches_the_node_it_names(tmp_path: Path) -> None:
    cluster = Cluster(tmp_path)
    try:
        cluster.router()
        scenario = write_scenario(tmp_path, SCENARIO)
        cluster.start("authority", "--scenario", str(scenario), "--session", "t",
                      "--connect", cluster.endpoint, "--json", name="authority")  # fmt: skip
        node = cluster.scripted("scripted-1", None, "--duration", "60")
        said = "carlaverse join: scenario message: Welcome, rider one\n"
        wait_until(lambda: said in node.stderr, 60, "the notice on the node's terminal")
        node.stop()
        assert not any("Not for rider one" in line for line in node.stderr)
        assert node.json()["node_id"] == "scripted-1"
    finally:
        cluster.close()
