"""The web HMI's door, attacked over real sockets: a real HmiServer on 127.0.0.1 in this
process (its node side scripted, every command it passes on recorded), raw HTTP and
WebSocket handshakes written byte by byte, a second local account, and headless Chromium.

What each check stands for (issue 39):
- DNS rebinding: a page whose name was rebound to 127.0.0.1 reaches the port, but its
  browser sends the page's own name in `Host`. Only this machine's names may be served.
- Cross-site WebSocket hijacking: any page may open `ws://127.0.0.1:PORT/ws`; its browser
  always sends the page's origin in `Origin`. Only the HMI's own origin may open it.
- Clickjacking: a page on another origin must not show the HMI in a frame.
- A symlink in the pages folder must not serve a file outside it.
- Beyond loopback (or with the token asked for): whoever does not hold the pairing token,
  another local account included, is refused before anything reaches the car.
"""

from __future__ import annotations

import json
import os
import pwd
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest
from playwright.sync_api import Page

from carlaverse.hmi.config import load_hmi_config
from carlaverse.hmi.server import HmiServer
from carlaverse.hmi.wire import Cruise, Press
from tests.hmi.scripted import ScriptedBridge
from tests.security.web_client import http_get, ws_open

HMI_YAML = """
hmi: {pages_dir: pages}
layouts:
  dashboard:
    widgets: [{widget: speedometer}]
"""
ROUTES = ["/", "/dashboard", "/api/status", "/api/layout/dashboard", "/hmi.js", "/nothing"]
HAZARD = json.dumps({"type": "press", "action": "hazard"})
CRUISE_SET = json.dumps({"type": "cruise", "command": "set"})
HORN = json.dumps({"type": "press", "action": "horn"})


@pytest.fixture
def bridge() -> ScriptedBridge:
    car = ScriptedBridge()
    car.actions = frozenset({"hazard", "horn", "low_beam"})  # the drive node's, in part
    return car


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "pages").mkdir()
    (tmp_path / "hmi.yaml").write_text(HMI_YAML)
    return tmp_path


def _serve(bridge: ScriptedBridge, folder: Path, **options: object) -> HmiServer:
    return HmiServer(bridge, load_hmi_config(str(folder / "hmi.yaml")), **options).start()  # type: ignore[arg-type]


@pytest.fixture
def server(bridge: ScriptedBridge, folder: Path) -> Iterator[HmiServer]:
    running = _serve(bridge, folder)  # as `join --hmi PORT` runs it: 127.0.0.1, no flags
    try:
        yield running
    finally:
        running.close()


def _press(port: int, headers: dict[str, str], *messages: str) -> int:
    """Open /ws with `headers`, send `messages` if the handshake succeeded; the status."""
    with ws_open(port, "/ws", headers) as ws:
        if ws.reply.status == 101:
            ws.send_then_sync(*messages)
        return ws.reply.status


# ------------------------------------------------------------------ Host (DNS rebinding)


@pytest.mark.parametrize("host", [
    "evil.example", "evil.example:{port}", "127.0.0.1.evil.example:{port}",
    "localhost.evil.example", "attacker.localhost.evil:{port}", "", "127.0.0.1@evil.example",
])  # fmt: skip
def test_a_foreign_host_is_refused_on_every_route(server: HmiServer, host: str) -> None:
    # A rebound page names itself in Host; none of these names is this machine's.
    named = host.format(port=server.port)
    for route in ROUTES:
        reply = http_get(server.port, route, {"Host": named})
        assert reply.status == 403, f"GET {route} with Host {named!r}: {reply.status}"
        assert b"<html" not in reply.body.lower() and b"speedometer" not in reply.body
    status = _press(server.port, {"Host": named, "Origin": f"http://{named}"}, HAZARD)
    assert status == 403, f"/ws with Host {named!r}: {status}"


def test_the_machines_own_names_are_served(server: HmiServer) -> None:
    # 127.0.0.1, localhost and [::1] name this machine; the port is optional in Host
    # (RFC 9110 §7.2), and names are case-insensitive (RFC 4343).
    port = server.port
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"[::1]:{port}", "localhost",
                 f"LocalHost:{port}"):  # fmt: skip
        reply = http_get(port, "/dashboard", {"Host": host})
        assert reply.status == 200, f"Host {host!r}: {reply.status}"


def test_a_name_given_by_the_operator_is_served(bridge: ScriptedBridge, folder: Path) -> None:
    running = _serve(bridge, folder, allowed_hosts=["cabin-pc.lab"])
    try:
        assert http_get(running.port, "/", {"Host": f"cabin-pc.lab:{running.port}"}).status == 200
        assert http_get(running.port, "/", {"Host": "other-pc.lab"}).status == 403
    finally:
        running.close()


# ------------------------------------------------------------------ Origin (CSWSH)


