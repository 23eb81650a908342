"""The drive node's HMI door end to end: a real router, authority and drive node process
(`join drive --backend sim --hmi 0`), handshakes written byte by byte, the car watched
through its own page's WebSocket, and a tablet's pairing played by headless Chromium."""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Browser
from websockets.sync.client import ClientConnection, connect

from tests.hmi.live import node_with_hmi
from tests.security.web_client import http_get, ws_open
from tests.support import Cluster, Proc, wait_until

HAZARD = json.dumps({"type": "press", "action": "hazard"})
CRUISE_SET = json.dumps({"type": "cruise", "command": "set"})
WATCH_S = 2.0  # [s] how long the car is watched for an effect of the refused presses
HMI_AT = re.compile(r"HMI at http://\S+?:(\d+)/")
PAIRING = re.compile(r"HMI pairing URL[^\n]*?: (http://\S+?\?token=([A-Za-z0-9_-]+))\n")


@pytest.fixture(scope="module")
def car(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Cluster, Proc, str]]:
    with node_with_hmi(tmp_path_factory.mktemp("lock"), "drive", "car") as running:
        yield running


def _port(url: str) -> int:
    return int(url.rsplit(":", 1)[1].split("/")[0])


def _telemetry(page_socket: ClientConnection, until: Callable[[dict[str, Any]], bool],
               seconds: float) -> list[dict[str, Any]]:  # fmt: skip
    """The car's telemetry values, frame by frame, until `until` holds or `seconds` pass."""
    seen: list[dict[str, Any]] = []
    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        try:
            frame = json.loads(page_socket.recv(timeout=left))
        except TimeoutError:
            break
        if frame["type"] == "telemetry":
            seen.append(frame["values"])
            if until(seen[-1]):
                break
    return seen


def _moved(values: dict[str, Any]) -> bool:
    """What the two presses do to the car: hazard lights on, the cruise control holding."""
    return values["indicator"] == "hazard" or values["cruise_active"]


def test_a_foreign_origin_cannot_press_the_cars_buttons(car: tuple[Cluster, Proc, str]) -> None:
    _, _, url = car
    port = _port(url)
    own = f"http://127.0.0.1:{port}"
    with connect(f"ws://127.0.0.1:{port}/ws", origin=own) as page_socket:  # type: ignore[arg-type]
        _telemetry(page_socket, lambda v: True, 30)  # the car's loop runs
        # the attacker's page: its browser names its own origin, as browsers always do
        with ws_open(port, "/ws", {"Host": f"127.0.0.1:{port}", "Origin": "http://evil.example"}
                     ) as attacker:  # fmt: skip
            if attacker.reply.status == 101:
                attacker.send_then_sync(HAZARD, CRUISE_SET)
        watched = _telemetry(page_socket, _moved, WATCH_S)
        moved = [v for v in watched if _moved(v)]
        assert attacker.reply.status == 403 and not moved, (
            f"Origin http://evil.example: handshake {attacker.reply.status}, "
            f"car moved in {len(moved)} of {len(watched)} frames"
        )
        # The same presses from the page's own origin do act, and in far less than the
        # watch above: so the watch would have seen them had the door let them through.
        sent = time.monotonic()
        page_socket.send(HAZARD)
        page_socket.send(CRUISE_SET)
        acted = _telemetry(page_socket, lambda v: v["indicator"] == "hazard"
                           and v["cruise_active"], 10)  # fmt: skip
        took_s = time.monotonic() - sent
        assert acted and acted[-1]["indicator"] == "hazard" and acted[-1]["cruise_active"]
        assert took_s < WATCH_S / 2, f"the own-origin presses took {took_s:.2f} s to act"
        page_socket.send(HAZARD)  # hazard off again, cruise cancelled: the car as it was
        page_socket.send(json.dumps({"type": "cruise", "command": "cancel"}))


def test_a_foreign_host_never_reaches_the_node(car: tuple[Cluster, Proc, str]) -> None:
    _, _, url = car
    port = _port(url)
    rebound = {"Host": f"evil.example:{port}"}  # what a rebound page's browser sends
    assert http_get(port, "/touch", rebound).status == 403
    assert http_get(port, "/api/status", rebound).status == 403
    assert http_get(port, "/touch", {"Host": f"127.0.0.1:{port}"}).status == 200


@pytest.fixture
def cabin_node(tmp_path: Path) -> Iterator[Proc]:
    """A drive node serving its HMI on every address (a cabin tablet's case)."""
    cluster = Cluster(tmp_path)
    try:
        cluster.router()
        cluster.authority()
        yield cluster.start(
            "join", "drive", "--id", "cab", "--session", "t", "--connect", cluster.endpoint,
            "--backend", "sim", "--duration", "300", "--json",
            "--hmi", "0", "--hmi-bind", "0.0.0.0", name="cab",
        )  # fmt: skip
    finally:
        cluster.close()


def _printed(node: Proc, pattern: re.Pattern[str], what: str) -> re.Match[str]:
    def found() -> re.Match[str] | None:
        if not node.alive():
            raise AssertionError(f"the node exited: {node.output()[-2000:]}")
        return pattern.search("".join(node.stderr))

    return wait_until(found, 30, what)


@pytest.mark.browser
def test_a_node_beyond_loopback_pairs_a_tablet_by_its_token(
    cabin_node: Proc, chromium: Browser
) -> None:
    port = int(_printed(cabin_node, HMI_AT, "the HMI's address").group(1))
    host = {"Host": f"127.0.0.1:{port}"}
    for route in ("/", "/dashboard", "/api/status", "/hmi.js"):
        refused = http_get(port, route, host)
        assert refused.status == 401, f"{route} without the token: {refused.status}"
    with ws_open(port, "/ws", {**host, "Origin": f"http://127.0.0.1:{port}"}) as ws:
        assert ws.reply.status == 401, "the WebSocket without the token"
    pairing = _printed(cabin_node, PAIRING, "the pairing URL on the node's terminal")
    pairing_url, token = pairing.group(1), pairing.group(2)
    assert len(token) * 6 >= 128, f"a {len(token) * 6}-bit token"  # base64url: 6 bits/char
    assert http_get(port, "/dashboard?token=" + "A" * len(token), host).status == 401

    tablet = chromium.new_context()  # a tablet that has never seen this HMI
    try:
        page = tablet.new_page()
        page.goto(pairing_url)
        page.wait_for_function("window.hmi && hmi.frames > 0")  # pages and WebSocket paired
        assert "token" not in page.url and page.url.endswith("/dashboard")
        [cookie] = tablet.cookies()
        assert cookie["value"] == token and cookie["httpOnly"] and cookie["sameSite"] == "Strict"
        assert token not in page.evaluate("document.cookie")  # no script on the page reads it
    finally:
        tablet.close()

    assert cabin_node.stop() == 0
    summary = cabin_node.json()
    door = summary["extra"]["hmi"]
    assert door["token_required"] is True
    assert door["requests_refused"]["token"] >= 6  # the six tokenless tries above, counted
    assert token not in "".join(cabin_node.stdout), "the token left through --json"
    assert "".join(cabin_node.stderr).count(token) == 1, "the token printed once, on stderr"
