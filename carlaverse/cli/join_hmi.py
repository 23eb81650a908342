"""`carlaverse join KIND --hmi PORT`: the node serves its web HMI (dashboard, touchscreen, bike).

    carlaverse join drive --backend sim --hmi 8080          # http://127.0.0.1:8080/dashboard
    carlaverse join drive --hmi 8080 --hmi-bind 0.0.0.0     # a tablet on the lab's network
    carlaverse join bike --hmi 0 --hmi-config my-hmi.yaml   # any free port; layouts of yours

Beyond loopback (or with --hmi-token) the HMI asks for a pairing token made for this run:
the node prints it once, on stderr, inside the address a tablet opens ("HMI pairing URL").
It goes nowhere else (not into --json): whoever reads it can drive the car's buttons.

The server runs in a thread of the node process with its own event loop; a node kind takes
part through `hmi_bridge()` (carlaverse.hmi.bridge); a participant's kind without one (walk,
scripted) serves the questionnaire page alone, so a study can ask its participant too.
Starlette and uvicorn are imported only when --hmi is given.
"""

from __future__ import annotations

import argparse
import contextlib
import ipaddress
import socket
from collections.abc import Callable, Iterator
from typing import Any

from carlaverse.cli.common import Companion
from carlaverse.keys import Keys
from carlaverse.transport.node_client import NodeSettings


def add_hmi_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("web HMI (served by the node)")
    group.add_argument(
        "--hmi", type=int, metavar="PORT",
        help="serve the dashboard/touchscreen pages on PORT (0: any free port); a study's "
        "questionnaires show on whichever page is open (walk: the /questionnaire page only)",
    )  # fmt: skip
    group.add_argument(
        "--hmi-bind", default="127.0.0.1", metavar="ADDR",
        help="address to serve the HMI on (default 127.0.0.1: this machine only; any address "
        "beyond loopback, e.g. 0.0.0.0, asks for the pairing token)",
    )  # fmt: skip
    group.add_argument(
        "--hmi-allow-host", action="append", default=[], metavar="NAME",
        help="also answer to NAME, a host name or address a browser reaches this machine by "
        "(e.g. cabin-pc.lab; repeatable). Always answered: 127.0.0.1, localhost, [::1], the "
        "bind address and the address a connection arrives on; any other Host is refused "
        "(403), as are WebSockets opened by pages of another origin",
    )  # fmt: skip
    group.add_argument(
        "--hmi-token", action="store_true",
        help="ask for the pairing token on loopback too (other local accounts then cannot "
        "press the car's buttons). Beyond loopback it is always asked for: the node prints "
        "a pairing URL with ?token=... once on stderr; opened in a browser, it is kept as "
        "a cookie",
    )  # fmt: skip
    group.add_argument(
        "--hmi-config", metavar="FILE",
        help="HMI layouts and settings (default: the shipped hmi/<kind>.yaml)",
    )  # fmt: skip


@contextlib.contextmanager
def node_hmi(
    args: argparse.Namespace, kind: str, node: Any, say: Callable[[str], None],
    settings: NodeSettings | None = None,
) -> Iterator[Companion]:  # fmt: skip
    """Serve the node's HMI while the block runs, when --hmi was given. A participant's node
    kind without pages of its own (walk, scripted) serves the questionnaire page only."""
    hmi = Companion("hmi")
    if args.hmi is None:
        yield hmi
        return
    if not 0 <= args.hmi <= 65535:
        raise ValueError(f"--hmi {args.hmi}: not a TCP port (0..65535; 0 picks a free one)")
    from carlaverse.hmi.server import HmiServer

    hosts = _allowed_hosts(args.hmi_allow_host)
    bridge, loaded = _bridge_and_config(args, kind, node, settings)
    try:
        server = HmiServer(bridge, loaded, args.hmi_bind, args.hmi, hosts, args.hmi_token).start()
    except ValueError:  # HmiError: the address, in one line
        bridge.close()
        raise
    hmi.running = server
    say(f"HMI at {server.url}{loaded.config.hmi.home} (pages: "
        f"{', '.join(server.site.pages())})")  # fmt: skip
    if server.token is not None:  # the one place the token leaves the process
        say(f"HMI pairing URL (open it once on the tablet; it holds this run's token, keep "
            f"it private): {server.pairing_url(_address_for_tablets(args.hmi_bind))}")  # fmt: skip
    try:
        yield hmi
    finally:
        server.close()
        hmi.report = server.stats()
        bridge.close()


def _bridge_and_config(
    args: argparse.Namespace, kind: str, node: Any, settings: NodeSettings | None
) -> tuple[Any, Any]:
    """The node's HMI bridge and config; for a participant without pages, questionnaires."""
    from carlaverse.hmi.config import default_config_name, load_hmi_config

    if hasattr(node, "hmi_bridge"):
        loaded = load_hmi_config(args.hmi_config or default_config_name(kind))
        return node.hmi_bridge(), loaded
    if settings is None or not settings.actor_kind:  # an observer answers no questionnaire
        raise ValueError(f"--hmi: node kind {kind!r} has no HMI (drive and bike have one)")
    from carlaverse.hmi.bridge import QuestionnaireOnlyBridge
    from carlaverse.hmi.config import questionnaire_only_config

    return QuestionnaireOnlyBridge(kind, settings.node_id), questionnaire_only_config()


def _allowed_hosts(names: list[str]) -> list[str]:
    from carlaverse.web_policy import check_host_name

    try:
        return [check_host_name(name) for name in names]
    except ValueError as exc:
        raise ValueError(f"--hmi-allow-host {exc}") from None


def _address_for_tablets(bind: str) -> str:
    """The address to print in the pairing URL: the bind address, or for 0.0.0.0 / :: the
    one this host reaches its network from (a connected UDP socket only picks a route,
    it sends nothing); 127.0.0.1 when it has no network."""
    try:
        if not ipaddress.ip_address(bind).is_unspecified:
            return bind
    except ValueError:
        return bind  # a name: the operator's choice
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))  # TEST-NET-1 (RFC 5737): never a real host
        except OSError:
            return "127.0.0.1"
        return str(probe.getsockname()[0])


def hmi_questionnaires(
    hmi: Companion, node_id: str
) -> Callable[[Any, Any], Callable[[], None]] | None:
    """With an HMI: the node shows a study's questionnaires on it (issue 44), asked over its
    session (`run_node(on_session=...)`); the answers go back the same way."""
    if hmi.running is None:
        return None
    server = hmi.running

    def attach(session: Any, keys: Keys) -> Callable[[], None]:
        from carlaverse.hmi.questionnaire import QuestionnaireLink

        return QuestionnaireLink(session, keys, node_id, server).close

    return attach
