"""`carlaverse record` as a user runs it: what it says, and its exit status."""

from __future__ import annotations

from pathlib import Path

from tests.support import Cluster, wait_until


def test_an_authority_without_scenario_is_reported_once_in_plain_words(
    cluster: Cluster, tmp_path: Path
) -> None:
    router = cluster.router()
    authority = cluster.authority("--duration", "30")
    wait_until(lambda: "listening" in router.output() or not router.alive(), 20, "the router")
    recorder = cluster.start(
        "record", "--session", "t", "--connect", cluster.endpoint, "-o", str(tmp_path / "r.mcap"),
        "--duration", "5", "--progress-s", "0", name="recorder",
    )  # fmt: skip
    assert recorder.wait(timeout=40) == 0, recorder.output()
    assert authority.alive()
    lines = recorder.output().splitlines()
    no_map = [line for line in lines if "authority/map: this session has no map" in line]
    no_scenario = [line for line in lines if "scenario: the authority runs no scenario" in line]
    assert len(no_map) == 1, lines  # retried every second, said once
    assert len(no_scenario) == 1, lines
    assert not any("ReplyError" in line or "\\x" in line for line in lines), lines
    assert f"recording session t into {tmp_path / 'r.mcap'}" in lines, lines
