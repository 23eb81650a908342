"""Each participant's relay delays that participant's link alone, by the trial's condition."""

from __future__ import annotations

import socket
import threading
import time

from carlaverse.study.links import ParticipantLinks
from carlaverse.study.study_file import LinkCondition, Participant


def _echo_server() -> tuple[socket.socket, int]:
    server = socket.create_server(("127.0.0.1", 0))

    def serve() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            threading.Thread(target=_echo, args=(conn,), daemon=True).start()

    threading.Thread(target=serve, daemon=True).start()
    return server, server.getsockname()[1]


def _echo(conn: socket.socket) -> None:
    with conn:
        while data := conn.recv(1024):
            conn.sendall(data)


def _round_trip_s(endpoint: str) -> float:
    host, port = endpoint.removeprefix("tcp/").split(":")
    with socket.create_connection((host, int(port)), timeout=5) as s:
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        started = time.monotonic()
        s.sendall(b"ping")
        assert s.recv(16) == b"ping"
        return time.monotonic() - started


def test_a_participants_delay_is_theirs_alone() -> None:
    server, port = _echo_server()
    people = [Participant(id="P01", role="driver"), Participant(id="P02", role="cyclist")]
    links = ParticipantLinks(people, f"tcp/127.0.0.1:{port}").start()
    try:
        links.apply({"P01": LinkCondition(delay_ms=100)})
        # one way 100 ms on P01's relay, each direction: a round trip takes >= 200 ms
        assert _round_trip_s(links.endpoint("P01")) >= 0.2
        assert _round_trip_s(links.endpoint("P02")) < 0.2
        links.apply({})  # between trials: clear
        assert _round_trip_s(links.endpoint("P01")) < 0.2
        assert links.current["P01"] == LinkCondition()
    finally:
        links.close()
        server.close()
