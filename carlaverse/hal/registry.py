"""Backend registries: name -> lazily imported class, extended through entry points.

Modelled on python-can's `can/interfaces/__init__.py`: each device family keeps a table of
built-in backends as `name -> (module, class, extra)`; nothing is imported until a backend is
asked for, so a node without pygame can still open a `sim` input. Third-party packages add
backends with an entry point in the family's group, e.g. in their pyproject.toml:

    [project.entry-points."carlaverse.hal.motion_server"]
    dbox = "lab_dbox.platform:DboxPlatform"

Built-in names win over entry points of the same name.
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Mapping
from importlib import metadata
from typing import Generic, NamedTuple, TypeVar

from carlaverse.hal.errors import BackendDependencyError, BackendNotFoundError, HalError

log = logging.getLogger(__name__)

T = TypeVar("T")


class BackendSpec(NamedTuple):
    module: str
    cls: str
    extra: str | None = None  # the carlaverse extra that installs its dependencies


class Registry(Generic[T]):
    """The backends of one device family."""

    def __init__(
        self, family: str, base: type[T], builtins: Mapping[str, BackendSpec], group: str = ""
    ) -> None:
        self.family = family
        self.base = base
        self.builtins = dict(builtins)
        self.group = group or f"carlaverse.hal.{family}"

    def names(self) -> list[str]:
        """Every backend name: built-in first, then entry points, each sorted."""
        extra = sorted(set(self._entry_points()) - set(self.builtins))
        return sorted(self.builtins) + extra

    def resolve(self, name: str) -> type[T]:
        """The backend class for `name`, imported now."""
        if name in self.builtins:
            cls = self._load_builtin(name, self.builtins[name])
        else:
            entry_point = self._entry_points().get(name)
            if entry_point is None:
                raise BackendNotFoundError(self.family, name, self.names())
            cls = self._load_entry_point(name, entry_point)
        return self._checked(name, cls)

    def _load_builtin(self, name: str, spec: BackendSpec) -> type:
        try:
            module = importlib.import_module(spec.module)
        except ModuleNotFoundError as exc:
            if exc.name and spec.module.startswith(exc.name):
                raise  # our own module is missing: a packaging bug, not a user's missing extra
            extra = f"'carlaverse[{spec.extra}]'" if spec.extra else exc.name
            install = f"pip install {extra}"
            raise BackendDependencyError(self.family, name, exc.name, install) from exc
        return getattr(module, spec.cls)

    def _load_entry_point(self, name: str, entry_point: metadata.EntryPoint) -> type:
        try:
            return entry_point.load()
        except ModuleNotFoundError as exc:
            dist = entry_point.dist.name if entry_point.dist else entry_point.value
            install = f"pip install {exc.name}  (needed by {dist})"
            raise BackendDependencyError(self.family, name, exc.name, install) from exc

    def _checked(self, name: str, cls: object) -> type[T]:
        if not (isinstance(cls, type) and issubclass(cls, self.base)):
            raise HalError(
                f"{self.family} backend {name!r} resolves to {cls!r}, which is not a "
                f"{self.base.__name__} subclass; fix the backend table or its entry point"
            )
        return cls

    def _entry_points(self) -> dict[str, metadata.EntryPoint]:
        found: dict[str, metadata.EntryPoint] = {}
        for entry_point in metadata.entry_points(group=self.group):
            if entry_point.name in found:
                log.warning(
                    "two packages register %s backend %r; using %s, ignoring %s",
                    self.family,
                    entry_point.name,
                    found[entry_point.name].value,
                    entry_point.value,
                )
                continue
            found[entry_point.name] = entry_point
        return found
