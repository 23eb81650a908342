"""`--json` is JSON: every such command's whole stdout parses as one document, whatever the node
kind, config and backend (docs/protocol.md, "Command-line JSON outputs").

Each case runs the real `carlaverse` in a subprocess, against a router and an authority started
here where it needs a session, and hands its entire stdout to `json.loads`: one byte of a
library's greeting before or after the object fails it. PYGAME_HIDE_SUPPORT_PROMPT is removed
from the children's environment, so pygame greets unless the command keeps it off stdout.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import ego_pose, synthetic_map
from tests.audio.measure import LISTENER, scenes
from tests.audio.measure import write_recording as write_audio_recording
from tests.support import Cluster, wait_until

SESSION = "js"
RUN_S = "2"  # [s] --duration of each node: joined, a few poses, left


def carlaverse(*argv: str, timeout: float = 90) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYGAME_HIDE_SUPPORT_PROMPT"}
    return subprocess.run([sys.executable, "-m", "carlaverse", *argv], capture_output=True,
                          text=True, timeout=timeout, env=env, check=False)  # fmt: skip


def one_document(done: subprocess.CompletedProcess[str]) -> Any:
    """The whole of stdout as one JSON value; fails naming what else was there."""
    assert done.returncode == 0, done.stderr[-3000:]
    try:
        return json.loads(done.stdout)
    except json.JSONDecodeError as exc:
        pytest.fail(f"stdout is not one JSON document ({exc}); it starts {done.stdout[:300]!r}")


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    """A router and an authority of session SESSION, running for the module's cases."""
    cluster = Cluster(tmp_path_factory.mktemp("json"))
    try:
        cluster.router()
        authority = cluster.start("authority", "--scenario", "none", "--session", SESSION,
                                  "--connect", cluster.endpoint, name="authority")  # fmt: skip
        wait_until(lambda: "ticking" in authority.output() or not authority.alive(), 60,
                   "the authority to tick")  # fmt: skip
        assert authority.alive(), authority.output()[-2000:]
        yield cluster
    finally:
        cluster.close()


JOINS = {
    "observer": ["observer"],
    "scripted": ["scripted"],
    "drive-sim": ["drive", "--backend", "sim"],
    "bike-sim": ["bike", "--backend", "sim"],
    "walk-sim": ["walk", "--backend", "sim"],
    # The newcomer's case: the keyboard backend imports pygame, which greets on stdout.
    "drive-desktop": ["drive", "--config", "configs/drive-desktop.yaml"],
}


@pytest.mark.parametrize("case", sorted(JOINS))
def test_join_prints_one_document_whatever_the_kind(case: str, world: Cluster) -> None:
    node_id = f"{case}-1"
    done = carlaverse("join", *JOINS[case], "--id", node_id, "--session", SESSION,
                      "--connect", world.endpoint, "--duration", RUN_S, "--json")  # fmt: skip
    summary = one_document(done)
    assert summary["node_id"] == node_id and summary["joined"] is True, summary


def test_stats_prints_one_document(world: Cluster) -> None:
    done = carlaverse("stats", "--session", SESSION, "--connect", world.endpoint,
                      "--duration", RUN_S, "--json")  # fmt: skip
    assert "nodes" in one_document(done)


def test_swarm_prints_one_document(world: Cluster) -> None:
    done = carlaverse("swarm", "--egos", "2", "--session", SESSION, "--connect", world.endpoint,
                      "--duration", RUN_S, "--json")  # fmt: skip
    assert one_document(done)["joined"] == 2


def test_authority_prints_one_document(world: Cluster) -> None:
    done = carlaverse("authority", "--scenario", "none", "--session", "js-2", "--connect",
                      world.endpoint, "--duration", RUN_S, "--json")  # fmt: skip
    assert one_document(done)["tick"]["ticks"] > 0


def test_schema_prints_one_document() -> None:
    assert "$defs" in one_document(carlaverse("schema", "--json"))


@pytest.fixture(scope="module")
def pose_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two seconds of one ego on its circle, with the map, as a recorder writes them."""
    path = tmp_path_factory.mktemp("rec") / "poses.mcap"
    keys, t0_ns = Keys("rec"), 1_700_000_000 * 10**9
    sink = McapSink(path, monotonic=time.monotonic)
    sink.write(keys.authority("map"), m.MAP.encode(synthetic_map()), t0_ns)
    sink.write(keys.node("ego-0"), b"", t0_ns)
    for k in range(100):
        pose = m.POSE.encode(ego_pose(0, k, k / 50))
        sink.write(keys.pose("ego-0", "t0_0"), pose, t0_ns + k * 20_000_000)
    sink.close()
    return path


def test_analyze_prints_one_document(pose_recording: Path, tmp_path: Path) -> None:
    done = carlaverse("analyze", str(pose_recording), "--out", str(tmp_path / "out"))
    assert one_document(done)["humans"] == ["ego-0"]


def test_render_prints_one_document(pose_recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "still.png"
    done = carlaverse("render", str(pose_recording), "--out", str(out), "--at", "1",
                      "--width", "160", "--height", "90", "--json")  # fmt: skip
    assert one_document(done)["frames"] == 1


def test_audio_render_prints_one_document(tmp_path: Path) -> None:
    car = [("car-1", "engine", 80.0, 2000.0, 0.5, (10.0, 0.0, 1.0), (0.0, 5.0, 0.0), 0.0)]
    recording = write_audio_recording(tmp_path / "audio.mcap", scenes(car, 1.0))
    done = carlaverse("audio", "render", str(recording), "--listener", LISTENER, "--out",
                      str(tmp_path / "ears.wav"), "--layout", "stereo", "--json")  # fmt: skip
    assert one_document(done)["channels"] == 2


GUARDED = """
import os, subprocess, sys
from carlaverse.cli.common import json_stdout, print_json
print("before")
with json_stdout(True) as out:
    print("a print")                                  # Python's sys.stdout
    os.write(1, b"a C library's printf\\n")           # file descriptor 1 itself
    subprocess.run(["sh", "-c", "echo a child"])      # a child inheriting fd 1
    print_json({"ok": True}, out)
print("after")
"""


def test_json_stdout_sends_every_other_writer_of_fd_1_to_stderr() -> None:
    """Whatever writes to stdout while the guard holds lands on stderr, in the order written;
    only the document stays on stdout, and stdout is stdout again afterwards."""
    done = subprocess.run([sys.executable, "-c", GUARDED], capture_output=True, text=True,
                          timeout=60, check=True)  # fmt: skip
    assert done.stdout.splitlines()[0] == "before" and done.stdout.splitlines()[-1] == "after"
    assert json.loads("\n".join(done.stdout.splitlines()[1:-1])) == {"ok": True}
    assert done.stderr.splitlines() == ["a print", "a C library's printf", "a child"]
