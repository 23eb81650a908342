"""Render tests draw real frames offscreen (EGL; Mesa llvmpipe without a GPU).

They skip with the reason when Panda3D or a headless GL pipe is missing. Screenshots go to
the test's tmp dir, and also to $CARLAVERSE_SHOTS when set, so a human can look at them.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

panda3d = pytest.importorskip(
    "panda3d", reason="needs the render extra: pip install -e '.[render]'"
)


@pytest.fixture(scope="session")
def offscreen_gl() -> None:
    from panda3d.core import GraphicsPipeSelection, load_prc_file_data

    from carlaverse.render.graphics import PRC

    load_prc_file_data("carlaverse-render", PRC)
    if GraphicsPipeSelection.get_global_ptr().make_module_pipe("p3headlessgl") is None:
        pytest.skip("no headless GL pipe: apt-get install libegl1 libgl1-mesa-dri")


@pytest.fixture
def save_shot(tmp_path: Path) -> Callable[[str, np.ndarray], Path]:
    from PIL import Image

    def save(name: str, image: np.ndarray) -> Path:
        path = tmp_path / f"{name}.png"
        Image.fromarray(image).save(path)
        extra = os.environ.get("CARLAVERSE_SHOTS")
        if extra:
            Path(extra).mkdir(parents=True, exist_ok=True)
            Image.fromarray(image).save(Path(extra) / path.name)
        return path

    return save
