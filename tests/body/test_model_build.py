"""The pose model's offline build: pinned inputs, normalization metadata, the same bytes twice."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from carlaverse.body import model
from carlaverse.body.errors import PoseModelError

pytest.importorskip("mediapipe", reason="mediapipe not installed (tools/install-test-deps.sh)")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return model.download_wheel(tmp_path_factory.mktemp("wheel"))


def test_build_is_reproducible_aligned_and_normalized(wheel: Path, tmp_path: Path) -> None:
    from carlaverse.body.tflite_metadata import read_normalization

    first = model.build(tmp_path / "a.task", wheel).read_bytes()
    second = model.build(tmp_path / "b.task", wheel).read_bytes()
    assert first == second
    with zipfile.ZipFile(tmp_path / "a.task") as bundle:
        assert bundle.comment == model.BUILD_ID
        names = [info.filename for info in bundle.infolist()]
        assert names == ["pose_detector.tflite", "pose_landmarks_detector.tflite"]
        for info in bundle.infolist():
            assert info.compress_type == zipfile.ZIP_STORED
            data_at = info.header_offset + 30 + len(info.filename) + len(info.extra)
            assert data_at % model.ZIP_ALIGNMENT == 0, info.filename
        detector = read_normalization(bundle.read("pose_detector.tflite"))
        landmarks = read_normalization(bundle.read("pose_landmarks_detector.tflite"))
    assert detector == ("pose_detector", 127.5, 127.5)  # pixels to [-1, 1]
    assert landmarks == ("pose_landmarks_detector", 0.0, 255.0)  # pixels to [0, 1]
    assert model.require(tmp_path / "a.task") == tmp_path / "a.task"


def test_a_wheel_that_is_not_the_pinned_one_is_refused(tmp_path: Path) -> None:
    fake = tmp_path / model.WHEEL_NAME
    with zipfile.ZipFile(fake, "w") as archive:
        archive.writestr("mediapipe/__init__.py", "")
    with pytest.raises(PoseModelError, match=r"SHA-256 .* is not"):
        model.build(tmp_path / "x.task", fake)
    assert not (tmp_path / "x.task").exists()


def test_a_missing_or_foreign_model_says_how_to_build_it(tmp_path: Path) -> None:
    with pytest.raises(PoseModelError, match="missing; build it once with `carlaverse body"):
        model.require(tmp_path / "none.task")
    foreign = tmp_path / "foreign.task"
    with zipfile.ZipFile(foreign, "w") as archive:
        archive.writestr("pose_detector.tflite", b"")
    with pytest.raises(PoseModelError, match="not made by this version's build"):
        model.require(foreign)
