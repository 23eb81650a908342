"""`carlaverse view --save x.rrd`: one entity per actor at the published poses, lights, map."""

from __future__ import annotations

import bisect
import math
import signal
import statistics
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from carlaverse import cli, messages
from carlaverse.keys import parse
from carlaverse.recording.reading import iter_samples
from carlaverse.recording.recorder import Recorder
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import (
    SyntheticSpec,
    ego_pose,
    light_state,
    npc_rows,
    synthetic_map,
)
from carlaverse.viz.live import viewer_interpolation
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
# sample: dead reckoning along the tangent for dt is off by v² dt² / 2r, 2.5 cm at
# dt = 0.1 s, and is then blended out over 0.1 s. So most frames are within 1 cm, nearly all
# within 5 cm (dt <= 0.14 s); 0.4 m is the limit of a 0.25 s extrapolation
# (v² dt² / 2r = 0.16 m) plus the float32 wire.
MEDIAN_ERROR_M = 0.01  # [m]
P95_ERROR_M = 0.05  # [m]
MAX_ERROR_M = 0.4  # [m]
# A sample that came late (sent or received late: a pause of the loaded test process or of
# its delivery) leaves the view nothing to interpolate towards: it dead-reckons, as it must,
# while the sample is missing, for at most max_extrapolation_s, then holds the actor there
# while the truth drives on; when the sample comes, the error decays with time constant
# blend_time_s. Frames drawn from a late sample's predecessor until that error is below
# MEDIAN_ERROR_M are excused the bounds above: they are held to MAX_ERROR_M plus the way
# driven in the part of the hole past the extrapolation limit (a stall of 0.5 s leaves the
# view 1.5 m behind, and it takes 0.5 s to decay). Late: sent or received more than
# LATE_INTERVALS send intervals after the previous sample, at the typical latency.
LATE_INTERVALS = 3
POSE_INTERVAL_S = 1 / SyntheticSpec().pose_hz
NPC_INTERVAL_S = 1 / SyntheticSpec().npc_hz
EGO_SPEED_MPS = 10.0  # synthetic.ego_pose
NPC_SPEED_MPS = 8.0  # synthetic.npc_rows
VIEW = viewer_interpolation()
# A session is published until it has run STEADY_S in one stretch of steps no longer than
# a pose's late limit: under load, stalls once left a 1.5 s recording 6 frames to judge;
# such a stretch gives 20 or more (frames at 20 Hz, less the decay of a stall before it).
STEADY_S = 1.5  # [s]
STEADY_GAP_S = LATE_INTERVALS * POSE_INTERVAL_S


@dataclass(frozen=True)
class Late:
    """A sample that came late: frames drawn in (start, end) are held to `allowed_m` only."""

    start: float  # [s] its predecessor's time
    end: float  # [s] when the error it revealed has decayed below MEDIAN_ERROR_M
    allowed_m: float  # [m]


Errors = tuple[list[float], list[float]]  # (frames with a sample to approach, frames without)


def _errors(
    boxes: list[dict],
    truth: Callable[[float], tuple[float, float]],
    span: tuple[float, float],
    late: list[Late],
) -> Errors:
    """Distance of each logged box (at its render time) from the scripted path then, split
    by whether its render time lies in a `late` span; an excused frame is checked here
    against its span's allowance."""
    judged: list[float] = []
    excused: list[float] = []
    for row in boxes:
        t = row["sim_time"]
        if not (span[0] <= t <= span[1] and row.get("Boxes3D:centers")):
            continue
        x, y, _ = row["Boxes3D:centers"][0]
        tx, ty = truth(t)
        error = math.hypot(x - tx, y - ty)
        holes = [s for s in late if s.start < t < s.end]
        if not holes:
            judged.append(error)
            continue
        allowed = max(s.allowed_m for s in holes)
        assert error <= allowed, f"{error:.3f} m off at t = {t:.3f} s, {allowed:.3f} m allowed"
        excused.append(error)
    return judged, excused


def _late(
    sent: list[float], received: list[float], interval_s: float, speed_mps: float
) -> list[Late]:
    """The samples that came late, from their send and receive times (on any clock)."""
    typical = statistics.median(r - t for t, r in zip(sent, received, strict=True))
    limit = typical + LATE_INTERVALS * interval_s
    out = []
    for i in range(1, len(sent)):
        if received[i] - sent[i - 1] > limit:
            came = received[i] - typical  # when it came, as a send time
            hole_s = came - sent[i - 1]  # the view went without a sample this long
            allowed_m = MAX_ERROR_M + speed_mps * max(0.0, hole_s - VIEW.max_extrapolation_s)
            decay_s = VIEW.blend_time_s * math.log(allowed_m / MEDIAN_ERROR_M)
            out.append(Late(sent[i - 1], came + decay_s, allowed_m))
    return out


