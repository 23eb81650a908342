"""A raw HTTP/WebSocket client for door tests: every header exactly as the test writes it.

Library clients fill in Host and leave Origin out, and a browser cannot be told to lie about
either; an attacker's script can, so these tests speak HTTP over a plain socket. The
WebSocket part is RFC 6455 as far as a handshake and one masked text frame go.

    reply = http_get(port, "/", {"Host": "evil.example"})
    reply.status == 403
    with ws_open(port, "/ws", {"Host": f"127.0.0.1:{port}", "Origin": "http://evil.example"}) as ws:
        ws.reply.status == 403
"""

from __future__ import annotations

import base64
import os
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

TIMEOUT_S = 10.0  # [s] a reply on 127.0.0.1 takes milliseconds; this only ends a hung test


@dataclass(frozen=True)
class Reply:
    status: int
    headers: dict[str, list[str]]  # lower-case names; a name may repeat (Set-Cookie)
    body: bytes

    def header(self, name: str) -> str | None:
        values = self.headers.get(name.lower())
        return values[0] if values else None


def http_get(port: int, path: str, headers: dict[str, str]) -> Reply:
    """GET path from 127.0.0.1:port sending exactly `headers` (give Host yourself)."""
    with socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT_S) as sock:
        sock.sendall(_request(path, {**headers, "Connection": "close"}))
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    status, parsed = _parse_head(head)
    return Reply(status, parsed, body)


class OpenSocket:
    """A WebSocket handshake's reply and, when it was 101, the open socket."""

    def __init__(self, sock: socket.socket, reply: Reply) -> None:
        self.sock = sock
        self.reply = reply

    def send_text(self, text: str) -> None:
        """One masked text frame (RFC 6455 §5.2: a client masks every frame)."""
        data = text.encode()
        assert len(data) < 126, "one short frame is all these tests send"
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(data))
        self.sock.sendall(bytes([0x81, 0x80 | len(data)]) + mask + masked)

    def send_then_sync(self, *texts: str) -> None:
        """Send `texts`, then a ping, and return once its pong is back: the server reads a
        connection's frames in order, so by then it has handled every one of `texts`."""
        for text in (*texts, '{"type": "ping", "page_ms": 1}'):
            self.send_text(text)
        seen = b""
        while b'"type":"pong"' not in seen:
            chunk = self.sock.recv(65536)
            assert chunk, "the server closed the WebSocket before its pong"
            seen = seen[-64:] + chunk


@contextmanager
def ws_open(port: int, path: str, headers: dict[str, str]) -> Iterator[OpenSocket]:
    """Attempt a WebSocket handshake on 127.0.0.1:port with exactly `headers` (+ upgrade)."""
    key = base64.b64encode(os.urandom(16)).decode()
    upgrade = {"Upgrade": "websocket", "Connection": "Upgrade", "Sec-WebSocket-Key": key,
               "Sec-WebSocket-Version": "13"}  # fmt: skip
    sock = socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT_S)
    try:
        sock.sendall(_request(path, {**headers, **upgrade}))
        data = b""
        while b"\r\n\r\n" not in data:
            chunk = sock.recv(4096)
            if not chunk:
                break
            data += chunk
        head, _, body = data.partition(b"\r\n\r\n")
        status, parsed = _parse_head(head)
        yield OpenSocket(sock, Reply(status, parsed, body))
    finally:
        sock.close()


def _request(path: str, headers: dict[str, str]) -> bytes:
    lines = [f"GET {path} HTTP/1.1", *(f"{k}: {v}" for k, v in headers.items()), "", ""]
    return "\r\n".join(lines).encode("latin-1")


def _parse_head(head: bytes) -> tuple[int, dict[str, list[str]]]:
    lines = head.decode("latin-1").split("\r\n")
    if not lines[0].startswith("HTTP/1.1 "):
        return 0, {}  # the server closed without a reply
    headers: dict[str, list[str]] = {}
    for line in lines[1:]:
        name, _, value = line.partition(":")
        headers.setdefault(name.strip().lower(), []).append(value.strip())
    return int(lines[0].split()[1]), headers
