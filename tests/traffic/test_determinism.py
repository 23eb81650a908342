"""Same scenario and seed, same traffic: NPC trajectories over 60 s of sim time are identical."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from carlaverse.authority.memory_outbox import MemoryOutbox
from tests.traffic.helpers import T0, domain_of, run

SIM_S = 60.0  # [s]


def trajectories(
    net_cache: Path, seed: int | None = None, seconds: float = SIM_S
) -> list[tuple[list[str], bytes]]:
    """Every NPC batch of a run of the town scenario, as (ids, rows)."""
    with domain_of("town", net_cache, seed) as domain:
        out = MemoryOutbox()
        run(domain, out, T0, seconds)
        return [(b.ids, b.rows) for b in out.npcs]


def test_same_seed_gives_identical_npc_trajectories(net_cache: Path) -> None:
    first, second = trajectories(net_cache), trajectories(net_cache)
    assert len(first) == len(second)
    assert abs(len(first) - SIM_S * 20) <= 1  # 20 Hz batches
    assert len(first[-1][0]) >= 40  # vehicles and pedestrians are about
    for (ids_a, rows_a), (ids_b, rows_b) in zip(first, second, strict=True):
        assert ids_a == ids_b
        assert rows_a == rows_b  # bit for bit


def test_another_seed_gives_other_traffic(net_cache: Path) -> None:
    first, other = trajectories(net_cache, seconds=5.0), trajectories(net_cache, 1234, 5.0)
    a = np.frombuffer(first[-1][1], dtype=np.float32)
    b = np.frombuffer(other[-1][1], dtype=np.float32)
    assert first[-1][0] != other[-1][0] or not np.array_equal(a, b)
