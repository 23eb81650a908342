"""`carlaverse view --save x.rrd`: one entity per actor at the published poses, lights, map."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest

from carlaverse import cli, messages
from carlaverse.keys import parse
from carlaverse.recording.recorder import Recorder
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import light_state, synthetic_map
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


def _check_scene(rows: dict[str, list[dict]], published: dict[str, list], egos: list[str]) -> None:
    # an entity per actor, its boxes exactly at published poses (float32 on the wire)
    for node_id in egos:
        boxes = rows[f"/world/egos/{node_id}"]
        truth = {round(p.t, 6): p for p in published[node_id]}
        assert len(boxes) >= 5, f"{node_id}: only {len(boxes)} frames"
        for row in boxes:
            pose = truth[round(row["sim_time"], 6)]
            x, y, z = row["Boxes3D:centers"][0]
            assert (x, y) == pytest.approx((pose.x, pose.y), abs=1e-4)
            assert z == pytest.approx(pose.z + messages.Extent().height / 2, abs=1e-4)
        assert boxes[0]["Boxes3D:labels"] == [node_id]  # then rerun keeps it (latest-at)
        assert boxes[0]["Boxes3D:half_sizes"] and boxes[0]["Boxes3D:colors"]
        assert rows[f"/world/trails/{node_id}"], "a trajectory per ego"
    batches = {round(b.t, 6): b for b in published["npc"]}
    assert rows["/world/trails/npcs"], "the NPCs' recent paths"
    for i, npc_id in enumerate(published["npc"][0].ids):
        assert rows[f"/world/npcs/{npc_id}"][0]["Boxes3D:labels"] == [npc_id]
        for row in rows[f"/world/npcs/{npc_id}"]:
            r = batches[round(row["sim_time"], 6)].array()[i]
            assert row["Boxes3D:centers"][0][:2] == pytest.approx((r["x"], r["y"]), abs=1e-4)
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


def test_view_save_holds_actors_lights_and_map(world: World, tmp_path: Path) -> None:
    rrd = tmp_path / "x.rrd"
    counted: list[int] = []
    observer = world.connect()
    sub = observer.declare_subscriber("carlaverse/view/**", lambda s: counted.append(1))
    view = Proc(["view", "--session", "view", "--connect", world.endpoint, "--save", str(rrd)])
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
    _check_scene(rows, _published(world), ["ego-0", "ego-1"])
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
    rrd = tmp_path / "from-mcap.rrd"
    assert cli.main(["view", str(mcap), "--save", str(rrd)]) == 0
    _check_scene(rrd_rows(rrd), _published(world), ["ego-0", "ego-1"])


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
