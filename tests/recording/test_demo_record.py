"""`carlaverse demo --record FILE.mcap --rrd FILE.rrd` keeps both, and both hold the session."""

from __future__ import annotations

import bisect
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from carlaverse import messages
from carlaverse.keys import Keys, parse
from carlaverse.recording.archive import CONFIG_ATTACHMENT, SCENARIO_ATTACHMENT
from carlaverse.recording.reading import iter_samples, read_attachments, read_metadata
from tests.recorded_demo import RecordedDemo
from tests.viz.conftest import rrd_rows

AUTHORITY_STREAMS = ("events", "lights", "npc", "weather")  # what the authority counts as sent


@pytest.fixture(scope="module")
def demo(recorded_demo: RecordedDemo) -> tuple[dict, Path, Path]:
    """The suite's one recorded demo (tests/recorded_demo.py): `demo --duration 8 --json
    --quiet --record FILE.mcap --rrd FILE.rrd`."""
    summary = recorded_demo.summary
    assert summary["tools"] == {"recorder": 0, "viewer": 0}
    return summary, recorded_demo.mcap, recorded_demo.rrd


def test_demo_recording_has_every_key_the_counts_and_the_configs(demo: tuple) -> None:
    summary, mcap, _ = demo
    keys = Keys("demo")
    samples = list(iter_samples(mcap))
    counts = Counter(s.key for s in samples)
    nodes = list(summary["nodes"])
    # A pose's key ends in the tile the node is in: count them per node, whatever the tile.
    poses = Counter(parse(s.key).node_id for s in samples if parse(s.key).channel == "pose")
    assert set(nodes) <= set(poses), poses
    expected = {keys.world(c) for c in AUTHORITY_STREAMS}
    expected |= {keys.authority(q) for q in ("map", "scenario", "snapshot", "configs")}
    expected |= {keys.node(n) for n in nodes}
    assert expected <= set(counts), sorted(expected - set(counts))
    # Exact for every stream, NPC batches included: the demo starts the authority only after
    # the recorder said it is subscribed (else a loaded host loses the first world/lights put),
    # and stops the authority before the recorder and the router (else its last put, counted
    # as sent, reaches nobody).
    sent_by_stream = summary["authority"]["sent"]
    for stream in AUTHORITY_STREAMS:
        sent = sent_by_stream[stream]
        assert counts[keys.world(stream)] == sent, (
            f"world/{stream}: sent {sent}; recorded at session times "
            f"{[round(x.publish_time_ns / 1e9, 3) for x in samples if x.key == keys.world(stream)]}"
            f" (the demo ran {summary['authority']['tick']})"
        )
    # Audio scenes (audio/<id>, one per listener every 50 ms) are best effort like poses: a
    # bound. The recorder may read every participant's audio (docs/architecture.md §12).
    audio = sum(counts[keys.audio(n)] for n in nodes)
    assert 0.9 * sent_by_stream["audio"] <= audio <= sent_by_stream["audio"], (
        audio,
        sent_by_stream,
    )
    # Poses are DROP class, so a bound, not a count; against what each node says it sent,
    # not the nominal 50 Hz, which a loaded machine does not keep.
    for n in nodes:
        sent = summary["nodes"][n]["poses_sent"]
        assert sent > 50 and 0.9 * sent <= poses[n] <= sent, (n, sent)

    # attachments hold the configs as the authority has them, byte for byte
    attachments = read_attachments(mcap)
    last_configs = [s for s in samples if s.key == keys.authority("configs")][-1]
    reply = messages.CONFIGS.decode(last_configs.payload)
    for n in nodes:
        data = attachments[CONFIG_ATTACHMENT.format(node_id=n)]
        assert data == reply.nodes[n].encode()
        assert yaml.safe_load(data)["node"]["node_id"] == n
    scenario = [s for s in samples if s.key == keys.authority("scenario")][-1]
    assert (
        attachments[SCENARIO_ATTACHMENT] == messages.SCENARIO.decode(scenario.payload).yaml.encode()
    )
    meta = read_metadata(mcap)
    assert meta["carlaverse.session"]["session"] == "demo"
    assert set(nodes) <= set(meta["carlaverse.roster"])


