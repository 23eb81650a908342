"""The scale bench's profile split: SUMO's child process apart from the tick, waits dropped."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "tools" / "bench"


@pytest.fixture
def scale_profile(monkeypatch: pytest.MonkeyPatch):  # type: ignore[no-untyped-def]
    monkeypatch.syspath_prepend(str(BENCH))
    return importlib.import_module("scale_profile")


def test_stacks_of_sumo_s_own_process_are_not_read_as_the_tick_s(
    tmp_path: Path,
    scale_profile,  # type: ignore[no-untyped-def]
) -> None:
    rate = scale_profile.SAMPLE_RATE_HZ
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
    assert shares[sumo_step] == 70 / rate
    assert shares[scale_profile.SUMO_PROCESS + "NPC read-back from SUMO"] == 20 / rate
    assert "SUMO's own step (libsumo simulationStep)" not in shares  # nothing in the tick's
    top = [frame for frame, _ in scale_profile.top_functions(raw)]
    assert not any(frame.startswith("process ") for frame in top), top
    tick_side = {k: v for k, v in shares.items() if not k.startswith(scale_profile.SUMO_PROCESS)}
    assert sum(tick_side.values()) == 30 / rate  # the authority's handing over, apart


def test_samples_in_a_wait_or_with_no_python_frame_are_dropped(
    tmp_path: Path,
    scale_profile,  # type: ignore[no-untyped-def]
) -> None:
    """Recorded with --idle, every thread is in every sample: the waits must not count."""
    rate = scale_profile.SAMPLE_RATE_HZ
    authority = 'process 10:"python -c from multiprocessing.spawn import spawn_main; x";'
    thread = "Thread._bootstrap (threading.py:1002);Thread.run (threading.py:982);"
    loop = "Authority.run (carlaverse/authority/service.py:146);"
    raw = tmp_path / "raw.txt"
    raw.write_text(
        # the tick thread between ticks, then in its work
        f"{authority}{thread}{loop}Authority._run (carlaverse/authority/service.py:165);"
        "Event.wait (threading.py:629);Condition.wait (threading.py:331) 80\n"
        f"{authority}{thread}{loop}Authority._run (carlaverse/authority/service.py:157);"
        "Authority.tick (carlaverse/authority/service.py:205);"
        "PoseIntake.drain (carlaverse/authority/pose_intake.py:86) 15\n"
        # a Zenoh thread with no Python frame, and the control pipe's reader
        f"{authority}{thread.rstrip(';')} 9000\n"
        f"{authority}authority_main (scale_children.py:62);"
        "Connection._recv (multiprocessing/connection.py:395) 97\n"
    )
    shares = scale_profile.split(raw, seconds=1.0)
    assert shares == {"pose intake (callback, decode, roster)": 15 / rate}
    top = dict(scale_profile.top_functions(raw))
    assert top["PoseIntake.drain (carlaverse/authority/pose_intake.py:86)"] == 1.0
