"""Opening Zenoh sessions from typed settings (docs/architecture.md §2).

Nodes are `peer`s by default, the site router is a `router`, and `client` is there for
constrained networks. Defaults are chosen for a simulation fabric rather than Zenoh's own:
multicast scouting off (a lab network should not be sprayed with 224.0.0.224), listen only on
loopback unless told otherwise (Zenoh's default binds every interface), and a transport lease
short enough that a crashed node is noticed well within the despawn timeout.
"""

from __future__ import annotations

import json
import re
import signal
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import msgspec
import zenoh

from carlaverse.patterns import whole_ascii
from carlaverse.transport.settings import FabricSettings, Mode


class FabricError(RuntimeError):
    """A Zenoh session could not be configured or opened."""


class FabricUnreachable(FabricError):
    """Client mode: no router answered before the deadline or the stop signal."""


# Client mode cannot open a session without a router, and Zenoh's open blocks (in Rust, deaf
# to signals) for as long as `connect/timeout_ms` says. One attempt per second keeps a waiting
# client responsive to Ctrl-C / SIGTERM and lets it say what it waits for.
CLIENT_ATTEMPT_MS = 1000

# A peer's links to the peers its router names open within ~1 ms on loopback; a loaded host
# or a LAN takes longer, so the set must hold still this long before it counts as complete.
MESH_QUIET_S = 0.1  # [s]
MESH_POLL_S = 0.005  # [s]

# Protocols whose address is host:port (the others -- unixsock-stream, serial, vsock -- are
# paths or device names and are left to Zenoh).
IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
OTHER_PROTOCOLS = ("unixsock-stream", "unixpipe", "serial", "vsock")
# Who opens a peer-to-peer link in low-latency mode: routers are always dialled, between
# peers only the one with the greater zid dials (see build_config).
LOWLATENCY_AUTOCONNECT = {"peer": {"to_router": "always", "to_peer": "greater-zid"}}
_HOST_PORT = whole_ascii(r"(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>[0-9]{1,5})")
# What an endpoint may hold at all, whatever its protocol: printable ASCII, no space. A
# newline, a NUL or a look-alike letter in a path or a `?meta` part is refused, not passed on.
_ENDPOINT_TEXT = whole_ascii(r"[!-~]+")


def default_listen(mode: Mode) -> list[str]:
    """Loopback only: nothing on another host can dial this process. A client reaches other
    hosts through its site router; a peer does not, so a node whose router is elsewhere is a
    client unless told otherwise (docs/architecture.md §2)."""
    if mode == "client":
        return []
    return ["tcp/127.0.0.1:0"]


def _host_port(address: str) -> re.Match[str] | None:
    """`host` and `port` of an endpoint's address (after `proto/`, before `?meta` or `#cfg`)."""
    return _HOST_PORT.fullmatch(re.split(r"[?#]", address, maxsplit=1)[0])


