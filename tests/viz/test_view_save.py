"""`carlaverse view --save x.rrd`: one entity per actor at the published poses, lights, map."""

from __future__ import annotations

import bisect
import math
import signal
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from carlaverse import cli, messages
from carlaverse.keys import parse
from carlaverse.recording.recorder import Recorder
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import ego_pose, light_state, npc_rows, synthetic_map
from carlaverse.viz.scene import LIGHT_COLORS
from tests.recording.conftest import World
from tests.support import Proc, wait_until
from tests.viz.conftest import rrd_rows


def _published(world: World) -> dict[str, list]:
    """Decoded publications per kind: poses per ego, NPC batches, light states."""
    out: dict[str, list] = {"lights": [], "npc": []}
    for key, payload in world.synthetic.payloads or []:
        parsed = parse(key)
        if parsed.channel == "pose":
            out.setdefault(parsed.node_id, []).append(messages.POSE.decode(payload))
        elif parsed.channel == "lights":
            out["lights"].append(messages.LIGHTS.decode(payload))
        elif parsed.channel == "npc":
            out["npc"].append(messages.NPC_BATCH.decode(payload))
    return out


# Interpolating a 50 Hz pose stream of a 10 m/s, 20 m-radius circle with Hermite is exact
# to ~1e-5 m; what error there is comes from frames whose render time ran past the newest
# sample (a late delivery on a loaded machine): dead reckoning along the tangent for dt is
# off by v² dt² / 2r, 2.5 cm at dt = 0.1 s, and is then blended out over 0.1 s. So most
# frames are within 1 cm, nearly all within 5 cm (dt <= 0.14 s); 0.4 m is the limit of a
# 0.25 s extrapolation (v² dt² / 2r = 0.16 m) plus the float32 wire.
MEDIAN_ERROR_M = 0.01  # [m]
P95_ERROR_M = 0.05  # [m]
MAX_ERROR_M = 0.4  # [m]


def _errors(
    boxes: list[dict], truth: Callable[[float], tuple[float, float]], span: tuple[float, float]
) -> list[float]:
    """Distance of each logged box (at its render time) from the scripted path then."""
    out = []
    for row in boxes:
        t = row["sim_time"]
        if span[0] <= t <= span[1] and row.get("Boxes3D:centers"):
            x, y, _ = row["Boxes3D:centers"][0]
            tx, ty = truth(t)
            out.append(math.hypot(x - tx, y - ty))
    return out


def _assert_close(errors: list[float], what: str) -> None:
    assert len(errors) >= 10, f"{what}: only {len(errors)} frames in the published span"
    median, p95 = statistics.median(errors), statistics.quantiles(errors, n=20)[-1]
    summary = f"{what}: median {median:.4f} m, p95 {p95:.4f} m, max {max(errors):.4f} m"
    print(summary)
    assert median <= MEDIAN_ERROR_M, summary
    assert p95 <= P95_ERROR_M, summary
    assert max(errors) <= MAX_ERROR_M, summary


def _check_actors(rows: dict[str, list[dict]], published: dict[str, list], egos: list[str]) -> None:
    """Every ego and NPC at the scripted truth at the render times the view logged it."""
    for i, node_id in enumerate(egos):
        poses = published[node_id]
        span = (poses[0].t, poses[-1].t)
        boxes = rows[f"/world/egos/{node_id}"]
        errors = _errors(boxes, lambda t, i=i: _xy(ego_pose(i, 0, t)), span)
        _assert_close(errors, node_id)
        between = [r for r in boxes if not _has_sample(poses, r["sim_time"])]
        assert len(between) > len(boxes) // 2, "drawn at render times, not at the samples' times"
        assert boxes[0]["Boxes3D:labels"] == [node_id]  # then rerun keeps it (latest-at)
        assert boxes[0]["Boxes3D:half_sizes"] and boxes[0]["Boxes3D:colors"]
        z = boxes[0]["Boxes3D:centers"][0][2]
        assert z == pytest.approx(messages.Extent().height / 2, abs=1e-4)
        assert rows[f"/world/trails/{node_id}"], "a trajectory per ego"
    batches = published["npc"]
    span = (batches[0].t, batches[-1].t)
    assert rows["/world/trails/npcs"], "the NPCs' recent paths"
    count = len(batches[0].ids)
    for i, npc_id in enumerate(batches[0].ids):
        boxes = rows[f"/world/npcs/{npc_id}"]
        assert boxes[0]["Boxes3D:labels"] == [npc_id]
        truth = lambda t, i=i: tuple(float(v) for v in npc_rows(count, t)[i][["x", "y"]])  # noqa: E731
        _assert_close(_errors(boxes, truth, span), npc_id)


def _check_raw(rows: dict[str, list[dict]], published: dict[str, list], egos: list[str]) -> None:
    """`--raw`: every pose and NPC sample exactly as published, at its own time."""
    for node_id in egos:
        raw = rows[f"/world/raw/egos/{node_id}"]
        truth = sorted(published[node_id], key=lambda p: p.t)
        assert len(raw) == len(truth), f"{node_id}: {len(raw)} raw samples of {len(truth)}"
        for row in raw:
            pose = _at(truth, row["sim_time"])
            assert row["Points3D:positions"][0][:2] == pytest.approx(_xy(pose), abs=1e-4)
    batches = sorted(published["npc"], key=lambda b: b.t)
    raw = rows["/world/raw/npcs"]
    assert len(raw) == len(batches)
    for row in raw:
        r = _at(batches, row["sim_time"]).array()
        got = [c for p in row["Points3D:positions"] for c in p[:2]]  # x0, y0, x1, y1, ...
        want = [float(c) for xy in zip(r["x"], r["y"], strict=True) for c in xy]
        assert got == pytest.approx(want, abs=1e-4)  # pytest 9 compares flat sequences only


