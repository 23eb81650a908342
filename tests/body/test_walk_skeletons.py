"""Skeletons from the body sources reach other processes over real Zenoh, through the walk
node (`body: {source: camera}` runs the pose process), and a missing camera ends it in one
line."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from carlaverse import messages as m
from carlaverse.config import shipped_dir
from carlaverse.keys import Keys
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until


def _walk_config(tmp_path: Path, body: dict) -> Path:
    config = yaml.safe_load((shipped_dir() / "walk-sim.yaml").read_text())
    config["body"] = body
    path = tmp_path / "walk.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_camera_skeletons_arrive_over_zenoh_from_the_walk_node(cluster: Cluster,
                                                               tmp_path: Path) -> None:  # fmt: skip
    sim_camera = {"source": "camera", "options": {"camera": {"backend": "sim"}, "rate_hz": 30}}
    cluster.router()
    cluster.authority()
    session = open_session(FabricSettings(connect=[cluster.endpoint]),
                           deadline=time.monotonic() + 20)  # fmt: skip
    cluster.sessions.append(session)
    got: list[tuple[float, m.Skeleton]] = []
    lock = threading.Lock()

    def on_sample(sample) -> None:
        skeleton = m.SKELETON.decode(sample.payload.to_bytes())
        with lock:
            got.append((time.monotonic(), skeleton))

    subscriber = session.declare_subscriber(Keys("t").ego("walker", "skeleton"), on_sample)
    try:
        _watch_the_walker(cluster, tmp_path, sim_camera, got)
    finally:
        subscriber.undeclare()


def _watch_the_walker(cluster: Cluster, tmp_path: Path, body: dict, got: list) -> None:
    walker = cluster.start(
        "join", "walk", "--id", "walker", "--session", "t", "--connect", cluster.endpoint,
        "--config", str(_walk_config(tmp_path, body)), "--duration", "60", "--json",
        name="walker",
    )  # fmt: skip
    wait_until(lambda: len(got) >= 1, 60, f"a first skeleton; walker said {walker.output()}")
    start = len(got)
    first_t = time.monotonic()
    wait_until(lambda: len(got) >= start + 30, 10, "30 more skeletons")
    rate_hz = 30 / (time.monotonic() - first_t)
    assert walker.stop() == 0
    assert rate_hz > 15, f"{rate_hz:.1f} Hz"  # 30 Hz nominal, on a loaded 2-core host
    seqs = [s.seq for _, s in got]
    assert seqs == sorted(seqs)
    for _, skeleton in got:
        angles = np.frombuffer(skeleton.angles, "<f4").reshape(-1, 3)
        elbow = angles[skeleton.joints.index("left_elbow")]
        assert elbow == pytest.approx((0.0, -0.3, 0.0), abs=1e-5)  # the sim walker's bend
    assert walker.json()["extra"]["skeletons_sent"] >= len(got)


def test_an_absent_camera_ends_the_walk_node_in_one_line(cluster: Cluster,
                                                         tmp_path: Path) -> None:  # fmt: skip
    webcam = {
        "source": "camera",
        "options": {"camera": {"backend": "opencv", "options": {"device": 57}}},
    }
    walker = cluster.start("join", "walk", "--id", "walker", "--session", "t", "--connect",
                           cluster.endpoint, "--config", str(_walk_config(tmp_path, webcam)),
                           name="walker")  # fmt: skip
    assert walker.wait(60) == 2
    errors = [line for line in walker.stderr if line.strip()]
    assert len(errors) == 1, errors
    assert "camera /dev/video57 cannot be opened" in errors[0]
