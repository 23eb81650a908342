"""The launcher's door: the project's web door (`carlaverse.web_guard`, keeping the rule of
`carlaverse.web_policy`: Host, Origin, Fetch Metadata and token, decided there for every
server) with what is the launcher's own.

- **A token always**, made fresh each launch, also on loopback: the page starts processes.
- **A cookie per port** (`cookie_name`): cookies ignore ports, and two launchers on one host
  must not overwrite each other's token.
- **socket.io's own paths** (`APP_PATHS`): a `?token=` there is a script's credential,
  answered in place, never paired.
- **A redirect**: a page URL with a good `?token=` sets the cookie and goes on to the same URL
  without it with a 303 when the navigation began here (the launcher's own page, or typed);
  when the browser came from another site (the file:// page the launcher opens it on) a
  Strict cookie is not sent along a redirect chain that site began, so the door's page that
  refreshes to it answers instead.
"""

from __future__ import annotations

from collections.abc import Iterable

from carlaverse.web_guard import App, Send, WebGuard, send_reply
from carlaverse.web_policy import DoorPolicy, Scope, door_hosts, request_headers

# Paths the web app's own scripts fetch (socket.io polling, static files).
APP_PATHS = ("/_nicegui",)
NEEDS_TOKEN = (
    "open the URL the launcher printed at start, or send the token from its token file "
    "(Authorization: Bearer TOKEN)"
)
SAME_SITE_STARTS = ("none", "same-origin")  # Sec-Fetch-Site of a navigation begun here


def cookie_name(port: int) -> str:
    """Cookies ignore ports: two launchers on one host each need a name of their own."""
    return f"carlaverse-launcher-{port}"


class HostPolicy:
    """The names the launcher answers to: loopback, its --bind address, --allow-host names."""

    def __init__(self, bind: str, extra: Iterable[str] = ()) -> None:
        self.names = door_hosts(bind, extra)


class Door(WebGuard):
    """The web door with the launcher's policy and its redirect (module docstring)."""

    def __init__(self, app: App, token: str, hosts: HostPolicy, cookie: str) -> None:
        policy = DoorPolicy(hosts.names, token, cookie, host_hint="; see --allow-host",
                            token_hint=NEEDS_TOKEN, server="carlaverse launcher",
                            script_paths=APP_PATHS)  # fmt: skip
        super().__init__(app, policy)

    async def _paired(self, scope: Scope, send: Send, clean: str) -> None:
        if request_headers(scope).get("sec-fetch-site", "none") not in SAME_SITE_STARTS:
            await super()._paired(scope, send, clean)
            return
        await send_reply(send, 303, b"", self.cookie_header(), (b"location", clean.encode()))
