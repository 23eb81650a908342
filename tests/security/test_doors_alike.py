"""The launcher and the HMI keep one door (issue 41: each thing written once), shown through
their real interfaces: a real `carlaverse launcher` process and a real HmiServer asking for
its token, both on 127.0.0.1, sent the same raw requests byte by byte.

What each should answer is the door's documented rule (carlaverse/web_guard.py's docstring,
README "Its door" and "Host and Origin allow-lists"), applied by hand to each request:

1. Host must name this machine (127.0.0.1 with or without the port): else 403.
2. An Origin, when sent, must be the server's own, `http://` + the Host: else 403.
3. What another page embeds (Sec-Fetch-Site other than same-origin or none, and not a
   top-level navigation to a document) is refused: 403. Another port on 127.0.0.1 is the
   same *site* as the server, not the same *origin*, so it is refused too.
4. The token must be shown (cookie, Bearer or ?token=), equal to the server's: else 401.
Every answer forbids framing. A page address with the token sets an HttpOnly SameSite=Strict
cookie and goes on to the address without the token.
"""

from __future__ import annotations

import logging
import re
import subprocess
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import pytest

from carlaverse.hmi.config import load_hmi_config
from carlaverse.hmi.server import HmiServer
from tests.hmi.scripted import ScriptedBridge
from tests.launcher.served import ServedLauncher
from tests.security.web_client import Reply, http_get, ws_open

pytestmark = pytest.mark.timeout(120)

HMI_YAML = """
hmi: {pages_dir: pages}
layouts:
  dashboard:
    widgets: [{widget: speedometer}]
"""
REFRESH_TO = re.compile(rb'http-equiv="refresh" content="0;url=([^"]*)"')


@dataclass(frozen=True)
class Served:
    """One server under test: where its page and its WebSocket are, and its token."""

    name: str
    port: int
    page: str  # a page a browser opens
    socket: str  # the path of its page's WebSocket
    token: str
    read_log: Callable[[], str]  # what it has logged so far

    def own(self) -> dict[str, str]:
        return {"Host": f"127.0.0.1:{self.port}"}

    def bearer(self) -> dict[str, str]:
        return {**self.own(), "Authorization": f"Bearer {self.token}"}


class _Lines(logging.Handler):
    """Keeps what this process (the HMI's) logs, formatted."""

    def __init__(self) -> None:
        super().__init__()
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(self.format(record))


# the launcher prints its token URL once, on purpose (README: the only place it is shown)
PRINTED_URL = re.compile(r"launcher at http://\S+\?token=\S+\n")


@pytest.fixture(scope="module")
def servers(tmp_path_factory: pytest.TempPathFactory) -> Iterator[list[Served]]:
    root = tmp_path_factory.mktemp("doors")
    (root / "configs").mkdir()
    launcher = ServedLauncher(root / "configs")  # starts in the background meanwhile
    hmi_log = _Lines()
    logging.getLogger().addHandler(hmi_log)
    (root / "pages").mkdir()
    (root / "hmi.yaml").write_text(HMI_YAML)
    config = load_hmi_config(str(root / "hmi.yaml"))
    hmi = HmiServer(ScriptedBridge(), config, require_token=True).start()
    try:
        launcher.wait_ready()
        assert launcher.token is not None and hmi.token is not None
        yield [
            Served("launcher", launcher.port, "/", "/_nicegui_ws/socket.io/?EIO=4&transport="
                   "websocket", launcher.token,
                   lambda: PRINTED_URL.sub("", launcher.log_path.read_text(), count=1)),
            Served("hmi", hmi.port, "/dashboard", "/ws", hmi.token,
                   lambda: "\n".join(hmi_log.lines)),
        ]  # fmt: skip
    finally:
        logging.getLogger().removeHandler(hmi_log)
        hmi.close()
        try:
            launcher.terminate()
        except subprocess.TimeoutExpired:
            launcher.kill()


def wrong(token: str) -> str:
    """As long as the token and of its alphabet, but not it."""
    return ("A" if token[0] != "A" else "B") + token[1:]


def embedded(site: str, mode: str = "no-cors", dest: str = "image") -> dict[str, str]:
    """Fetch Metadata as a browser sends it (w3c.github.io/webappsec-fetch-metadata)."""
    return {"Sec-Fetch-Site": site, "Sec-Fetch-Mode": mode, "Sec-Fetch-Dest": dest}


