from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from carlaverse.testing.chromium import missing_browser
from tests.browser import chromium, page, screenshot_dir
from tests.recorded_demo import recorded_demo
from tests.support import Cluster

# browser fixtures, and one recorded demo session, for every test
__all__ = ["chromium", "page", "recorded_demo", "screenshot_dir"]


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[Cluster]:
    c = Cluster(tmp_path)
    try:
        yield c
    finally:
        c.close()


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--hardware",
        action="store_true",
        default=False,
        help="run tests marked `hardware` against real devices (evdev FFB wheel, joysticks)",
    )


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    no_browser = missing_browser()
    for item in items:
        if "browser" in item.keywords and no_browser:
            item.add_marker(pytest.mark.skip(reason=no_browser))
    if config.getoption("--hardware"):
        return
    skip = pytest.mark.skip(reason="needs a real device: run with --hardware")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)
