"""`carlaverse join KIND --view` from the command line: the drive node's view rides in the car
and ends with the node; an observer's view chases a node; flag mistakes are one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from carlaverse.cli import main
from carlaverse.config import to_yaml
from tests.render.test_view_process import RIG, SCRIPTED, _alive, _assert_frames_show_a_car, _png
from tests.support import Cluster, wait_until

pytestmark = pytest.mark.usefixtures("offscreen_gl")


def _join(cluster: Cluster, kind: str, node_id: str, rig: Path, out: Path, *extra: str):
    return cluster.start(
        "join", kind, "--id", node_id, "--session", "t", "--connect", cluster.endpoint,
        "--duration", "8", "--json", "--view", "--offscreen", "--view-out", str(out),
        "--render-config", str(rig), *extra, name=node_id,
    )  # fmt: skip


def test_drive_and_observer_views_from_the_cli(tmp_path: Path) -> None:
    rig = tmp_path / "rig.yaml"
    rig.write_text(to_yaml(RIG))
    scripted = tmp_path / "scripted.yaml"
    scripted.write_text(SCRIPTED)
    cluster = Cluster(tmp_path)
    try:
        cluster.router()
        cluster.authority()
        cluster.scripted("s1", scripted)
        drive = _join(cluster, "drive", "d1", rig, tmp_path / "drive", "--backend", "sim")
        chase = _join(cluster, "observer", "o1", rig, tmp_path / "chase", "--view-camera", "s1")
        for proc in (drive, chase):
            assert proc.wait(timeout=90) == 0, proc.output()[-3000:]
        views = {p.name: p.json()["extra"]["view"] for p in (drive, chase)}
    finally:
        cluster.close()
    for view in views.values():
        assert view["error"] == "" and view["frames"] >= 20, view
        wait_until(lambda v=view: not _alive(v["pid"]), 5, "the render process to end")
    _assert_frames_show_a_car(sorted((tmp_path / "drive").glob("frame-*.png")),
                              views["d1"]["written"])  # fmt: skip
    # the chase camera sits 7 m behind s1: its car fills the lower middle of every late frame
    late = [_png(f) for f in sorted((tmp_path / "chase").glob("frame-*.png"))[-4:]]
    # s1 circles, so the view turns with it; a starved s1 (a loaded 2-core host) may leave
    # one 0.5 s pair of frames alike, but not the whole last 1.5 s
    assert len(late) == 4 and not np.array_equal(late[0], late[-1])
    for frame in late:
        h, w = frame.shape[:2]
        middle = frame[h // 2 :, w // 3 : 2 * w // 3].reshape(-1, 3).astype(int)
        carlike = (middle[:, 2] > middle[:, 1] + 30).sum()  # the car's blue body, not grass
        assert carlike > 50, carlike


def test_view_flags_without_view_are_one_line_errors(capsys) -> None:
    code = main(["join", "observer", "--id", "o2", "--view-out", "/tmp/x", "--connect",
                 "tcp/127.0.0.1:9"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and "need --view" in err and "Traceback" not in err
