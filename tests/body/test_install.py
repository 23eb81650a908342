"""The install path leaves exactly one cv2: mediapipe without its opencv-contrib dependency."""

from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_exactly_one_distribution_provides_cv2() -> None:
    providers = metadata.packages_distributions().get("cv2", [])
    assert sorted(set(providers)) == ["opencv-python-headless"], providers
    for other in ("opencv-contrib-python", "opencv-python", "opencv-contrib-python-headless"):
        with pytest.raises(metadata.PackageNotFoundError):
            metadata.distribution(other)


def test_mediapipe_is_the_version_the_install_step_pins() -> None:
    pytest.importorskip("mediapipe", reason="mediapipe not installed (tools/install-test-deps.sh)")
    script = (ROOT / "tools" / "install-test-deps.sh").read_text()
    pinned = re.search(r"--no-deps '?mediapipe==([\d.]+)", script)
    assert pinned, "tools/install-test-deps.sh no longer installs mediapipe --no-deps"
    assert metadata.version("mediapipe") == pinned[1]
    readme = (ROOT / "README.md").read_text()
    assert f"pip install --no-deps 'mediapipe=={pinned[1]}'" in readme
