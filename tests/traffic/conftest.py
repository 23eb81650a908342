from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def net_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One network cache for the whole run: each map is built by netconvert once."""
    return tmp_path_factory.mktemp("carlaverse-cache")
