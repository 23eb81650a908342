"""`carlaverse render SESSION` against a live session (router, authority and scripted nodes
as processes; the render command as a process too): a still riding in one node shows the
other car and nothing else, a clip has its frames, and what did not arrive is said in one
line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from carlaverse.cli import main
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import RenderConfig, Resolution, SimpleRig
from tests.render.support import car, changed
from tests.support import Cluster

pytestmark = pytest.mark.usefixtures("offscreen_gl")

WIDTH, HEIGHT = 320, 180
SIZE = ("--width", str(WIDTH), "--height", str(HEIGHT))
# The rider stands at the origin heading east (a circle at no speed: paths run on session
# time, so anything moving would be anywhere on its path).
RIDER = "path: {type: circle, center: [0.0, 1.0], radius: 1.0, speed_mps: 0.0, phase_deg: -90}"
# The other car: a slow circle 37..53 m ahead of the rider, within its view's ±45°.
AHEAD = "path: {type: circle, center: [45.0, 0.0], radius: 8.0, speed_mps: 2.0}"


def _png(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"))


def _empty_scene() -> np.ndarray:
    """Riding at the origin with nobody else there (no map: a session without a scenario),
    through the default rig at the still's size, as `carlaverse render` draws it: its own
    car (bonnet, dashboard, mirrors) is in both pictures."""
    import msgspec

    from carlaverse.cli.render import DEFAULT_RIG
    from carlaverse.config import load_config

    rig = load_config(DEFAULT_RIG, RenderConfig)
    camera = msgspec.structs.replace(rig.camera, resolution=Resolution(width=WIDTH, height=HEIGHT))
    config = msgspec.structs.replace(rig, output="offscreen", camera=camera)
    with Renderer(config, None) as r:
        r.draw(SceneFrame(0.0, (car("rider", 0.0, 0.0, ego=True),)), follow="rider")
        return r.images()[0]


def _render(cluster: Cluster, *args: str) -> tuple[int, str]:
    proc = cluster.start("render", "t", "--connect", cluster.endpoint, *args, name="render")
    code = proc.wait(timeout=120)
    for reader in proc.readers:
        reader.join(timeout=5)
    return code, proc.output()


def _rig_is_simple_90() -> None:
    """The test's empty scene assumes the default rig is a 90° simple camera."""
    from carlaverse.cli.render import DEFAULT_RIG
    from carlaverse.config import load_config

    rig = load_config(DEFAULT_RIG, RenderConfig).camera
    assert isinstance(rig, SimpleRig) and rig.fov_deg == 90, rig


def test_live_still_and_clip(tmp_path: Path, save_shot) -> None:
    _rig_is_simple_90()
    (tmp_path / "rider.yaml").write_text(RIDER)
    (tmp_path / "ahead.yaml").write_text(AHEAD)
    still, clip = tmp_path / "now.png", tmp_path / "next.mp4"
    cluster = Cluster(tmp_path)
    try:
        cluster.router()
        cluster.authority()
        cluster.scripted("rider", tmp_path / "rider.yaml")
        cluster.scripted("ahead", tmp_path / "ahead.yaml")
        code, out = _render(cluster, "--camera", "rider", "--out", str(still), *SIZE)
        assert code == 0, out
        code, out = _render(cluster, "--camera", "rider", "--out", str(clip), "--duration",
                            "1", "--fps", "5", "--width", "160", "--height", "90")  # fmt: skip
        assert code == 0, out
        code, missing = _render(cluster, "--camera", "nobody", "--join-timeout", "3",
                                "--out", str(tmp_path / "x.png"), *SIZE)  # fmt: skip
    finally:
        cluster.close()
    image = _png(still)
    save_shot("live_rider", image)
    assert image.shape == (HEIGHT, WIDTH, 3)
    shown = changed(image, _empty_scene())
    assert 20 < shown.sum() < WIDTH * HEIGHT // 4, shown.sum()  # the car ahead, only the car
    # 37..53 m ahead and at most 8 m aside: within ±13° of the view's axis, ±40 px here
    columns = np.nonzero(shown)[1]
    assert abs(columns.min() - WIDTH / 2) < 40 and abs(columns.max() - WIDTH / 2) < 40, columns
    _assert_clip(clip, frames=5, size=(160, 90))
    assert code == 5 and "node 'nobody' is not in session 't'" in missing, missing
    assert "ahead" in missing and "rider" in missing and "Traceback" not in missing


def _assert_clip(path: Path, frames: int, size: tuple[int, int]) -> None:
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    assert next(reader)["size"] == size
    assert sum(1 for _ in reader) == frames


def test_an_empty_session_says_what_did_not_arrive(tmp_path: Path) -> None:
    cluster = Cluster(tmp_path)
    try:
        cluster.router()
        cluster.authority()
        code, out = _render(cluster, "--join-timeout", "4", "--out", str(tmp_path / "x.png"))
    finally:
        cluster.close()
    assert code == 5, out
    said = [line for line in out.splitlines() if "arrived" in line]
    assert said == [
        "carlaverse render: no NPC batch and no node's pose arrived: session 't' is empty "
        "(waited --join-timeout 4 s)"
    ], out
    assert "Traceback" not in out and not (tmp_path / "x.png").exists()


def test_live_usage_errors_are_one_line(tmp_path: Path, capsys) -> None:
    png = str(tmp_path / "x.png")
    assert main(["render", "demo", "--at", "1.0", "--out", png]) == 2
    assert main(["render", str(tmp_path / "gone.mcap"), "--out", png]) == 2
    assert main(["render", "no such session", "--out", png]) == 2
    recording = tmp_path / "rec.mcap"
    recording.write_bytes(b"")
    assert main(["render", str(recording), "--connect", "tcp/127.0.0.1:1", "--out", png]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 4, lines
    assert lines[0].startswith("carlaverse render: --at is for recordings")
    assert lines[1] == f"carlaverse render: {tmp_path / 'gone.mcap'}: no such recording"
    assert "session name" in lines[2]
    assert "are for a live session" in lines[3]
