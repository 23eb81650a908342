"""Where the walker's body pose comes from: a skeleton source chosen by the config's `body:`.

    body:
      source: none            # the default: no avatar joints are sent
      options: {}             # the source's own typed options

A source is any `carlaverse.body.skeleton.SkeletonSource`: `poll() -> Skeleton | None` (the
newest joints not yet handed out, never blocking: a source doing vision runs it in a process of
its own) and `close()`. The node polls it every step and publishes what it returns on
`ego/<id>/skeleton`, giving it the node's sequence number and moving its `t` (the source's
`time.monotonic()` at capture) onto session time. Sources are registered in `SOURCES` as
name -> "module:factory", or named directly by such an import path (a lab's own source); a
factory takes the `options` mapping and returns the source (it decodes its options itself, so a
typo is an error naming the field).
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

import msgspec

from carlaverse.body.skeleton import SkeletonSource
from carlaverse.config import ConfigError, StrictStruct, convert

SOURCES: dict[str, str] = {  # name -> "module:factory"; "none" is built in
    "camera": "carlaverse.body.sources:camera_source",  # webcam + MediaPipe (carlaverse.body)
    "synthetic": "carlaverse.body.sources:synthetic_source",  # the sim camera's walker
}


OPTIONS: dict[str, str] = {  # name -> "module:Type" of its options, checked with the config
    "camera": "carlaverse.body.skeleton:BodyConfig",
    "synthetic": "carlaverse.body.skeleton:BodyConfig",
}


class BodySettings(StrictStruct):
    source: str = "none"
    options: dict[str, Any] = msgspec.field(default_factory=dict)


def source_names() -> list[str]:
    return ["none", *sorted(SOURCES)]


def _import_path(source: str) -> str:
    return SOURCES.get(source, source if ":" in source else "")


def check_body(settings: BodySettings) -> None:
    """The source exists, and a shipped source's options decode (a typo names its field)."""
    if settings.source != "none" and not _import_path(settings.source):
        raise ConfigError("body.source", f"unknown skeleton source {settings.source!r}; "
                                         f"choose one of {source_names()} or give "
                                         "'module:factory'")  # fmt: skip
    if settings.source in OPTIONS:
        module_name, _, type_name = OPTIONS[settings.source].partition(":")
        options_type = getattr(importlib.import_module(module_name), type_name)
        convert(dict(settings.options), options_type, "body.options")


def open_skeleton_source(settings: BodySettings) -> SkeletonSource | None:
    """The configured source, opened; None for `none`."""
    check_body(settings)
    if settings.source == "none":
        return None
    module_name, _, factory = _import_path(settings.source).partition(":")
    try:
        make = getattr(importlib.import_module(module_name), factory)
    except (ImportError, AttributeError) as exc:
        raise ConfigError("body.source", f"{settings.source!r} cannot be loaded: {exc}") from exc
    options: Mapping[str, Any] = settings.options
    return make(options)
