"""Plumbing the hardware-server commands share: backend options from the command line, the
backend table, and stopping cleanly on SIGINT/SIGTERM."""

from __future__ import annotations

import argparse
import sys
import threading
from collections.abc import Callable
from typing import Any

import yaml

from carlaverse.cli.common import stop_on_signals
from carlaverse.config import ConfigError
from carlaverse.hal.device import DeviceConfig, open_device
from carlaverse.hal.registry import Registry


def add_server_args(parser: argparse.ArgumentParser, port: int, backends: str) -> None:
    parser.add_argument("--port", type=int, default=port, help=f"UDP port (default {port})")
    parser.add_argument(
        "--bind",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1; 0.0.0.0 for a rig on another host)",
    )
    parser.add_argument("--backend", help=f"device backend: {backends}, or a plugin's name")
    parser.add_argument(
        "-o",
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="backend option, VALUE parsed as YAML (repeatable), e.g. -o path=frames.csv",
    )
    parser.add_argument(
        "--watchdog-ms", type=float, default=250.0, help="safety timeout (default 250 ms)"
    )
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    parser.add_argument("--list-backends", action="store_true", help="list backends and exit")


def parse_options(pairs: list[str]) -> dict[str, Any]:
    """`["gain_percent=80", "device=G29"]` -> {"gain_percent": 80, "device": "G29"}."""
    options: dict[str, Any] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise ConfigError("--option", f"{pair!r} is not KEY=VALUE")
        try:
            options[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError as exc:
            raise ConfigError("--option", f"{key}: value {value!r} is not valid YAML") from exc
    return options


def open_backend(registry: Registry, name: str, options: dict[str, Any]) -> Any:
    cfg = DeviceConfig(backend=name, options=options)
    return open_device(registry, cfg, DeviceConfig, source=f"{registry.family} --option")


def list_backends(registry: Registry) -> int:
    for name in registry.names():
        print(name)
    return 0


def stop_after(seconds: float | None, stop: Callable[[], None]) -> None:
    if seconds is not None:
        timer = threading.Timer(seconds, stop)
        timer.daemon = True
        timer.start()


def serve(command: str, server: Any, backend: str, args: argparse.Namespace,
          summary: Callable[[], str]) -> int:  # fmt: skip
    """Run `server` in this thread until a signal or `--duration`, then print `summary()`."""
    stop_on_signals(then=server.stop)
    stop_after(args.duration, server.stop)
    host, port = server.address
    print(
        f"{command} listening on udp {host}:{port}, backend {backend}, "
        f"watchdog {args.watchdog_ms:g} ms",
        file=sys.stderr,
        flush=True,
    )
    server.serve_forever()
    print(f"{command} stopped: {summary()}", file=sys.stderr)
    return 0
