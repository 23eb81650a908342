"""A node's web HMI as the launcher starts it, and the pairing URL it takes from the node.

`carlaverse join drive|bike --hmi PORT --hmi-bind ADDR` beyond loopback asks for a pairing
token and prints the URL that carries it once, on stderr (`carlaverse.cli.join_hmi`):

    carlaverse join: HMI pairing URL (open it once on the tablet; ...): http://10.0.0.5:8080/dashboard?token=...

The launcher shows that URL as a QR code for a cabin tablet and keeps it in memory only. Which
line it believes (`PairingWatch`): the FIRST line of the node's STDERR that is exactly such a
line and names the port the launcher asked for. Stdout is never read for it (it carries
`--json` and whatever a scenario makes a node print), and the node prints this line before it
opens the fabric (`join` enters its HMI before `run_node`), so no line carrying another
participant's words can come first; any later line, however well forged, changes nothing.

The live log the page shows never holds the token (`processes.redact_tokens`: `?token=…`):
that log is read by whoever holds the launcher's token, not only by whoever sits in the cab.
"""

from __future__ import annotations

import ipaddress
import re
import threading

from carlaverse.launcher.processes import LaunchError

LOOPBACK = "127.0.0.1"
EVERY_ADDRESS = "0.0.0.0"  # this machine's network addresses: what a tablet on the lab LAN reaches
# The node's own line in full (join_hmi.node_hmi through cli.common.say), nothing before or
# after it. Host, path and token are held to the characters the node writes (an IP literal or
# name, a quoted page name, base64url), so what is shown can never carry markup or spaces.
PAIRING_LINE = re.compile(
    r"carlaverse join: HMI pairing URL \([^()]*\): "
    r"(?P<url>http://(?:[A-Za-z0-9.-]+|\[[0-9A-Fa-f:.]+\]):(?P<port>[0-9]{1,5})"
    r"/[A-Za-z0-9._~%/-]*\?token=[A-Za-z0-9_-]{22,})"
)  # 22 base64url characters: the 128 bits issue 39 asks for; the node makes 43 (256 bit)


def hmi_argv(port: object, bind: object) -> list[str]:
    """`--hmi PORT --hmi-bind BIND` for a node; LaunchError naming a bad value."""
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise LaunchError(f"HMI port {port!r}: not a TCP port (a whole number 1..65535)")
    try:
        address = ipaddress.ip_address(bind if isinstance(bind, str) else "")
    except ValueError:
        raise LaunchError(
            f"HMI bind address {bind!r}: not an IP address ({LOOPBACK}: this machine only; "
            f"{EVERY_ADDRESS}: its network addresses, with a pairing token)"
        ) from None
    return ["--hmi", str(port), "--hmi-bind", str(address)]


class PairingWatch:
    """Fed a node's stderr lines; keeps the first exact pairing line's URL for `port`."""

    def __init__(self, port: int) -> None:
        self.port = port
        self._url: str | None = None
        self._lock = threading.Lock()

    @property
    def url(self) -> str | None:
        with self._lock:
            return self._url

    def feed(self, line: str) -> None:
        """One stderr line (its newline optional); only the first exact match is kept."""
        with self._lock:
            if self._url is not None:
                return
            found = PAIRING_LINE.fullmatch(line.rstrip("\r\n"))
            if found is not None and int(found["port"]) == self.port:
                self._url = found["url"]
