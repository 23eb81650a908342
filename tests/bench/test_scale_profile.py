"""The scale bench's profile split: SUMO's child process is split apart from the tick."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "tools" / "bench"


def test_stacks_of_sumo_s_own_process_are_not_read_as_the_tick_s(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(BENCH))
    scale_profile = importlib.import_module("scale_profile")
    raw = tmp_path / "raw.txt"
    raw.write_text(
        'process 10:"python -m carlaverse authority";run (service.py:1);'
        "tick (traffic_domain.py:5);step (sumo_process.py:90) 30\n"
        # a child's stacks sit under its parent's process frame, then its own
        'process 10:"python -m carlaverse authority";'
        'process 11:"python -m carlaverse.traffic.sumo_process 5";main (sumo_process.py:300);'
        "_serve (sumo_process.py:260);step (sumo_engine.py:110);"
        "simulationStep (libsumo.py:1) 70\n"
        'process 11:"python -m carlaverse.traffic.sumo_process 5";main (sumo_process.py:300);'
        "_serve (sumo_process.py:260);read (sumo_reader.py:50) 20\n"
    )
    shares = scale_profile.split(raw, seconds=1.0)
    sumo_step = scale_profile.SUMO_PROCESS + "SUMO's own step (libsumo simulationStep)"
    assert shares[sumo_step] == 0.70
    assert shares[scale_profile.SUMO_PROCESS + "NPC read-back from SUMO"] == 0.20
    assert "SUMO's own step (libsumo simulationStep)" not in shares  # nothing in the tick's
    top = [frame for frame, _ in scale_profile.top_functions(raw)]
    assert not any(frame.startswith("process ") for frame in top), top
    tick_side = {k: v for k, v in shares.items() if not k.startswith(scale_profile.SUMO_PROCESS)}
    assert sum(tick_side.values()) == 0.30  # the authority's handing over, apart
