"""A scenario trigger's message reaches the participant it names, and only that one."""

from __future__ import annotations

import json
from pathlib import Path

from carlaverse.analysis.export import events_table
from carlaverse.analysis.tracks import read_recording
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


def test_a_notice_reaches_the_node_it_names_and_the_firing_is_recorded(tmp_path: Path) -> None:
    cluster = Cluster(tmp_path)
    mcap = tmp_path / "session.mcap"
    try:
        cluster.router()
        recorder = cluster.start("record", "--session", "t", "--connect", cluster.endpoint,
                                 "-o", str(mcap), name="recorder")  # fmt: skip
        recorder.wait_for_line("recording session", 30)  # the recorder has subscribed
        scenario = write_scenario(tmp_path, SCENARIO)
        cluster.start("authority", "--scenario", str(scenario), "--session", "t",
                      "--connect", cluster.endpoint, "--json", name="authority")  # fmt: skip
        node = cluster.scripted("scripted-1", None, "--duration", "60")
        said = "carlaverse join: scenario message: Welcome, rider one\n"
        wait_until(lambda: said in node.stderr, 60, "the notice on the node's terminal")
        node.stop()
        assert not any("Not for rider one" in line for line in node.stderr)
        assert node.json()["node_id"] == "scripted-1"
        assert recorder.stop() == 0
    finally:
        cluster.close()
    events = events_table(read_recording(mcap).events).to_pylist()
    (fired,) = [e for e in events if e["type"] == "trigger"]
    assert json.loads(fired["fields"])["actions"] == [
        "message to scripted-1",
        "message to scripted-2",
    ]
    assert json.loads(fired["fields"])["values"]["v"] > 1
    assert sorted(json.loads(e["fields"])["to"] for e in events if e["type"] == "notice") == [
        "scripted-1", "scripted-2"]  # fmt: skip
