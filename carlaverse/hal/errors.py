"""Errors of the hardware layer, one tree rooted in builtins so callers can catch broadly.

    HalError (Exception)
    ├── BackendNotFoundError (HalError, LookupError)     unknown backend name, with suggestions
    ├── BackendDependencyError (HalError, ImportError)   optional dependency missing, with the
    │                                                    pip command that installs it
    └── DeviceError (HalError, OSError)                  device absent, busy or failed

Packet codecs raise their own ValueError subclasses (`FfbPacketError`, `MotionPacketError`);
bad options raise `carlaverse.config.ConfigError` (a ValueError) naming the field path.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence


class HalError(Exception):
    """Base of every hardware-layer error."""


class BackendNotFoundError(HalError, LookupError):
    """No backend of that name is built in or registered through an entry point."""

    def __init__(self, family: str, name: str, known: Sequence[str]) -> None:
        self.family = family
        self.name = name
        self.suggestions = difflib.get_close_matches(name, known, n=3, cutoff=0.5)
        hint = f" Did you mean {' or '.join(repr(s) for s in self.suggestions)}?"
        super().__init__(
            f"unknown {family} backend {name!r}.{hint if self.suggestions else ''} "
            f"Known {family} backends: {', '.join(known) or 'none'}. A third-party backend "
            f"registers itself under the entry-point group 'carlaverse.hal.{family}'."
        )


class BackendDependencyError(HalError, ImportError):
    """A backend's optional dependency is not installed."""

    def __init__(self, family: str, backend: str, missing: str | None, install: str) -> None:
        self.family = family
        self.backend = backend
        self.install = install
        super().__init__(
            f"the {family} backend {backend!r} needs the missing module {missing!r}. "
            f"Install it with: {install}",
            name=missing,
        )


class DeviceError(HalError, OSError):
    """The device is absent, busy or failed; the message says which and what to check."""
