"""The web HMI server: pages over HTTP, telemetry and commands over one WebSocket per page.

Its door (carlaverse.web_guard, keeping carlaverse.web_policy's rule, as the launcher's does)
answers only to this machine's names and those the operator adds (`allowed_hosts`), lets
pages of another origin reach nothing (the WebSocket included) and refuses what another
page embeds, and forbids framing; beyond loopback, or with `require_token`, it asks for a
pairing token made per run (`token`, `pairing_url()`), which a page keeps as a cookie.

It runs Starlette on uvicorn in a thread of its own with its own asyncio loop, beside the
node's fabric loop, and never blocks it: telemetry is read from the bridge at the frame rate
(the control loop's latest-value slot), commands go back through the bridge's queue. Each
page gets the newest frame only: a slow page skips frames rather than queueing them, while
info, messages, pongs and rejections are always delivered in order.

    server = HmiServer(bridge, load_hmi_config("hmi/drive.yaml"), port=8080).start()
    server.show_message("Take the next exit", seconds=5)
    ...
    server.close()
"""

from __future__ import annotations

import asyncio
import logging
import socket
import threading
import time
from collections import deque
from collections.abc import Iterable
from typing import Any
from urllib.parse import quote

import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from carlaverse.hmi.bridge import HmiBridge
from carlaverse.hmi.config import LoadedHmiConfig
from carlaverse.hmi.questionnaire import QuestionnaireDesk
from carlaverse.hmi.site import Site
from carlaverse.hmi.wire import (
    ENCODER,
    Answer,
    Info,
    InputCheck,
    Message,
    Ping,
    Pong,
    Rejected,
    Telemetry,
)
from carlaverse.web_guard import WebGuard
from carlaverse.web_policy import DoorPolicy, door_hosts, is_loopback, new_token

log = logging.getLogger(__name__)

START_TIMEOUT_S = 10.0
MAX_MESSAGE_S = 3600.0  # [s] longest a pushed message stays up


class HmiError(ValueError):
    """The HMI cannot serve (address in use, bad bind address)."""


class _Page:
    """One connected page: the newest frame for it, and frames that must all arrive."""

    def __init__(self, socket_: WebSocket) -> None:
        self.socket = socket_
        self.frame: bytes | None = None
        self.ordered: deque[bytes] = deque(maxlen=256)
        self.wake = asyncio.Event()

    def offer(self, frame: bytes) -> None:
        self.frame = frame
        self.wake.set()

    def post(self, frame: bytes) -> None:
        self.ordered.append(frame)
        self.wake.set()