@pytest.mark.parametrize("origin", [
    "http://evil.example", "null", "http://127.0.0.1:1", "https://localhost.evil.example",
    "http://127.0.0.1:{port}.evil.example", "file://",
])  # fmt: skip
def test_a_websocket_from_a_foreign_origin_is_refused_and_moves_nothing(
    server: HmiServer, bridge: ScriptedBridge, origin: str
) -> None:
    port = server.port
    named = origin.format(port=port)
    status = _press(port, {"Host": f"127.0.0.1:{port}", "Origin": named}, HAZARD, CRUISE_SET)
    # The same presses from the page's own origin arrive (so a refusal is the door's work):
    own = _press(port, {"Host": f"127.0.0.1:{port}", "Origin": f"http://127.0.0.1:{port}"},
                 HORN)  # fmt: skip
    assert own == 101
    assert (status, bridge.commands) == (403, [Press("horn")]), f"Origin {named!r}"


def test_the_pages_own_origin_opens_the_websocket_and_its_presses_act(
    server: HmiServer, bridge: ScriptedBridge
) -> None:
    port = server.port
    for host in (f"127.0.0.1:{port}", f"localhost:{port}"):
        status = _press(port, {"Host": host, "Origin": f"http://{host}"}, HAZARD, CRUISE_SET)
        assert status == 101, f"same origin http://{host}: {status}"
    assert bridge.commands == [Press("hazard"), Cruise("set")] * 2


def test_a_client_without_origin_is_not_a_browser_and_may_connect_on_loopback(
    server: HmiServer, bridge: ScriptedBridge
) -> None:
    # Browsers send Origin on every WebSocket handshake (RFC 6455 §4.1, Fetch); a client
    # that sends none is a program, which could as well send a forged one: Origin cannot
    # stop it, the pairing token does (tested below). Documented in the README.
    port = server.port
    assert _press(port, {"Host": f"127.0.0.1:{port}"}, HORN) == 101
    assert bridge.commands == [Press("horn")]


# ------------------------------------------------------------------ framing (clickjacking)


def test_every_response_forbids_framing(server: HmiServer) -> None:
    port = server.port
    for route, host in [(r, f"127.0.0.1:{port}") for r in ROUTES] + [("/", "evil.example")]:
        reply = http_get(port, route, {"Host": host})
        assert reply.header("X-Frame-Options") == "DENY", f"{route} ({reply.status})"
        assert "frame-ancestors 'none'" in (reply.header("Content-Security-Policy") or "")


class _FramingPage(BaseHTTPRequestHandler):
    """Another local origin: a page that frames the HMI, and one that frames itself."""

    hmi_url = ""

    def do_GET(self) -> None:
        own = f"http://localhost:{self.server.server_address[1]}/plain"
        body = (f"<!doctype html><title>framer</title><iframe id='hmi' src='{self.hmi_url}'>"
                f"</iframe><iframe id='own' src='{own}'></iframe>" if self.path == "/"
                else "<!doctype html><p id='framed'>framed fine</p>")  # fmt: skip
        data = body.encode()
        self.send_response(200)
        self.send_header("Content-Type", "text/html")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def log_message(self, *args: object) -> None:
        pass


@pytest.mark.browser
def test_a_page_on_another_local_origin_cannot_show_the_hmi_in_a_frame(
    server: HmiServer, page: Page
) -> None:
    _FramingPage.hmi_url = server.url + "dashboard"
    framer = ThreadingHTTPServer(("127.0.0.1", 0), _FramingPage)
    threading.Thread(target=framer.serve_forever, daemon=True).start()
    try:
        # the load event waits for both frames to finish: shown, or replaced by an error page
        page.goto(f"http://localhost:{framer.server_address[1]}/")
        frames = {f.name or f.url: f for f in page.main_frame.child_frames}
        own = page.frame_locator("#own").locator("#framed")
        assert own.text_content() == "framed fine"  # a frame on that page does show
        hmi = page.frame_locator("#hmi").locator("#layout")
        assert hmi.count() == 0, "the HMI's dashboard is shown inside another site's frame"
        shown = [f.url for f in frames.values() if f.url.startswith(server.url)]
        assert shown == [], f"a frame holds the HMI: {shown}"
    finally:
        framer.shutdown()
        framer.server_close()


# ------------------------------------------------------------------ pages_dir symlinks


def test_a_symlink_out_of_the_pages_folder_is_not_served(server: HmiServer, folder: Path) -> None:
    outside = folder / "outside"
    outside.mkdir()
    (outside / "secret.html").write_text("<p>operator's secret</p>")
    (outside / "secret.js").write_text("const secret = 'operator';")
    pages = folder / "pages"
    (pages / "mine.html").write_text("<p>my page</p>")
    (pages / "alias.html").symlink_to(pages / "mine.html")  # inside: still the folder's
    (pages / "leak.html").symlink_to(outside / "secret.html")
    (pages / "leak.js").symlink_to(outside / "secret.js")
    (pages / "passwd.js").symlink_to("/etc/passwd")
    host = {"Host": f"127.0.0.1:{server.port}"}
    assert http_get(server.port, "/alias", host).body == b"<p>my page</p>"
    for route in ("/leak", "/leak.js", "/passwd.js"):
        reply = http_get(server.port, route, host)
        assert reply.status == 404, f"{route}: {reply.status} {reply.body[:80]!r}"
        assert b"secret" not in reply.body and b"root:" not in reply.body
    index = http_get(server.port, "/", host).body.decode()
    assert "mine" in index and "leak" not in index


