"""The one door to Lab Streaming Layer: pylsl imported lazily, liblsl configured once.

liblsl reads its configuration once per process, at its first use, and finds peers by
multicast and broadcast. That is what a lab wants (an eye tracker on another PC appears by
itself) and what a test or a laptop does not (every host on the subnet sees its streams). So
the configuration is chosen here, in code, before liblsl loads it:

- `scope="machine"` (the default): discovery stays on this host -- liblsl's machine resolve
  scope, IPv4 only, 127.0.0.1 as the one known peer. Streams of other hosts are not found.
- `scope="lab"`: liblsl's own defaults (site scope), plus any `known_peers` where multicast
  does not pass (a switch that drops it, Wi-Fi).

`session_id` is liblsl's `[lab] SessionID`: only streams of the same id see each other, so a
test run (or two studies in one lab) cannot pick up another's streams.

What liblsl offers no setting for: its data servers listen on every interface (TCP, ports
from 16572) whatever the scope; the scope bounds who finds a stream, not who may connect.
"""

from __future__ import annotations

import importlib
import threading
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any, Literal

LslScope = Literal["machine", "lab"]
INSTALL_HINT = "pip install 'carlaverse[study]' (pylsl, which ships liblsl)"


class LslUnavailable(ImportError):
    """pylsl (and with it liblsl) is not installed, or too old to be configured in code."""


class LslConfigConflict(RuntimeError):
    """liblsl was already configured otherwise in this process (it reads its config once)."""


@dataclass(frozen=True, slots=True)
class LslNetwork:
    """Where LSL looks for streams and who sees ours."""

    scope: LslScope = "machine"
    session_id: str = "default"  # liblsl [lab] SessionID: only equal ids see each other
    known_peers: tuple[str, ...] = field(default=())  # hosts asked directly (unicast)


def config_text(network: LslNetwork) -> str:
    """The lsl_api.cfg (INI) text for `network`."""
    lines = ["[lab]", f"SessionID = {network.session_id}", "[log]", "level = -2"]
    peers = list(network.known_peers)
    if network.scope == "machine":
        # IPv6 off: the machine scope's IPv6 group needs a multicast route that containers
        # and many laptops lack, and liblsl then waits on it before every resolve.
        lines = ["[ports]", "IPv6 = disable", *lines]
        peers = ["127.0.0.1", *[p for p in peers if p != "127.0.0.1"]]
        lines += ["[multicast]", "ResolveScope = machine"]
    else:
        lines += ["[multicast]", "ResolveScope = site"]
    if peers:
        lines.append("KnownPeers = {" + ", ".join(peers) + "}")
    return "\n".join(lines) + "\n"


class _Applied:
    """liblsl's configuration is process-wide (a C++ singleton): this remembers which one this
    process gave it, so a second, different one is refused rather than silently ignored."""

    lock = threading.Lock()
    network: LslNetwork | None = None
    module: ModuleType | None = None


def load(network: LslNetwork | None = None) -> Any:
    """pylsl, with liblsl configured for `network` (default: this machine only).

    The first call in a process decides; a later call with another network raises
    LslConfigConflict. Raises LslUnavailable with the install command if pylsl is missing.
    """
    network = network or LslNetwork()
    with _Applied.lock:
        if _Applied.module is not None:
            if network != _Applied.network:
                raise LslConfigConflict(
                    f"LSL is already configured for {_Applied.network} in this process; "
                    f"liblsl reads its configuration once, so {network} cannot apply"
                )
            return _Applied.module
        pylsl = _import_pylsl()
        try:
            pylsl.set_config_content(config_text(network))
        except NotImplementedError as exc:  # liblsl < 1.17.7
            raise LslUnavailable(f"{exc}; {INSTALL_HINT} >= 1.18") from exc
        _Applied.network, _Applied.module = network, pylsl
        return pylsl


def _import_pylsl() -> Any:
    try:
        return importlib.import_module("pylsl")
    except (ImportError, RuntimeError) as exc:  # RuntimeError: pylsl found no liblsl
        raise LslUnavailable(
            f"Lab Streaming Layer is not available ({exc}): {INSTALL_HINT}"
        ) from exc


def stream_errors(pylsl: Any) -> tuple[type[Exception], ...]:
    """pylsl's timeout and lost-stream errors (in `pylsl.util`; the package does not export
    them, and its TimeoutError is its own, not the builtin)."""
    return (pylsl.util.TimeoutError, pylsl.util.LostError)


class LslClock:
    """liblsl's `local_clock()` as a `transport.clock.Clock`: the clock every LSL timestamp of
    this host is read on, so a session clock built on it maps LSL times directly."""

    def __init__(self, pylsl: Any) -> None:
        self._local_clock = pylsl.local_clock

    def now(self) -> float:
        return float(self._local_clock())
