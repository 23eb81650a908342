"""A late joiner's snapshot parts: every NPC, every light and the weather, as sent last."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.messages import SCHEMA_VERSION, SNAPSHOT, Snapshot
from tests.traffic.helpers import T0, TICK_S, domain_of, run


def test_snapshot_parts_hold_all_npcs_lights_and_weather(net_cache: Path) -> None:
    with domain_of("town", net_cache) as domain:
        assert domain.snapshot_parts() == (None, None, None)  # before the first tick
        out = MemoryOutbox()
        t = run(domain, out, T0, 10.0)
        for _ in range(5):  # until a tick that published a batch (20 Hz of 50 Hz ticks)
            if abs(out.npcs[-1].t - (t - TICK_S)) < 1e-9:
                break
            t = run(domain, out, t, TICK_S)
        npc, lights, weather = domain.snapshot_parts()
        frame = domain.engine.npcs()
        assert npc is out.npcs[-1]
        assert npc.ids == frame.ids and len(npc.ids) >= 40
        rows, step = npc.array(), domain.engine.step_length_s
        for column in ("kind", "length", "width", "height", "yaw_rate", "lights"):
            assert (rows[column] == frame.rows[column]).all(), column
        # Dead reckoning at a constant turn rate keeps an NPC's speed and turns its velocity
        # with its heading (docs/architecture.md, one motion model): the same speed, and the
        # velocity turned from the step's by the heading turned since (float32 rows).
        assert np.allclose(np.hypot(rows["vx"], rows["vy"]),
                           np.hypot(frame.rows["vx"], frame.rows["vy"]), atol=1e-3)  # fmt: skip
        turned = np.arctan2(rows["vy"], rows["vx"]) - np.arctan2(frame.rows["vy"], frame.rows["vx"])
        heading = rows["yaw"] - frame.rows["yaw"]
        moving = np.hypot(frame.rows["vx"], frame.rows["vy"]) > 0.1
        off = np.angle(np.exp(1j * (turned - heading)))[moving]
        assert np.abs(off).max() < 1e-3
        # dead-reckoned from the engine's last step to the batch's time: at most half a step
        reach = np.hypot(frame.rows["vx"], frame.rows["vy"]) * step / 2 + 1e-3
        assert (np.hypot(rows["x"] - frame.rows["x"], rows["y"] - frame.rows["y"]) <= reach).all()
        kinds = set(npc.array()["kind"].tolist())
        assert len(kinds) >= 2  # cars and pedestrians at least
        readings = domain.engine.light_readings()
        assert {x.id for x in lights.lights} == {r.id for r in readings} and len(readings) == 9
        assert [x.state for x in lights.lights] == [r.state for r in readings]
        assert lights.t == npc.t  # rebuilt every tick, not only when published
        assert weather is out.weathers[-1]
        snap = Snapshot(SCHEMA_VERSION, t, [], npc, lights, weather)
        assert SNAPSHOT.decode(SNAPSHOT.encode(snap)) == snap