# Rerun keeps `sim_time` as integer nanoseconds, so a logged time reads back within 1 ns of
# the float64 it was logged at. Matching by round(t, 6) flaked: when t lies within that 1 ns
# of a half-microsecond boundary the two sides round apart (~1 sample in 2000, so about one
# run in four or five over the ~500 samples these tests match). Match by nearest instead.
SAME_TIME_S = 1e-6  # [s] far below the 20 ms between samples, far above the 1 ns stored


def _at(samples: list[Any], t: float) -> Any:
    """The sample (anything with `.t`, sorted by it) logged at time `t`; KeyError if none."""
    times = [s.t for s in samples]
    i = bisect.bisect_left(times, t - SAME_TIME_S)
    if i < len(samples) and abs(samples[i].t - t) <= SAME_TIME_S:
        return samples[i]
    raise KeyError(f"no sample at t = {t:.9f} s")


def _has_sample(samples: list[Any], t: float) -> bool:
    try:
        _at(samples, t)
    except KeyError:
        return False
    return True


def _xy(pose: messages.Pose) -> tuple[float, float]:
    return pose.x, pose.y


def _check_scene(rows: dict[str, list[dict]], published: dict[str, list], egos: list[str]) -> None:
    _check_actors(rows, published, egos)
    # light states: one point per controlled link, labelled and coloured by its state
    # (the synthetic light program is a function of time, snapshots included)
    light_rows = rows["/world/lights/J0"]
    assert len(light_rows) >= 2
    for row in light_rows:
        state = light_state(0, row["sim_time"]).lights[0].state
        assert [label.split()[-1] for label in row["Points3D:labels"]] == list(state)
        assert row["Points3D:colors"] == [_rgba(LIGHT_COLORS[c]) for c in state]
    # the map, static: every lane of the reply
    road_map = synthetic_map()
    lanes = [r for path, rs in rows.items() if path.startswith("/world/map/lanes/") for r in rs]
    assert all(r["static"] for r in lanes)
    assert sum(len(r["LineStrips3D:strips"]) for r in lanes) == len(road_map.lanes)


def _rgba(rgb: tuple[int, int, int]) -> int:
    """Rerun stores colours as 0xRRGGBBAA."""
    r, g, b = rgb
    return (r << 24) | (g << 16) | (b << 8) | 0xFF


def test_view_save_holds_interpolated_actors_raw_samples_lights_and_map(
    world: World, tmp_path: Path
) -> None:
    rrd = tmp_path / "x.rrd"
    counted: list[int] = []
    observer = world.connect()
    sub = observer.declare_subscriber("carlaverse/view/**", lambda s: counted.append(1))
    view = Proc(
        ["view", "--session", "view", "--connect", world.endpoint, "--save", str(rrd), "--raw"]
    )
    try:
        # the viewer subscribes, then asks for the map: once asked, it listens
        wait_until(lambda: world.synthetic.queries["map"], 20, "the viewer to ask for the map")
        world.wait_matched()
        world.publish_for(2.0)
        total = sum(world.synthetic.published.values())
        wait_until(lambda: len(counted) >= total, 10, "the session's samples delivered")
    finally:
        sub.undeclare()
        observer.close()
        code = view.stop(signal.SIGINT)
    assert code == 0, view.output()[-2000:]
    rows = rrd_rows(rrd)
    published = _published(world)
    _check_scene(rows, published, ["ego-0", "ego-1"])
    _check_raw(rows, published, ["ego-0", "ego-1"])
    assert rows["/world/impulses/ego-0"], "collision impulses as arrows"
    assert any("spawned ego-0" in r["TextLog:text"][0] for r in rows["/events"])
    assert rows["/weather/precipitation"] and rows["/weather/summary"]
    assert any(path.startswith("/stats/rate_hz/") for path in rows)
    assert any(path.startswith("/stats/latency_ms/") for path in rows)


def test_view_renders_a_recording(world: World, tmp_path: Path) -> None:
    mcap = tmp_path / "session.mcap"
    session = world.connect()
    recorder = Recorder(session, world.synthetic.keys, McapSink(mcap, monotonic=time.monotonic))
    try:
        recorder.start()
        world.wait_matched()
        world.publish_for(1.5)
        total = sum(world.synthetic.published.values())
        wait_until(lambda: recorder.stats().received >= total, 10, f"{total} samples")
        wait_until(lambda: recorder.stats().written >= total + 3, 10, "map and snapshot kept")
        recorder.stop()
    finally:
        session.close()
    published = _published(world)
    rrd, raw_rrd = tmp_path / "from-mcap.rrd", tmp_path / "from-mcap-raw.rrd"
    assert cli.main(["view", str(mcap), "--save", str(rrd)]) == 0
    rows = rrd_rows(rrd)
    _check_scene(rows, published, ["ego-0", "ego-1"])
    assert not [path for path in rows if path.startswith("/world/raw")], "raw only with --raw"
    assert cli.main(["view", str(mcap), "--save", str(raw_rrd), "--raw"]) == 0
    raw_rows = rrd_rows(raw_rrd)
    _check_raw(raw_rows, published, ["ego-0", "ego-1"])
    _check_actors(raw_rows, published, ["ego-0", "ego-1"])


def test_view_refuses_without_an_output(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["view", "--session", "x"]) == 2
    assert "choose an output" in capsys.readouterr().err
    assert "EXPOSES" in _help_text()


def _help_text() -> str:
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
        cli.main(["view", "--help"])
    return out.getvalue()
