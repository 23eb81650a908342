"""What every device family shares: typed backend options, an injected clock, `close()`.

A node's YAML names a backend and its options (docs/architecture.md §9):

    ffb:
      backend: udp
      options: {host: 127.0.0.1, port: 45500}

`options` stays a plain mapping until the backend is known; then it is decoded into that
backend's own `Options` StrictStruct, so a typo is an error naming the field, not a silently
ignored key (bleak's typed backend options, not `**kwargs`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, TypeVar

import msgspec

from carlaverse.config import StrictStruct, convert
from carlaverse.hal.registry import Registry

Clock = Callable[[], float]  # returns seconds on a monotonic scale

D = TypeVar("D", bound="Device")


class NoOptions(StrictStruct):
    """A backend that takes no options."""


class DeviceConfig(StrictStruct):
    """The YAML block that picks one backend of a device family."""

    backend: str = "sim"
    options: dict[str, Any] = msgspec.field(default_factory=dict)


class Device:
    """Base of every device: holds its options and clock; `close()` is idempotent."""

    Options: ClassVar[type[StrictStruct]] = NoOptions

    def __init__(self, options: Any, *, clock: Clock = time.monotonic) -> None:
        self.options = options
        self.clock = clock
        self._closed = False

    def close(self) -> None:
        """Release the device; safe to call twice."""
        if not self._closed:
            self._closed = True
            self._close()

    def _close(self) -> None:
        """Backend hook: release the hardware."""

    @property
    def closed(self) -> bool:
        return self._closed

    def __enter__(self: D) -> D:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def open_device(
    registry: Registry[D],
    cfg: DeviceConfig | Mapping[str, Any],
    config_type: type[DeviceConfig],
    *,
    clock: Clock | None = None,
    source: str | None = None,
) -> D:
    """Resolve `cfg.backend`, decode its options, and open the device."""
    where = source or registry.family
    if not isinstance(cfg, DeviceConfig):
        cfg = convert(dict(cfg), config_type, where)
    backend = registry.resolve(cfg.backend)
    options = convert(cfg.options, backend.Options, f"{where}.options (backend {cfg.backend!r})")
    return backend(options, clock=clock or time.monotonic)
