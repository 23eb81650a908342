"""`carlaverse analyze` on a recording made by hand: a participant closing on a car stopped at
a stop line, and two NPCs queued nose to tail at another. Every expected number is worked out
here from the scene's geometry, not read from the analysis."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from carlaverse import messages as m
from carlaverse.cli import main
from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink

T0_NS = 1_700_000_000 * 10**9  # [ns] the recorder's wall clock at the recording's start
LATENCY_NS = 3_000_000  # [ns] every sample arrives 3 ms after its session time
SESSION_T0_S = 100.0  # [s] session time at the recording's start (the recorder joined late)
SECONDS = 3.0  # [s] recorded
CAR = m.Extent(4.5, 1.8, 1.5)  # [m] every road user here
EGO_X0, EGO_SPEED = -40.0, 10.0  # [m], [m/s] the participant drives east on y = 0
STOPPED_X = -CAR.length / 2  # [m] its front on the stop line at x = 0
QUEUE_Y = 100.0  # [m] the queue's road: far from the participant's, so never paired with it
QUEUE_GAP_M, CREEP_MPS = 1.5, 0.4  # the follower creeps towards the stopped one ahead
FOLLOWER_X0 = STOPPED_X - CAR.length - QUEUE_GAP_M  # [m] centre: a car length plus the gap back
LANES = [  # two approaches to stop lines at x = 0
    m.MapLane("west_0", "road", 3.5, [(-100.0, 0.0), (0.0, 0.0)]),
    m.MapLane("queue_0", "road", 3.5, [(-100.0, QUEUE_Y), (0.0, QUEUE_Y)]),
]
NPC_IDS = ["stopped", "queue-head", "queue-creeper"]


def npc_rows(t: float) -> np.ndarray:
    """[t: s from the start] the stopped car, the queue's head (stopped) and its creeper."""
    rows = np.zeros(3, dtype=m.NPC_DTYPE)
    rows["x"] = [STOPPED_X, STOPPED_X, FOLLOWER_X0 + CREEP_MPS * t]
    rows["y"] = [0.0, QUEUE_Y, QUEUE_Y]
    rows["vx"] = [0.0, 0.0, CREEP_MPS]
    rows["length"], rows["width"], rows["height"] = CAR.length, CAR.width, CAR.height
    rows["kind"] = 0  # car
    return rows


def write_recording(path: Path) -> None:
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    bounds = (-100.0, -10.0, 10.0, 110.0)
    road_map = m.MapReply(m.SCHEMA_VERSION, "stop-lines", bounds, LANES)
    sink.write(keys.authority("map"), m.MAP.encode(road_map), T0_NS + LATENCY_NS)
    for k in range(int(SECONDS * 50) + 1):  # poses at 50 Hz, NPC batches at 25 Hz
        t = k / 50
        at = T0_NS + round(t * 1e9) + LATENCY_NS
        x = EGO_X0 + EGO_SPEED * t
        pose = m.Pose(k, SESSION_T0_S + t, x, 0.0, 0.0, 0.0, 0.0, 0.0, EGO_SPEED, 0.0)
        if k == 0:
            ego = m.EgoInfo("ego-0", "drive", "car", CAR, 1350.0, pose_wire=pose)
            snapshot = m.Snapshot(m.SCHEMA_VERSION, SESSION_T0_S, [ego])
            sink.write(keys.authority("snapshot"), m.SNAPSHOT.encode(snapshot), at)
        sink.write(keys.pose("ego-0", "t0_0"), m.POSE.encode(pose), at)
        if k % 2 == 0:
            batch = m.NpcBatch.pack(k, SESSION_T0_S + t, NPC_IDS, npc_rows(t))
            sink.write(keys.world("npc"), m.NPC_BATCH.encode(batch), at)
    sink.close()


