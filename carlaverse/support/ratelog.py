"""Logging at a bounded rate, so a flood of bad packets cannot flood the log."""

from __future__ import annotations

import logging
from collections.abc import Callable


class RateLimitedLog:
    """Logs each kind of message at most once per `interval_s`; counts what it held back."""

    def __init__(
        self, logger: logging.Logger, clock: Callable[[], float], interval_s: float = 1.0
    ) -> None:
        self.logger = logger
        self.clock = clock
        self.interval_s = interval_s  # [s]
        self._last: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}

    def log(self, level: int, kind: str, message: str, *args: object) -> bool:
        """Log `message` unless `kind` was logged within the interval; True if logged."""
        now = self.clock()
        last = self._last.get(kind)
        if last is not None and now - last < self.interval_s:
            self._suppressed[kind] = self._suppressed.get(kind, 0) + 1
            return False
        self._last[kind] = now
        held = self._suppressed.pop(kind, 0)
        if held:
            message += f" ({held} more like this in the last {self.interval_s:g} s)"
        self.logger.log(level, message, *args, stacklevel=3)  # name the caller's line
        return True

    def warning(self, kind: str, message: str, *args: object) -> bool:
        return self.log(logging.WARNING, kind, message, *args)