def _assert_close(errors: Errors, what: str) -> None:
    judged, excused = errors
    assert len(judged) >= 10, f"{what}: only {len(judged)} frames with a sample to approach"
    median, p95 = statistics.median(judged), statistics.quantiles(judged, n=20)[-1]
    worst = max(judged)
    summary = (
        f"{what}: median {median:.4f} m, p95 {p95:.4f} m, max {worst:.4f} m "
        f"({len(excused)} frames drawn with a sample late, max {max(excused, default=0):.4f} m)"
    )
    print(summary)
    assert median <= MEDIAN_ERROR_M, summary
    assert p95 <= P95_ERROR_M, summary
    assert worst <= MAX_ERROR_M, summary


def _check_actors(
    rows: dict[str, list[dict]],
    published: dict[str, list],
    egos: list[str],
    received: dict[str, dict[float, float]],
) -> None:
    """Every ego and NPC at the scripted truth at the render times the view logged it;
    `received`: per ego (and `npc`), each sample's receive time by its time."""

    def late(what: str, sent: list[float], interval_s: float, speed_mps: float) -> list[Late]:
        return _late(sent, [received[what][t] for t in sent], interval_s, speed_mps)

    for i, node_id in enumerate(egos):
        poses = published[node_id]
        span = (poses[0].t, poses[-1].t)
        boxes = rows[f"/world/egos/{node_id}"]
        sent = sorted(p.t for p in poses)
        errors = _errors(boxes, lambda t, i=i: _xy(ego_pose(i, 0, t)), span,
                         late(node_id, sent, POSE_INTERVAL_S, EGO_SPEED_MPS))  # fmt: skip
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
        sent = sorted(b.t for b in batches)
        errors = _errors(boxes, truth, span, late("npc", sent, NPC_INTERVAL_S, NPC_SPEED_MPS))
        _assert_close(errors, npc_id)


def _received(mcap: Path) -> dict[str, dict[float, float]]:
    """When the recorder received each pose and NPC batch: see `_receipts`."""
    return _receipts((s.key, s.payload, s.log_time_ns / 1e9) for s in iter_samples(mcap))


def _receipts(samples: Iterable[tuple[str, bytes, float]]) -> dict[str, dict[float, float]]:
    """When each pose (per ego) and NPC batch (`npc`) of (key, payload, receive time) was
    received, by its time."""
    out: dict[str, dict[float, float]] = {}
    for key, payload, rx_t in samples:
        parsed = parse(key)
        if parsed.channel == "pose":
            what, t = parsed.node_id, messages.POSE.decode(payload).t
        elif parsed.channel == "npc":
            what, t = "npc", messages.NPC_BATCH.decode(payload).t
        else:
            continue
        out.setdefault(what, {})[t] = rx_t
    return out


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


def _check_scene(
    rows: dict[str, list[dict]],
    published: dict[str, list],
    egos: list[str],
    received: dict[str, dict[float, float]],
) -> None:
    _check_actors(rows, published, egos, received)
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
    # what an observer received when: the view's receive times, as near as this process sees
    # them (a stall of this process delays both), so a late delivery is told apart
    heard: list[tuple[str, bytes, float]] = []
    observer = world.connect()
    sub = observer.declare_subscriber(
        "carlaverse/view/**",
        lambda s: heard.append((str(s.key_expr), s.payload.to_bytes(), time.monotonic())),
    )
    view = Proc(
        ["view", "--session", "view", "--connect", world.endpoint, "--save", str(rrd), "--raw"]
    )
    try:
        # the viewer subscribes, then asks for the map: once asked, it listens
        wait_until(lambda: world.synthetic.queries["map"], 20, "the viewer to ask for the map")
        world.wait_matched()
        world.publish_steady(2.0, STEADY_S, STEADY_GAP_S)
        total = sum(world.synthetic.published.values())
        wait_until(lambda: len(heard) >= total, 10, "the session's samples delivered")
    finally:
        sub.undeclare()
        observer.close()
        code = view.stop(signal.SIGINT)
    assert code == 0, view.output()[-2000:]
    rows = rrd_rows(rrd)
    published = _published(world)
    _check_scene(rows, published, ["ego-0", "ego-1"], _receipts(heard))
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
        world.publish_steady(1.5, STEADY_S, STEADY_GAP_S)
        total = sum(world.synthetic.published.values())
        wait_until(lambda: recorder.stats().received >= total, 10, f"{total} samples")
        wait_until(lambda: recorder.stats().written >= total + 3, 10, "map and snapshot kept")
        recorder.stop()
    finally:
        session.close()
    published, received = _published(world), _received(mcap)
    rrd, raw_rrd = tmp_path / "from-mcap.rrd", tmp_path / "from-mcap-raw.rrd"
    assert cli.main(["view", str(mcap), "--save", str(rrd)]) == 0
    rows = rrd_rows(rrd)
    _check_scene(rows, published, ["ego-0", "ego-1"], received)
    assert not [path for path in rows if path.startswith("/world/raw")], "raw only with --raw"
    assert cli.main(["view", str(mcap), "--save", str(raw_rrd), "--raw"]) == 0
    raw_rows = rrd_rows(raw_rrd)
    _check_raw(raw_rows, published, ["ego-0", "ego-1"])
    _check_actors(raw_rows, published, ["ego-0", "ego-1"], received)


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