class HmiServer:
    """Serves the node's HMI pages on bind:port until `close()`."""

    def __init__(
        self,
        bridge: HmiBridge,
        loaded: LoadedHmiConfig,
        bind: str = "127.0.0.1",
        port: int = 0,
        allowed_hosts: Iterable[str] = (),
        require_token: bool = False,
    ) -> None:
        self.bridge = bridge
        self.settings = loaded.config.hmi
        self.site = Site(loaded)
        self.bind, self.port = bind, port
        self.allowed_hosts = tuple(allowed_hosts)  # names beyond loopback and the bind address
        self.require_token = require_token  # also on loopback; always beyond it
        self.token: str | None = None  # this run's pairing token, once started, if asked
        self._guard: WebGuard | None = None
        self.inputs = InputCheck(bridge.actions, bridge.cruise)
        self._pages: set[_Page] = set()
        self._messages: list[tuple[Message, float]] = []  # with expiry, monotonic [s]
        self._message_ids = 0
        self.questionnaires: QuestionnaireDesk | None = None  # while the node is joined
        self._questionnaire_stats: dict[str, Any] = {}  # of the last desk, once detached
        self.frames_sent = 0  # telemetry frames handed to pages (one per page per frame)
        self.frames_made = 0
        self.telemetry_errors = 0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._started = threading.Event()
        self._server: uvicorn.Server | None = None

    # ------------------------------------------------------------ the caller's side

    @property
    def url(self) -> str:
        host = f"[{self.bind}]" if ":" in self.bind else self.bind
        return f"http://{host}:{self.port}/"

    def pairing_url(self, host: str | None = None) -> str:
        """The home page's address with this run's token (for the operator's terminal
        only): opened once, the page keeps the token as a cookie. `host`: the name or
        address a tablet reaches this machine by (default: the bind address)."""
        if self.token is None:
            raise HmiError("this HMI asks for no pairing token")
        name = host or self.bind
        name = f"[{name}]" if ":" in name else name
        home = quote(self.settings.home)
        return f"http://{name}:{self.port}/{home}?token={self.token}"

    def start(self) -> HmiServer:
        """Bind (raising HmiError in one line) and serve in a thread; returns when ready."""
        listener = _listen(self.bind, self.port)
        address, self.port = listener.getsockname()[:2]
        # The socket's own address decides, not the name given: `localhost` is loopback,
        # 0.0.0.0 and :: are every interface.
        if self.require_token or not is_loopback(address):
            self.token = new_token()
        self._guard = WebGuard(self._app(), self._policy())
        config = uvicorn.Config(
            self._guard, log_level="warning", access_log=False, lifespan="off",
            ws="websockets-sansio", ws_max_size=64 * 1024, timeout_graceful_shutdown=2,
        )  # fmt: skip
        self._server = uvicorn.Server(config)
        self._thread = threading.Thread(
            target=self._run, args=(listener,), name="hmi-server", daemon=True
        )
        self._thread.start()
        if not self._started.wait(START_TIMEOUT_S):
            raise HmiError(f"the HMI did not start within {START_TIMEOUT_S:.0f} s")
        return self

    def _app(self) -> Starlette:
        return Starlette(routes=[
            Route("/api/status", self._status),
            WebSocketRoute("/ws", self._websocket),
            *self.site.routes(),
        ])  # fmt: skip

    def _policy(self) -> DoorPolicy:
        # A cookie name per port: browsers keep cookies per host, not per port, and two
        # nodes on one machine must not overwrite each other's token on a tablet.
        hosts = door_hosts(self.bind, self.allowed_hosts)
        hint = " (join --hmi-allow-host NAME adds one)"
        return DoorPolicy(hosts, self.token, f"carlaverse-hmi-{self.port}", host_hint=hint,
                          server="carlaverse HMI")  # fmt: skip

    def show_message(self, text: str, seconds: float = 5.0) -> None:
        """Show `text` on every page for `seconds` (also on pages that connect meanwhile)."""
        seconds = min(max(float(seconds), 0.1), MAX_MESSAGE_S)
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._push_message, str(text), seconds)

    def attach_questionnaires(self, desk: QuestionnaireDesk | None) -> None:
        """Show `desk`'s questionnaires and hand it the pages' answers (None: no more)."""
        if self.questionnaires is not None:
            self._questionnaire_stats = self.questionnaires.stats()
        self.questionnaires = desk
        if desk is not None:
            desk.show_on(self)

    def post_frame(self, frame: bytes) -> None:
        """Send `frame` to every page, in order with the other ordered frames (any thread)."""
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._post_all, frame)

    def _post_all(self, frame: bytes) -> None:
        for page in self._pages:
            page.post(frame)

    def stats(self) -> dict[str, Any]:
        desk = self.questionnaires
        return {
            "url": self.url,
            "pages_connected": len(self._pages),
            "frames_made": self.frames_made,
            "frames_sent": self.frames_sent,
            "telemetry_errors": self.telemetry_errors,
            "telemetry_torn_reads": self.bridge.torn_reads,
            "inputs_accepted": self.inputs.accepted,
            "inputs_rejected": dict(self.inputs.rejected),
            "token_required": self.token is not None,
            "requests_refused": dict(self._guard.refused) if self._guard else {},
            **(desk.stats() if desk is not None else self._questionnaire_stats),
        }

    def close(self) -> None:
        if self._server is not None:
            self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=10)
            self._thread = None

    # ------------------------------------------------------------ the server's thread

    def _run(self, listener: socket.socket) -> None:
        asyncio.run(self._serve(listener))

    async def _serve(self, listener: socket.socket) -> None:
        assert self._server is not None
        self._loop = asyncio.get_running_loop()
        ticker = asyncio.create_task(self._tick())
        self._started.set()
        try:
            await self._server.serve(sockets=[listener])
        finally:
            ticker.cancel()
            listener.close()

    async def _tick(self) -> None:
        """Read the bridge at the frame rate and offer the frame to every page."""
        period = 1.0 / self.settings.rate_hz
        next_t = time.monotonic()
        while True:
            next_t += period
            await asyncio.sleep(max(0.0, next_t - time.monotonic()))
            if next_t < time.monotonic() - period:
                next_t = time.monotonic()  # fell behind (a loaded host): skip, never burst
            self._expire_messages()
            sample = self._sample() if self._pages else None
            if sample is None:
                continue
            self.frames_made += 1
            frame = ENCODER.encode(Telemetry(self.frames_made, sample[0], sample[1]))
            for page in self._pages:
                page.offer(frame)

    def _sample(self) -> tuple[float, dict[str, Any]] | None:
        """The bridge's telemetry; a failing read (the node closing its state) is counted."""
        try:
            return self.bridge.telemetry()
        except Exception:  # the HMI must outlive a bad read: count it, say it once
            self.telemetry_errors += 1
            if self.telemetry_errors == 1:
                log.exception("reading the node's telemetry for the HMI failed")
            return None

    def _push_message(self, text: str, seconds: float) -> None:
        self._message_ids += 1
        message = Message(self._message_ids, text, seconds)
        self._messages.append((message, time.monotonic() + seconds))
        frame = ENCODER.encode(message)
        for page in self._pages:
            page.post(frame)

    def _expire_messages(self) -> None:
        now = time.monotonic()
        self._messages = [(m, until) for m, until in self._messages if until > now]

    def _info(self) -> bytes:
        b = self.bridge
        return ENCODER.encode(Info(
            b.kind, b.node_id, self.settings.units, self.settings.rate_hz, sorted(b.actions),
            b.cruise, b.static_info(),
        ))  # fmt: skip

    async def _status(self, request: Request) -> Response:
        return JSONResponse(self.stats())

    async def _websocket(self, socket_: WebSocket) -> None:
        await socket_.accept()
        page = _Page(socket_)
        page.post(self._info())
        now = time.monotonic()
        for message, until in self._messages:  # still showing: with the time left
            left = Message(message.id, message.text, round(until - now, 3))
            page.post(ENCODER.encode(left))
        shown = self.questionnaires.page_frame() if self.questionnaires is not None else None
        if shown is not None:  # open now: a page that (re)connects shows it, answers kept
            page.post(shown)
        self._pages.add(page)
        writer = asyncio.create_task(self._write(page))
        try:
            await self._read(page)
        finally:
            self._pages.discard(page)
            writer.cancel()

    async def _read(self, page: _Page) -> None:
        while True:
            event = await page.socket.receive()
            if event["type"] == "websocket.disconnect":
                return
            item, reason = self.inputs.check(event.get("text"))
            if item is None:
                page.post(ENCODER.encode(Rejected(reason)))
            elif isinstance(item, Ping):
                page.post(ENCODER.encode(Pong(item.page_ms, time.monotonic())))
            elif isinstance(item, Answer):
                why = self._answer(item)
                if why:
                    page.post(ENCODER.encode(Rejected(why)))
            else:
                self.bridge.submit(item)

    def _answer(self, item: Answer) -> str:
        desk = self.questionnaires
        return desk.answer(item) if desk is not None else "questionnaire: none is open"

    async def _write(self, page: _Page) -> None:
        try:
            while True:
                await page.wake.wait()
                page.wake.clear()
                while page.ordered:
                    await page.socket.send_text(page.ordered.popleft().decode())
                frame, page.frame = page.frame, None
                if frame is not None:
                    await page.socket.send_text(frame.decode())
                    self.frames_sent += 1
        except (WebSocketDisconnect, RuntimeError, OSError):
            return  # the page went away; its reader ends the connection


def _listen(bind: str, port: int) -> socket.socket:
    """A listening TCP socket on bind:port, or HmiError naming the address and the fix."""
    try:
        infos = socket.getaddrinfo(bind, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise HmiError(f"--hmi-bind {bind!r}: not an address here ({exc.strerror})") from exc
    family, _, _, _, address = infos[0]
    listener = socket.socket(family, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        listener.bind(address)
    except OSError as exc:
        listener.close()
        raise HmiError(
            f"--hmi {port}: cannot listen on {bind}:{port} ({exc.strerror}); pick another port"
        ) from exc
    listener.listen(16)
    listener.setblocking(False)
    return listener