# (what, headers beside Host 127.0.0.1:{port}, the token shown as Bearer, the rule's answer)
CASES = [
    ("a good request", {}, "good", 200),  # passes 1-4
    ("a foreign Host", {"Host": "evil.example:{port}"}, "good", 403),  # 1
    ("a rebound look-alike", {"Host": "127.0.0.1.evil.example:{port}"}, "good", 403),  # 1
    ("a foreign Origin", {"Origin": "http://evil.example"}, "good", 403),  # 2
    ("another local origin", {"Origin": "http://127.0.0.1:1"}, "good", 403),  # 2
    ("its own Origin", {"Origin": "http://127.0.0.1:{port}"}, "good", 200),  # 2
    ("no token", {}, None, 401),  # 4
    ("a wrong token", {}, "wrong", 401),  # 4
    ("a cross-site image", embedded("cross-site"), "good", 403),  # 3
    ("a same-site image", embedded("same-site"), "good", 403),  # 3: another port, same site
    ("a cross-site frame", embedded("cross-site", "navigate", "iframe"), "good", 403),  # 3
    ("a link from another site", embedded("cross-site", "navigate", "document"), "good", 200),
    ("its own page's image", embedded("same-origin"), "good", 200),  # 3
]


def request_headers(served: Served, extra: dict[str, str], token: str | None) -> dict[str, str]:
    headers = {"Host": "127.0.0.1:{port}", **extra}
    if token is not None:
        shown = served.token if token == "good" else wrong(served.token)
        headers["Authorization"] = f"Bearer {shown}"
    return {name: value.format(port=served.port) for name, value in headers.items()}


@pytest.mark.parametrize("what, extra, token, expected", CASES, ids=[c[0] for c in CASES])
def test_both_servers_answer_a_request_as_the_rule_says(
    servers: list[Served], what: str, extra: dict[str, str], token: str | None, expected: int
) -> None:
    answers = {}
    for served in servers:
        reply = http_get(served.port, served.page, request_headers(served, extra, token))
        assert reply.header("X-Frame-Options") == "DENY", f"{served.name}: {what}"
        answers[served.name] = reply.status
    assert answers == dict.fromkeys(answers, expected), what


@pytest.mark.parametrize("origin, token, expected", [
    ("http://evil.example", True, 403),  # 2: cross-site WebSocket hijacking
    ("http://127.0.0.1:1", True, 403),  # 2: another local origin
    (None, False, 401),  # 4: a program sends no Origin; the token stops it
    ("own", True, 101),  # the page's own, with the token: the socket opens
])  # fmt: skip
def test_both_servers_open_a_websocket_only_as_the_rule_says(
    servers: list[Served], origin: str | None, token: bool, expected: int
) -> None:
    answers = {}
    for served in servers:
        headers = served.bearer() if token else served.own()
        if origin is not None:
            headers["Origin"] = f"http://127.0.0.1:{served.port}" if origin == "own" else origin
        with ws_open(served.port, served.socket, headers) as ws:
            answers[served.name] = ws.reply.status
    assert answers == dict.fromkeys(answers, expected), origin


def test_both_servers_pair_a_token_in_the_address_into_a_strict_cookie(
    servers: list[Served],
) -> None:
    for served in servers:
        for path, onward in (
            (f"{served.page}?token={served.token}&units=mph", f"{served.page}?units=mph"),
            # `\` may not stand in a path (RFC 3986 §3.3): percent-encoded, as browsers would
            # otherwise read it as `/` and go on to `//evil.example`, another site
            (f"/\\evil.example?token={served.token}", "/%5Cevil.example"),
        ):
            reply = http_get(served.port, path, served.own())
            [cookie] = reply.headers["set-cookie"]
            name, _, rest = cookie.partition("=")
            attributes = {a.strip().lower() for a in rest.split(";")[1:]}
            assert rest.split(";")[0] == served.token and name.startswith("carlaverse-")
            assert attributes == {"path=/", "httponly", "samesite=strict"}, served.name
            assert _goes_on_to(reply) == onward, served.name  # never `//host`: another site
            assert served.token.encode() not in reply.body
        stale = f"{served.page}?token={wrong(served.token)}"
        kept = {**served.own(), "Cookie": cookie.split(";")[0]}
        assert http_get(served.port, stale, kept).status == 401, served.name  # 4: wrong in URL


def test_neither_server_writes_its_token_in_its_log(servers: list[Served]) -> None:
    for served in servers:  # refused for its Host while showing the token everywhere it goes
        shown = {"Host": "evil.example", "Authorization": f"Bearer {served.token}",
                 "Cookie": f"carlaverse-{served.name}-{served.port}={served.token}"}  # fmt: skip
        assert http_get(served.port, f"/?token={served.token}", shown).status == 403
    for served in servers:
        logged = served.read_log()
        assert "refused request" in logged, f"the {served.name} logged no refusal"
        assert served.token not in logged, f"the {served.name}'s log holds its token"


def _goes_on_to(reply: Reply) -> str:
    """Where a pairing answer sends the browser: its Location, or its page's refresh."""
    if reply.status == 303:
        return reply.header("Location") or ""
    found = REFRESH_TO.search(reply.body)
    assert reply.status == 200 and found is not None, reply.status
    return found[1].decode().replace("&amp;", "&")
