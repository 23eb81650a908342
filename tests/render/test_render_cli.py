"""`carlaverse render` on a real MCAP file: a still where the recording says, twice the same,
and a clip that ffmpeg can read back."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.cli import main
from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import ego_pose, light_state, npc_rows, synthetic_map

pytestmark = pytest.mark.usefixtures("offscreen_gl")

T0_NS = 1_700_000_000 * 10**9  # [ns] the recorder's wall clock at session time 0
LATENCY_NS = 3_000_000  # [ns] every sample arrives 3 ms after its session time


def write_recording(path: Path, seconds: float = 2.0) -> None:
    """Two egos on their circles and NPC batches, on the real keys, as a recorder writes them."""
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    sink.write(keys.authority("map"), m.MAP.encode(synthetic_map()), T0_NS)
    sink.write(keys.node("ego-0"), b"", T0_NS)
    sink.write(keys.node("ego-1"), b"", T0_NS)
    sink.write(keys.world("weather"), m.WEATHER.encode(m.Weather(1, 0.0)), T0_NS)
    for k in range(int(seconds * 50)):
        t = k / 50
        at = T0_NS + round(t * 1e9) + LATENCY_NS
        for i in range(2):
            sink.write(keys.pose(f"ego-{i}", "t0_0"), m.POSE.encode(ego_pose(i, k, t)), at)
        if k % 2 == 0:
            rows = npc_rows(8, t)
            batch = m.NpcBatch.pack(k, t, [f"npc-{j}" for j in range(8)], rows)
            sink.write(keys.world("npc"), m.NPC_BATCH.encode(batch), at)
        if k % 50 == 0:
            sink.write(keys.world("lights"), m.LIGHTS.encode(light_state(k, t)), at)
    sink.close()


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "session.mcap"
    write_recording(path)
    return path


def _png(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"))


def test_still_follows_the_recorded_ego(recording: Path, tmp_path: Path, save_shot) -> None:
    outs = []
    for name in ("a", "b"):
        out = tmp_path / f"{name}.png"
        argv = ["render", str(recording), "--camera", "ego-0", "--at", "1.0", "--out", str(out),
                "--width", "320", "--height", "180"]  # fmt: skip
        assert main(argv) == 0
        outs.append(_png(out))
    save_shot("cli_ego0_t1", outs[0])
    assert outs[0].shape == (180, 320, 3)
    assert np.array_equal(outs[0], outs[1])  # the same recording at the same time
    free = tmp_path / "free.png"
    assert main(["render", str(recording), "--at", "1.0", "--out", str(free),
                 "--width", "320", "--height", "180"]) == 0  # fmt: skip
    save_shot("cli_free_t1", _png(free))
    assert not np.array_equal(_png(free), outs[0])


def test_recorded_world_shows_the_ego_where_it_was(recording: Path) -> None:
    from carlaverse.render.recording import RecordedWorld

    world = RecordedWorld(recording)
    frame = world.frame(1.0)
    assert {a.actor_id for a in frame.actors if a.ego} == {"ego-0", "ego-1"}
    assert len([a for a in frame.actors if not a.ego]) == 8
    for shown in world.view.ego_views(1.0):
        assert shown.render_t <= 1.0  # the view's one render time (past or present mode)
        truth = ego_pose(int(shown.actor_id[-1]), 0, shown.render_t)
        assert math.hypot(shown.x - truth.x, shown.y - truth.y) < 0.05


def test_clip(recording: Path, tmp_path: Path) -> None:
    import imageio_ffmpeg

    out = tmp_path / "clip.mp4"
    argv = ["render", str(recording), "--camera", "ego-1", "--at", "0.5", "--duration", "0.5",
            "--fps", "10", "--out", str(out), "--width", "160", "--height", "90"]  # fmt: skip
    assert main(argv) == 0
    frames = imageio_ffmpeg.read_frames(str(out))
    meta = next(frames)
    assert meta["size"] == (160, 90)
    assert sum(1 for _ in frames) == 5


def test_user_errors_are_one_line(recording: Path, tmp_path: Path, capsys) -> None:
    assert main(["render", str(recording), "--out", str(tmp_path / "x.gif")]) == 2
    assert (
        main(
            [
                "render",
                str(recording),
                "--camera",
                "nobody",
                "--at",
                "1.0",
                "--out",
                str(tmp_path / "x.png"),
                "--width",
                "64",
                "--height",
                "36",
            ]
        )
        == 1
    )
    err = capsys.readouterr().err
    assert "no actor 'nobody'" in err and "ego-0" in err and "Traceback" not in err