def on_this_host(endpoint: str) -> bool:
    """Whether `endpoint` names an address of this host (a socket can be bound to it).

    Binding sends nothing: it only asks the kernel whether the address is one of ours. A
    name is resolved first; one that does not resolve counts as another host.
    """
    proto, _, rest = endpoint.partition("/")
    if proto in OTHER_PROTOCOLS:
        return True  # unix sockets, pipes, serial and vsock never leave the host
    match = _host_port(rest)
    if match is None:
        return False
    host = match["host"].strip("[]")
    try:
        addresses = {
            str(info[4][0]) for info in socket.getaddrinfo(host, None, type=socket.SOCK_DGRAM)
        }
    except OSError:
        return False
    for address in addresses:
        family = socket.AF_INET6 if ":" in address else socket.AF_INET
        with socket.socket(family, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind((address, 0))
            except OSError:
                return False
    return True


def reachable(settings: FabricSettings) -> FabricSettings:
    """`settings`, made a client when they describe a peer whose router is on another host.

    A router does not relay between its peers, and a peer listens on loopback unless told
    otherwise, so such a peer would hear none of its site's other hosts (docs/architecture.md
    §2); a client's router relays everything for it. Settings that `listen` have made the peer
    reachable and are kept, as are other modes.
    """
    if settings.mode != "peer" or settings.listen:
        return settings
    if all(on_this_host(endpoint) for endpoint in settings.connect):
        return settings
    return msgspec.structs.replace(settings, mode="client")


def check_endpoint(endpoint: str, role: str = "connect") -> None:
    """Raise FabricError unless `endpoint` reads `proto/host:port[?meta][#config]`."""
    proto, slash, rest = endpoint.partition("/")
    example = "e.g. tcp/127.0.0.1:7447"
    if not slash or proto not in IP_PROTOCOLS + OTHER_PROTOCOLS:
        known = "/".join(IP_PROTOCOLS)
        raise FabricError(
            f"bad --{role} endpoint {endpoint!r}: expected {known}/HOST:PORT ({example})"
        )
    if proto in OTHER_PROTOCOLS:
        if not _ENDPOINT_TEXT.fullmatch(rest):
            raise FabricError(
                f"bad --{role} endpoint {endpoint!r}: a {proto} address is printable ASCII "
                "without spaces"
            )
        return
    match = _host_port(rest)
    if match is None or not _ENDPOINT_TEXT.fullmatch(rest):  # `?meta` and `#config` too
        raise FabricError(
            f"bad --{role} endpoint {endpoint!r}: expected {proto}/HOST:PORT ({example})"
        )
    port = int(match["port"])
    if port > 65535 or (port == 0 and role == "connect"):
        lowest = 0 if role == "listen" else 1
        raise FabricError(f"bad --{role} endpoint {endpoint!r}: port must be {lowest}-65535")


def zenoh_reason(exc: BaseException) -> str:
    """Zenoh's message without the Rust source location and debug wrapping."""
    text = str(exc)
    inner = re.search(r'msg: "(.*?)(?:"|$)', text)  # Json5Err(Message { msg: "...", ... })
    if inner:
        text = inner[1]
    text = re.sub(r"\s+at /\S+\.rs:\d+\.?", "", text)
    text = re.sub(r"\[Single\(([^)]*)\)\]", r"\1", text)
    text = re.sub(r'^Str\("(.*)"\)$', r"\1", text.strip())
    return text.strip().rstrip(".!") or type(exc).__name__


def build_config(settings: FabricSettings) -> zenoh.Config:
    """Translate settings into a zenoh.Config; raise FabricError naming the bad entry."""
    for endpoint in settings.connect:
        check_endpoint(endpoint, "connect")
    for endpoint in settings.listen:
        check_endpoint(endpoint, "listen")
    entries: dict[str, Any] = {
        "mode": settings.mode,
        "scouting/multicast/enabled": settings.multicast_scouting,
        "listen/endpoints": settings.listen or default_listen(settings.mode),
        "connect/endpoints": settings.connect,
        "transport/link/tx/lease": settings.lease_ms,
        "transport/link/tx/keep_alive": settings.keep_alive,
        # Peers and routers keep retrying connects in the background: a node outlives a
        # router restart. A client cannot open without a router: open_session retries it.
        "connect/timeout_ms": {"router": -1, "peer": -1, "client": CLIENT_ATTEMPT_MS},
        "connect/exit_on_failure": {"router": False, "peer": False, "client": True},
        "connect/retry": {
            "period_init_ms": 250,
            "period_max_ms": 2000,
            "period_increase_factor": 2,
        },
    }
    if settings.lowlatency:
        entries["transport/unicast/lowlatency"] = True
        entries["transport/unicast/qos/enabled"] = False
        # A low-latency transport holds one link. Two peers that learn of each other by
        # gossip at the same time open to each other at once; each side keeps the link it
        # opened and closes the other's, and the pair ends with no transport at all (a node
        # never reaches the authority's join queryable). Only the peer with the greater
        # zid opens, so there is one link per pair.
        entries["scouting/gossip/autoconnect_strategy"] = LOWLATENCY_AUTOCONNECT
    entries.update(settings.zenoh)
    config = zenoh.Config()
    for path, value in entries.items():
        try:
            config.insert_json5(path, json.dumps(value))
        except Exception as exc:  # zenoh raises ZError with the parser's message
            raise FabricError(
                f"invalid zenoh setting {path} = {value!r}: {zenoh_reason(exc)}"
            ) from exc
    return config


def open_session(
    settings: FabricSettings,
    stop: threading.Event | None = None,
    deadline: float | None = None,
    on_wait: Callable[[str], None] | None = None,
) -> zenoh.Session:
    """Open a Zenoh session; errors name the endpoints involved.

    Given `stop` or `deadline`, a client retries once a second until a router answers; it
    calls `on_wait` once with what it waits for, and raises FabricUnreachable when `stop` is
    set or the monotonic `deadline` passes (within ~50 ms: the attempt runs in a worker
    thread). Without them a client makes one attempt (FabricError when no router answers).
    Peers and routers open at once and connect in the background.
    """
    config = build_config(settings)
    waited = False
    while True:
        attempt = _OpenAttempt(config)
        while not attempt.done.wait(0.05):
            if _should_give_up(stop, deadline):
                attempt.abandon()
                raise FabricUnreachable(f"no router answered at {_endpoints(settings)}")
        if attempt.session is not None:
            return attempt.session
        error = attempt.error
        patient = stop is not None or deadline is not None
        if not patient or settings.mode != "client" or "Unable to connect" not in str(error):
            raise FabricError(_cannot_open(settings, error)) from error
        if not waited and on_wait is not None:
            on_wait(
                f"waiting for a router at {_endpoints(settings)}: none answers or it refuses "
                "the handshake (retrying)"
            )
        waited = True
        if _should_give_up(stop, deadline):
            raise FabricUnreachable(f"no router answered at {_endpoints(settings)}") from error


def await_mesh(
    session: zenoh.Session,
    stop: threading.Event,
    timeout_s: float = 10.0,
    quiet_s: float = MESH_QUIET_S,
) -> bool:
    """Wait until the session reaches a peer or router and has opened its links to the peers.

    Why: a router does not relay between its own peers (Zenoh takes them to be meshed), so a
    peer's put reaches another peer of its site only over a direct link, which the peer opens
    once the router's gossip names the other, about a millisecond after open on loopback. A
    reliable put made before then never reaches that subscriber: on loopback a first put right
    after open missed a peer subscribed long before 11 times in 20, and never once the link was
    up. Zenoh says nothing when the links are all open, so this waits until the session's peers
    have stayed the same for `quiet_s`. False when nothing was reached within `timeout_s` or
    `stop` was set; a client is done once it reaches its router.
    """
    deadline = time.monotonic() + timeout_s
    info = session.info
    while not (list(info.peers_zid()) or list(info.routers_zid())):
        if time.monotonic() > deadline or stop.wait(MESH_POLL_S):
            return False
    peers = {str(z) for z in info.peers_zid()}
    since = time.monotonic()
    while time.monotonic() - since < quiet_s and time.monotonic() < deadline:
        if stop.wait(MESH_POLL_S):
            return False
        now = {str(z) for z in info.peers_zid()}
        if now != peers:
            peers, since = now, time.monotonic()
    return True


def _should_give_up(stop: threading.Event | None, deadline: float | None) -> bool:
    return (stop is not None and stop.is_set()) or (
        deadline is not None and time.monotonic() >= deadline
    )


class _OpenAttempt:
    """One zenoh.open in a worker thread, so the caller can give up at once on a signal.

    zenoh.open blocks in Rust for up to CLIENT_ATTEMPT_MS. `abandon` waits that long for it:
    a process that exits while a thread is inside zenoh.open aborts ("FATAL: exception not
    rethrown": the interpreter's pthread_exit unwinds through Rust frames). The worker
    blocks SIGINT/SIGTERM, so threads Zenoh starts from it leave the signals to the main one.
    """

    def __init__(self, config: zenoh.Config) -> None:
        self.session: zenoh.Session | None = None
        self.error: BaseException = FabricError("not opened")
        self.done = threading.Event()
        self._abandoned = False
        self._lock = threading.Lock()
        self._thread = threading.Thread(
            target=self._open, args=(config,), name="zenoh-open", daemon=True
        )
        self._thread.start()

    def _open(self, config: zenoh.Config) -> None:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        try:
            session = zenoh.open(config)
        except Exception as exc:  # zenoh raises ZError
            self.error = exc
            session = None
        with self._lock:
            if self._abandoned and session is not None:
                session.close()
            else:
                self.session = session
            self.done.set()

    def abandon(self) -> None:
        """Give up: the attempt's session, if any, is closed; returns once it has ended."""
        with self._lock:
            self._abandoned = True
            session, self.session = self.session, None
        if session is not None:
            session.close()
        self._thread.join(timeout=CLIENT_ATTEMPT_MS / 1e3 + 1.0)


def reaches_anyone(session: zenoh.Session) -> bool:
    """Whether the session is connected to at least one router or peer now."""
    return bool(list(session.info.routers_zid()) or list(session.info.peers_zid()))


def _endpoints(settings: FabricSettings) -> str:
    return ", ".join(settings.connect) or "(no --connect endpoint)"


def _cannot_open(settings: FabricSettings, exc: BaseException) -> str:
    listen = ", ".join(settings.listen or default_listen(settings.mode)) or "-"
    return (
        f"cannot open a zenoh {settings.mode} session (listen {listen}, connect "
        f"{_endpoints(settings)}): {zenoh_reason(exc)}"
    )