# The view draws each actor at one render time per frame, interpolated between its samples
# (tests/viz/test_view_save.py), so a box lies on the recorded path at its render time. The
# scripted paths are circles of r >= 25 m at <= 14 m/s sampled at 50 Hz: a chord strays
# (v dt)^2 / 8r = 0.2 mm from the arc, so most frames are within 1 cm. A frame whose render
# time ran past the newest sample (a late delivery on a loaded machine) is extrapolated:
# v^2 dt^2 / 2r = 4 cm at dt = 0.1 s, 0.25 m at 0.25 s.
MEDIAN_ERROR_M = 0.01  # [m]
P95_ERROR_M = 0.1  # [m]
MAX_ERROR_M = 0.5  # [m]


def _assert_on_recorded_path(node_id: str, boxes: list[dict], poses: list) -> None:
    """Each box, at its render time, near the recorded path linearly interpolated then."""
    t = np.array([p.t for p in poses])
    xs, ys = np.array([p.x for p in poses]), np.array([p.y for p in poses])
    inside = [r for r in boxes if t[0] <= r["sim_time"] <= t[-1]]
    assert len(inside) > 50, f"{node_id}: {len(inside)} of {len(boxes)} boxes in the recorded span"
    times = np.array([r["sim_time"] for r in inside])
    drawn = np.array([r["Boxes3D:centers"][0][:2] for r in inside])
    errors = np.hypot(drawn[:, 0] - np.interp(times, t, xs), drawn[:, 1] - np.interp(times, t, ys))
    summary = (
        f"{node_id}: median {np.median(errors):.4f} m, p95 {np.percentile(errors, 95):.4f} m, "
        f"max {errors.max():.4f} m over {len(errors)} frames"
    )
    print(summary)
    assert np.median(errors) <= MEDIAN_ERROR_M, summary
    assert np.percentile(errors, 95) <= P95_ERROR_M, summary
    assert errors.max() <= MAX_ERROR_M, summary


def test_demo_rrd_has_the_actors_on_recorded_paths_lights_and_map(demo: tuple) -> None:
    summary, mcap, rrd = demo
    rows = rrd_rows(rrd)
    poses: dict[str, dict[float, messages.Pose]] = {}
    lights: dict[float, messages.LightsState] = {}
    road_map = None
    for s in iter_samples(mcap):
        parsed = parse(s.key)
        if parsed.channel == "pose":
            pose = messages.POSE.decode(s.payload)
            poses.setdefault(parsed.node_id, {})[round(pose.t, 6)] = pose
        elif parsed.channel == "lights":
            state = messages.LIGHTS.decode(s.payload)
            lights[state.t] = state
        elif parsed.channel == "map":
            road_map = messages.MAP.decode(s.payload)
    for n in summary["nodes"]:
        boxes = [r for r in rows[f"/world/egos/{n}"] if r.get("Boxes3D:centers")]  # not Clears
        _assert_on_recorded_path(n, boxes, sorted(poses[n].values(), key=lambda p: p.t))
    assert road_map is not None
    lanes = [r for path, rs in rows.items() if path.startswith("/world/map/lanes/") for r in rs]
    assert sum(len(r["LineStrips3D:strips"]) for r in lanes) == len(road_map.lanes)
    light_paths = [p for p in rows if p.startswith("/world/lights/")]
    assert light_paths
    checked = 0
    for path in light_paths:
        tls = path.rsplit("/", 1)[-1]
        for row in rows[path]:
            state = _same_time(lights, row["sim_time"])
            if state is None:
                continue  # from the authority's snapshot, not a published state
            truth = next(x.state for x in state.lights if x.id == tls)
            shown = "".join(label.split()[-1] for label in row["Points3D:labels"])
            assert shown == truth, (tls, shown, truth)
            checked += 1
    assert checked >= len(light_paths), "every light shown at a published state"


SAME_TIME_S = 1e-6  # [s] far below the time between states, far above the 1 ns rerun stores


def _same_time(by_time: dict[float, Any], t: float) -> Any:
    """The entry logged at t. Rerun keeps integer nanoseconds, so rounding both sides to the
    microsecond splits times within 1 ns of a half-microsecond boundary: match by nearest."""
    times = sorted(by_time)
    i = bisect.bisect_left(times, t - SAME_TIME_S)
    return by_time[times[i]] if i < len(times) and abs(times[i] - t) <= SAME_TIME_S else None
