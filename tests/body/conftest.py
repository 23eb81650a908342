"""The pose model for the tests that run MediaPipe, built once by the project's own build step
(`carlaverse.body.model.build`, what `carlaverse body build-model` runs) into the user cache.
Tests that need it skip, with the reason, only when mediapipe is not installed."""

from __future__ import annotations

from pathlib import Path

import pytest

GRACE_HOPPER = ("sample_data", "grace_hopper.jpg")  # matplotlib ships this photograph


@pytest.fixture(scope="session")
def pose_model() -> Path:
    pytest.importorskip("mediapipe", reason="mediapipe not installed (tools/install-test-deps.sh)")
    from carlaverse.body import model
    from carlaverse.body.errors import PoseModelError

    try:
        return model.require()
    except PoseModelError:  # missing, or from another build: this is CI's build step
        return model.build()


@pytest.fixture(scope="session")
def grace_hopper() -> Path:
    matplotlib = pytest.importorskip("matplotlib")
    path = Path(matplotlib.get_data_path(), *GRACE_HOPPER)
    assert path.is_file(), f"{path}: matplotlib's sample photo is missing"
    return path
