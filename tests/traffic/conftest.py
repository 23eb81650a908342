from __future__ import annotations

from tests.traffic.helpers import net_cache

__all__ = ["net_cache"]
