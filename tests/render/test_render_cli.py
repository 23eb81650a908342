"""`carlaverse render` on a real MCAP file: a still where the recording says, twice the same,
and a clip that ffmpeg can read back."""

from __future__ import annotations

import math
import re
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


def documented_keys(heading: str) -> set[str]:
    """The backticked first-column keys of the table under `### heading` in docs/protocol.md."""
    doc = (Path(__file__).resolve().parents[2] / "docs" / "protocol.md").read_text("utf-8")
    section = doc.split(f"### {heading}\n", 1)[1].split("\n#", 1)[0]
    return set(re.findall(r"^\| `(\w+)` \|", section, re.M))


def _render_json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> dict:
    import json

    capsys.readouterr()  # what earlier calls printed
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_at_counts_seconds_from_the_recordings_start(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The recording's first sample (the map) was received at T0_NS; the first pose, of session
    # time 0, at T0_NS + LATENCY_NS: the recorder's clock runs LATENCY_NS ahead of the session
    # clock, so the recording starts at session time -0.003 s and --at 1.0 shows -0.003 + 1.0.
    start_s = -LATENCY_NS / 1e9
    size = ["--width", "160", "--height", "90"]
    at = tmp_path / "at.png"
    shown = _render_json(["render", str(recording), "--at", "1.0", "--out", str(at), *size], capsys)
    assert set(shown) == documented_keys("`carlaverse render --json`")
    assert shown["recording_start"] == pytest.approx(start_s, abs=1e-9)
    assert shown["t"] == pytest.approx(start_s + 1.0, abs=1e-9)
    assert shown["at"] == pytest.approx(1.0, abs=1e-9)
    # the same moment named on the session clock is the same picture
    same = tmp_path / "same.png"
    argv = ["render", str(recording), "--at-session", str(start_s + 1.0), "--out", str(same)]
    assert _render_json([*argv, *size], capsys)["t"] == pytest.approx(start_s + 1.0, abs=1e-9)
    assert np.array_equal(_png(at), _png(same))
    # without either flag: the first pose, at session time 0
    first = tmp_path / "first.png"
    assert _render_json(["render", str(recording), "--out", str(first), *size], capsys)["t"] == 0.0
    later = tmp_path / "later.png"
    argv = ["render", str(recording), "--at-session", "1.5", "--out", str(later), *size]
    assert _render_json(argv, capsys)["t"] == 1.5
    assert not np.array_equal(_png(at), _png(later))  # the NPCs moved 4 m along the road


def test_a_clip_past_the_end_is_said(recording: Path, tmp_path: Path, capsys) -> None:
    # the recording spans -0.003 ... 1.98 s of session time, 1.983 s: a clip from 1.8 s
    # for 0.5 s runs 1.8 + 0.5 - 1.983 = 0.317 s past it
    argv = ["render", str(recording), "--at", "1.8", "--duration", "0.5", "--fps", "4",
            "--width", "64", "--height", "36", "--out", str(tmp_path / "late.mp4")]  # fmt: skip
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "the clip runs 0.3 s past the recording's end (valid 0.0–1.9 s from start)" in err


def test_at_flags_are_checked(recording: Path, tmp_path: Path, capsys) -> None:
    out = str(tmp_path / "x.png")
    assert main(["render", str(recording), "--at", "-1", "--out", out]) == 2
    with pytest.raises(SystemExit) as exit_:  # argparse: the two name one moment twice
        main(["render", str(recording), "--at", "1", "--at-session", "1", "--out", out])
    assert exit_.value.code == 2
    assert main(["render", str(recording), "--chase", "--out", out]) == 2  # chase whom?
    err = capsys.readouterr().err
    # the recording spans session time -0.003 s (its map) to 1.98 s (its last pose): 1.983 s
    assert "--at -1 s is before the recording's start: valid 0.0–1.9 s from start" in err
    assert "--chase follows a node" in err


# The chase camera as the help states it: the eye 6 m behind the chased actor and 2.5 m above
# the road, looking at the point 4 m ahead of it and 1 m up (so pitched down atan(1.5/10)).
CHASE_BACK_M, CHASE_UP_M, AIM_AHEAD_M, AIM_UP_M = 6.0, 2.5, 4.0, 1.0
CHASED = m.Extent(4.5, 1.8, 1.5)  # [m] the chased car: length, width, height
CHASE_W, CHASE_H = 320, 180
CHASE_FOV_H = math.radians(90.0)  # rigs/rig-desktop


def write_chase_recording(path: Path, extent: m.Extent) -> None:
    """One ego driving east at 5 m/s from (0, 0), its extent in the snapshot, the sun overhead
    (any shadow falls inside the footprint), no map."""
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    sink.write(keys.node("ego-0"), b"", T0_NS)
    weather = m.Weather(1, 0.0, sun_altitude_deg=90.0)
    sink.write(keys.world("weather"), m.WEATHER.encode(weather), T0_NS)
    for k in range(100):
        t = k / 50
        pose = m.Pose(k, t, 5.0 * t, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0, 0.0)
        at = T0_NS + round(t * 1e9) + LATENCY_NS
        if k == 0:
            ego = m.EgoInfo("ego-0", "drive", "car", extent, 1350.0, pose_wire=pose)
            snapshot = m.Snapshot(m.SCHEMA_VERSION, t, [ego], weather=weather)
            sink.write(keys.authority("snapshot"), m.SNAPSHOT.encode(snapshot), at)
        sink.write(keys.pose("ego-0", "t0_0"), m.POSE.encode(pose), at)
    sink.close()


def _pixel(forward: float, left: float, up: float) -> tuple[float, float]:
    """(column, row) of a point given relative to the chase eye (forward, left, up) [m]."""
    pitch = math.atan2(CHASE_UP_M - AIM_UP_M, CHASE_BACK_M + AIM_AHEAD_M)
    depth = forward * math.cos(pitch) - up * math.sin(pitch)
    rise = forward * math.sin(pitch) + up * math.cos(pitch)
    fov_v = 2 * math.atan(math.tan(CHASE_FOV_H / 2) * CHASE_H / CHASE_W)
    col = CHASE_W / 2 * (1 - left / depth / math.tan(CHASE_FOV_H / 2))
    row = CHASE_H / 2 * (1 - rise / depth / math.tan(fov_v / 2))
    return col, row


def test_chase_camera_puts_the_actor_in_the_lower_middle(tmp_path: Path, save_shot) -> None:
    from tests.render.support import changed

    shots = {}
    for name, extent in (("car", CHASED), ("speck", m.Extent(0.01, 0.01, 0.01))):
        path = tmp_path / f"{name}.mcap"
        write_chase_recording(path, extent)
        out = tmp_path / f"{name}.png"
        argv = ["render", str(path), "--camera", "ego-0", "--chase", "--at-session", "1.0",
                "--out", str(out), "--width", str(CHASE_W), "--height", str(CHASE_H)]  # fmt: skip
        assert main(argv) == 0
        shots[name] = _png(out)
    save_shot("chase_car", shots["car"])
    # The same eye (it depends on the pose alone) with and without the car's body: what
    # changed is the car.
    rows, cols = np.nonzero(changed(shots["car"], shots["speck"]))
    assert len(rows) > 200, "the chased car is not in the picture"
    corners = [
        _pixel(CHASE_BACK_M + along, left, up - CHASE_UP_M)
        for along in (-CHASED.length / 2, CHASED.length / 2)
        for left in (-CHASED.width / 2, CHASED.width / 2)
        for up in (0.0, CHASED.height)
    ]
    col_lo, col_hi = min(c for c, _ in corners), max(c for c, _ in corners)
    row_lo, row_hi = min(r for _, r in corners), max(r for _, r in corners)
    tolerance = 3.0  # [px] rasterisation and anti-aliased edges
    assert col_lo - tolerance <= cols.min() and cols.max() <= col_hi + tolerance
    assert row_lo - tolerance <= rows.min() and rows.max() <= row_hi + tolerance
    assert abs(cols.mean() - CHASE_W / 2) < 0.02 * CHASE_W  # centred left to right
    assert CHASE_H / 2 < rows.mean() < 0.85 * CHASE_H  # below the middle: the lower middle
    assert (cols.max() - cols.min()) > 0.7 * (col_hi - col_lo)  # the whole car, not a sliver


def test_free_camera_on_an_empty_recording_is_an_error(tmp_path: Path, capsys) -> None:
    path = tmp_path / "empty.mcap"
    McapSink(path, monotonic=time.monotonic).close()
    out = tmp_path / "empty.png"
    assert main(["render", str(path), "--camera", "free", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no map and no actors" in err, err
    assert not out.exists()  # no empty picture left behind