@pytest.fixture(scope="module")
def analysis(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    tmp = tmp_path_factory.mktemp("queue")
    mcap, out = tmp / "stop-lines.mcap", tmp / "analysis"
    write_recording(mcap)
    done = subprocess.run(
        [sys.executable, "-m", "carlaverse", "analyze", str(mcap), "--out", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout), out


# The participant's front is at EGO_X0 + 2.25 + 10 t, the stopped car's rear at -4.5: the gap
# is 33.25 - 10 t m, 3.25 m at the end (t = 3 s). Grid: 10 Hz from the start.
def gap_m(t: float) -> float:
    return -CAR.length - (EGO_X0 + CAR.length / 2 + EGO_SPEED * t)


def test_the_participants_pair_comes_first_with_ttc_and_drac_by_hand(analysis) -> None:
    _, out = analysis
    pairs = pq.read_table(out / "pairs.parquet").to_pylist()
    human = pairs[0]
    assert (human["a"], human["b"], human["human"]) == ("ego-0", "stopped", True)
    # TTC = gap / closing speed, least at the last sample: 3.25 / 10
    assert human["min_ttc_s"] == pytest.approx(gap_m(3.0) / EGO_SPEED, abs=1e-4)
    assert human["t_min_ttc_rel_s"] == pytest.approx(3.0, abs=1e-6)
    assert human["t_min_ttc"] == pytest.approx(SESSION_T0_S + 3.0, abs=1e-6)
    # below 1.5 s while the gap is under 15 m: t > 1.825 s, the 12 samples 1.9 ... 3.0
    assert human["ttc_below_s"] == pytest.approx(1.2, abs=1e-6)
    # DRAC = v^2 / (2 gap) = 50 / gap: within the 10 m/s^2 friction limit while gap >= 5 m,
    # t <= 2.825 s; the last such sample, t = 2.8 s, gap 5.25 m, is the headline. At 2.9 and
    # 3.0 s (0.2 s) it is above: flagged, and its peak 100 / 6.5 kept apart.
    assert human["max_drac_mps2"] == pytest.approx(EGO_SPEED**2 / (2 * gap_m(2.8)), rel=1e-4)
    assert human["t_max_drac_rel_s"] == pytest.approx(2.8, abs=1e-6)
    assert human["drac_implausible_s"] == pytest.approx(0.2, abs=1e-6)
    assert human["peak_drac_mps2"] == pytest.approx(EGO_SPEED**2 / (2 * gap_m(3.0)), rel=1e-4)
    assert (human["a_kind"], human["a_lane"], human["b_kind"], human["b_lane"]) == (
        "car", "west_0", "car", "west_0")  # fmt: skip


def test_the_queue_at_standstill_is_no_encounter(analysis) -> None:
    summary, out = analysis
    pairs = pq.read_table(out / "pairs.parquet").to_pylist()
    assert [(p["a"], p["b"]) for p in pairs] == [
        ("ego-0", "stopped"), ("queue-creeper", "queue-head")]  # fmt: skip
    queue = pairs[1]
    # Creeping at 0.4 m/s over 3 s closes the 1.5 m gap to 0.3 m: a TTC of 0.3 / 0.4 s were
    # the queue an encounter. Both slower than 0.5 m/s throughout: left out, all 31 samples.
    assert math.isinf(queue["min_ttc_s"]) and queue["ttc_below_s"] == 0.0
    assert queue["queued_s"] == pytest.approx(3.1, abs=1e-6)
    assert queue["min_gap_m"] == pytest.approx(QUEUE_GAP_M - CREEP_MPS * SECONDS, abs=1e-4)
    assert queue["max_drac_mps2"] == 0.0
    assert summary["pairs_ttc_below_threshold"] == 1  # the participant's pair alone
    assert summary["human_pairs_ttc_below_threshold"] == 1
    assert summary["pairs_queued"] == 1 and summary["pairs_drac_implausible"] == 1
    assert summary["min_ttc_pair"] == summary["human_min_ttc_pair"] == ["ego-0", "stopped"]
    assert summary["human_min_ttc_s"] == pytest.approx(gap_m(3.0) / EGO_SPEED, abs=1e-4)
    assert summary["min_ttc_at_s"] == pytest.approx(3.0, abs=1e-6)
    assert summary["max_drac_mps2"] == pytest.approx(50 / gap_m(2.8), rel=1e-4)
    assert summary["max_drac_mps2"] <= summary["drac_limit_mps2"] == 10.0
    assert summary["recording_start"] == pytest.approx(SESSION_T0_S, abs=1e-9)


def test_every_id_is_explained_and_times_count_from_the_start(analysis) -> None:
    _, out = analysis
    actors = {a["actor"]: a for a in pq.read_table(out / "actors.parquet").to_pylist()}
    assert set(actors) == {"ego-0", *NPC_IDS}
    assert actors["ego-0"]["human"] and not actors["stopped"]["human"]
    assert {a["kind"] for a in actors.values()} == {"car"}
    assert actors["ego-0"]["route"] == "west_0" and actors["queue-creeper"]["route"] == "queue_0"
    assert actors["stopped"]["first_seen_rel_s"] == pytest.approx(0.0, abs=1e-6)
    assert actors["stopped"]["last_seen_rel_s"] == pytest.approx(SECONDS, abs=1e-6)
    trajectories = pq.read_table(out / "trajectories.parquet")
    rel = trajectories["t_rel_s"].to_numpy()
    assert rel.min() == pytest.approx(0.0, abs=1e-6) and rel.max() == pytest.approx(3.0, abs=1e-6)
    page = (out / "report.html").read_text()
    assert page.index("ego-0 (car, lane west_0)") < page.index("Crossing conflicts")
    assert "queue-creeper (car" not in page  # the queue does not fill the pairs table
    assert "NPC-only pairs never on a collision course are not listed here: 1" in page
    assert "μg = 9.8 m/s² for μ = 1" in page and "slower than 0.5 m/s" in page


def test_without_the_queue_rule_the_creeping_queue_is_critical(
    analysis, tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    # --standstill 0: nothing counts as standing, so the creeper's approach is measured as any
    # other: the 1.5 m gap closes at 0.4 m/s to 0.3 m at t = 3 s, TTC 0.3 / 0.4 = 0.75 s.
    mcap = next(analysis[1].parent.glob("*.mcap"))
    done = subprocess.run(
        [sys.executable, "-m", "carlaverse", "analyze", str(mcap), "--out", str(tmp_path),
         "--standstill", "0"], capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    queue = pq.read_table(tmp_path / "pairs.parquet").to_pylist()[1]
    assert queue["min_ttc_s"] == pytest.approx(0.3 / CREEP_MPS, abs=1e-3)
    assert queue["queued_s"] == 0.0
    assert json.loads(done.stdout)["pairs_ttc_below_threshold"] == 2
    argv = ["analyze", str(mcap), "--out", str(tmp_path), "--standstill", "-1"]
    assert main(argv) == 2
    assert "--standstill must be >= 0, got -1.0" in capfd.readouterr().err
