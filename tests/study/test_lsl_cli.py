"""`carlaverse record --lsl NAME` as a user runs it (in-process, off the main thread)."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from carlaverse.cli import main
from carlaverse.recording.reading import iter_samples
from carlaverse.study.lsl_sink import decode_sample
from tests.study.lsl_support import NETWORK, SESSION_OFFSET_S, EcgOutlet, Fabric, lsl, open_fabric
from tests.support import wait_until


@pytest.fixture
def fabric() -> Iterator[Fabric]:
    with open_fabric() as fab:
        yield fab


def _record(fabric: Fabric, out: Path, *extra: str) -> list[str]:
    return [
        "record", "--session", fabric.keys.session, "--connect", fabric.endpoint,
        "-o", str(out), "--progress-s", "0", "--lsl-session-id", NETWORK.session_id, *extra,
    ]  # fmt: skip


def test_record_lsl_writes_the_stream_beside_the_session_keys(
    fabric: Fabric, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ecg = EcgOutlet("ECG-cli")
    out = tmp_path / "trial.mcap"
    argv = _record(fabric, out, "--duration", "4", "--lsl", "ECG-cli")
    result: list[int] = []
    runner = threading.Thread(target=lambda: result.append(main(argv)))
    runner.start()
    ecg.wait_consumer(timeout_s=10)
    wait_until(lambda: fabric.clock_queries > 0, 10, "the recorder's first clock query")
    ecg.send(1.0)
    runner.join(timeout=30)
    assert result == [0], capsys.readouterr().err
    samples = [decode_sample(s.payload) for s in iter_samples(out) if s.key == "lsl/ECG-cli"]
    assert len(samples) == len(ecg.truth) == 250
    assert "LSL: lsl/ECG-cli 250 samples" in capsys.readouterr().err


def test_record_lsl_names_an_absent_stream_and_writes_nothing(
    fabric: Fabric, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "none.mcap"
    code = main(_record(fabric, out, "--lsl", "NoSuchTobii", "--lsl-wait", "0.3"))
    err = capsys.readouterr().err
    assert code == 2, err
    assert "carlaverse record: LSL stream(s) NoSuchTobii not found within 0.3 s" in err
    assert not out.exists()


def test_record_lsl_markers_publishes_the_session_clock_on_lsl(
    fabric: Fabric, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = _record(fabric, tmp_path / "m.mcap", "--duration", "4", "--lsl-markers")
    result: list[int] = []
    runner = threading.Thread(target=lambda: result.append(main(argv)))
    runner.start()
    pylsl = lsl()
    found = pylsl.resolve_byprop("name", "carlaverse-lsltest-clock", 1, 10.0)
    assert found, "the session-clock stream did not appear"
    inlet = pylsl.StreamInlet(found[0])
    sample, stamp = inlet.pull_sample(timeout=5.0)
    correction = inlet.time_correction(5.0)  # while the outlet is there to be probed
    runner.join(timeout=30)
    assert result == [0], capsys.readouterr().err
    # session time = LSL time + the stand-in authority's offset (tests/study/lsl_support.py)
    assert sample[0] - (stamp + correction) == pytest.approx(SESSION_OFFSET_S, abs=0.005)
    assert "LSL: markers published, no stream recorded" in capsys.readouterr().err