# ------------------------------------------------------------------ the pairing token


NOBODY_CLIENT = """
import encodings.idna, json, os, pwd, sys  # all imported while still root: nobody cannot
from tests.security.web_client import ws_open  # read this interpreter's folder
port, token = int(sys.argv[1]), sys.argv[2]
nobody = pwd.getpwnam("nobody")
os.setgroups([]); os.setgid(nobody.pw_gid); os.setuid(nobody.pw_uid)
path = f"/ws?token={token}" if token else "/ws"
with ws_open(port, path, {"Host": f"127.0.0.1:{port}"}) as ws:
    if ws.reply.status == 101:
        ws.send_then_sync(json.dumps({"type": "press", "action": "horn"}))
    print(json.dumps({"uid": os.getuid(), "status": ws.reply.status}))
"""


def _as_nobody(port: int, token: str) -> dict[str, int]:
    """A raw client (no Origin: not a browser) run by uid nobody against 127.0.0.1:port."""
    done = subprocess.run(
        [sys.executable, "-c", NOBODY_CLIENT, str(port), token], capture_output=True,
        text=True, timeout=30, cwd=Path(__file__).parents[2],
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.skipif(os.geteuid() != 0, reason="a second local uid needs root to switch to")
@pytest.mark.parametrize("bind, options", [
    ("0.0.0.0", {}),  # beyond loopback: the token is always asked for
    ("127.0.0.1", {"require_token": True}),  # `--hmi-token`: asked for on loopback too
])  # fmt: skip
def test_another_local_account_without_the_token_is_refused(
    bridge: ScriptedBridge, folder: Path, bind: str, options: dict[str, object]
) -> None:
    nobody_uid = pwd.getpwnam("nobody").pw_uid
    running = _serve(bridge, folder, bind=bind, **options)
    try:
        refused = _as_nobody(running.port, "")
        assert refused["uid"] == nobody_uid
        assert refused["status"] == 401, f"uid nobody without the token: {refused}"
        token = running.token
        assert token is not None and len(token) * 6 >= 128  # base64url: 6 bits a character
        paired = _as_nobody(running.port, token)  # the same client holding it gets in
        assert paired == {"uid": nobody_uid, "status": 101}
        assert bridge.commands == [Press("horn")]  # only the paired press
    finally:
        running.close()


def test_the_pairing_address_leaves_a_strict_cookie_and_goes_on_without_the_token(
    bridge: ScriptedBridge, folder: Path
) -> None:
    running = _serve(bridge, folder, require_token=True)
    try:
        port, token = running.port, running.token
        assert token is not None
        host = {"Host": f"127.0.0.1:{port}"}
        paired = http_get(port, f"/dashboard?units=mph&token={token}", host)
        assert paired.status == 200
        [cookie] = paired.headers["set-cookie"]
        attributes = {a.strip().lower() for a in cookie.split(";")[1:]}
        assert cookie.startswith(f"carlaverse-hmi-{port}={token};")
        assert attributes == {"path=/", "httponly", "samesite=strict"}
        assert b'url=/dashboard?units=mph"' in paired.body and token.encode() not in paired.body
        # a path that a browser would read as another site's address goes on to this one
        twisted = http_get(port, f"//evil.example/x?token={token}", host)
        assert b'url=/evil.example/x"' in twisted.body
        kept = {**host, "Cookie": f"other=1; carlaverse-hmi-{port}={token}"}
        assert http_get(port, "/dashboard", kept).status == 200
        assert http_get(port, "/api/status", {**host, "Authorization": f"Bearer {token}"}
                        ).status == 200  # fmt: skip
        for wrong in (f"carlaverse-hmi-{port}={token[:-1]}", f"carlaverse-hmi-1={token}"):
            assert http_get(port, "/dashboard", {**host, "Cookie": wrong}).status == 401
        # the token opens the door, it does not replace the Origin check
        with ws_open(port, f"/ws?token={token}", {**host, "Origin": "http://evil.example"}) as ws:
            assert ws.reply.status == 403
    finally:
        running.close()


def test_another_loopback_address_is_still_loopback(bridge: ScriptedBridge, folder: Path) -> None:
    # 127.0.0.0/8 is loopback (RFC 1122 §3.2.1.3): no token asked, the bind address served
    running = _serve(bridge, folder, bind="127.0.0.2")
    try:
        assert running.token is None
        with socket.create_connection(("127.0.0.2", running.port), timeout=10) as sock:
            sock.sendall(f"GET /dashboard HTTP/1.1\r\nHost: 127.0.0.2:{running.port}\r\n"
                         "Connection: close\r\n\r\n".encode())  # fmt: skip
            assert sock.recv(12) == b"HTTP/1.1 200"
    finally:
        running.close()
