"""Force-feedback path on loopback: the client's encode+send cost and the packets/s the
`carlaverse ffb-server` sustains without loss.

Client side: `UdpFfb.send` (range checks + 40-byte pack + non-blocking send) timed over many
calls, next to its parts. Server side: the real CLI (`carlaverse ffb-server --backend log`) in
its own process, fed at fixed rates for a few seconds each by this process; its exit summary
says how many packets it read and applied. The haptics loop needs 1 kHz; the server should
keep up with far more than that.
"""

from __future__ import annotations

import argparse
import re
import socket
import sys
import threading
import time

from benchdoc import RunInfo, command_line, write_section

from carlaverse.hal import ffb_packet, open_ffb
from carlaverse.hal.ffb_packet import FfbCommand
from carlaverse.procs import free_port, start, stop_children

COMMAND = FfbCommand(
    spring_stiffness=4000, spring_offset=-120, spring_deadband=50, spring_saturation=9000,
    constant_force=-1500, damper=800, friction=300, inertia=100, vibration_magnitude=400,
    vibration_frequency_hz=35,
)  # fmt: skip
HAPTICS_RATE_HZ = 1000  # [packets/s] the drive node's haptics loop
READY_TIMEOUT_S = 30.0  # [s] for the server to say it listens
CLIENT_TARGET_US = 10.0  # [µs] encode + send, so the 1 kHz loop barely notices


def per_call_us(fn, calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - start) / calls * 1e6


def client_costs(calls: int) -> dict[str, float]:
    """µs per call of encode, raw send, and encode+send through the `udp` backend."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    sink.setblocking(False)
    stop = threading.Event()
    threading.Thread(target=drain, args=(sink, stop), daemon=True).start()
    ffb = open_ffb({"backend": "udp", "options": {"port": sink.getsockname()[1]}})
    packet = ffb_packet.encode(COMMAND)
    sock = ffb.sender.sock
    results = {
        "encode (checks + pack)": per_call_us(lambda: ffb_packet.encode(COMMAND), calls),
        "socket send only": per_call_us(lambda: sock.send(packet), calls),
        "UdpFfb.send (encode + send)": per_call_us(lambda: ffb.send(COMMAND), calls),
    }
    results["_dropped"] = ffb.sender.dropped + ffb.sender.errors
    ffb.close()
    stop.set()
    return results


def drain(sock: socket.socket, stop: threading.Event) -> None:
    while not stop.is_set():
        try:
            sock.recv(64)
        except BlockingIOError:
            time.sleep(0.0005)


def server_trial(rate_hz: float | None, seconds: float) -> tuple[int, int, int]:
    """(sent, received, applied) with the real server in a child process; None = flood."""
    port = free_port(udp=True)
    server = start(
        ["ffb-server", "--backend", "log", "--port", str(port), "--watchdog-ms", "1000",
         "-o", "history=1"],
        name="ffb-server",
    )  # fmt: skip
    server.wait_for_line("ffb-server listening", READY_TIMEOUT_S)
    sent = blast(port, rate_hz, seconds)
    time.sleep(0.3)  # let the server drain what is queued before it stops
    stop_children([server])  # SIGINT: it prints its summary and exits
    server.finish_reading()
    summary = "\n".join(server.err.lines())
    match = re.search(r"(\d+) packets, (\d+) applied", summary)
    if not match:
        raise RuntimeError(f"no summary from ffb-server: {summary!r}")
    return sent, int(match[1]), int(match[2])


def blast(port: int, rate_hz: float | None, seconds: float) -> int:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.connect(("127.0.0.1", port))
    packet = ffb_packet.encode(COMMAND)
    sent, start = 0, time.perf_counter()
    end = start + seconds
    batch = 1 if rate_hz is None else max(1, int(rate_hz / 1000))  # pace in 1 ms slices
    while (now := time.perf_counter()) < end:
        if rate_hz is not None and sent >= (now - start) * rate_hz:
            time.sleep(0.0002)
            continue
        for _ in range(batch):
            sock.send(packet)
        sent += batch
    sock.close()
    return sent


def report(calls: int, seconds: float, rates: list[float]) -> str:
    costs = client_costs(calls)
    lines = [
        "Loopback UDP; client and server in separate processes.",
        "",
        f"Client side, {calls} calls each (target ≤ {CLIENT_TARGET_US:g} µs for encode + send):",
        "",
        "| step | µs per packet |",
        "|---|---|",
    ]
    lines += [f"| {k} | {v:.2f} |" for k, v in costs.items() if not k.startswith("_")]
    lines += [
        "",
        f"Server side, `carlaverse ffb-server --backend log`, {seconds:g} s per rate:",
        "",
        "| offered rate [packets/s] | sent | received | applied | loss |",
        "|---|---|---|---|---|",
    ]
    lossless = []
    for rate in [*rates, None]:
        sent, received, applied = server_trial(rate, seconds)
        label = "flood (as fast as one sender can)" if rate is None else f"{rate:,.0f}"
        loss = 1 - received / sent if sent else 0.0
        lines.append(f"| {label} | {sent:,} | {received:,} | {applied:,} | {loss:.2%} |")
        if rate is not None and received == applied == sent:
            lossless.append(rate)
    return "\n".join([*lines, "", reading(lossless)])


def reading(lossless_rates: list[float]) -> str:
    """What the server table says, from this run's figures."""
    text = (
        "Every received packet is decoded, range-checked and applied (log backend, so the cost "
        "is the server's own, not a device's); nothing is applied from a dropped packet. "
    )
    if not lossless_rates:
        return text + "No offered rate was received without loss in this run."
    best = max(lossless_rates)
    verdict = "enough" if best >= HAPTICS_RATE_HZ else "NOT enough"
    return text + (
        f"Highest offered rate received without loss: {best:,.0f} packets/s, {verdict} for the "
        f"haptics loop's {HAPTICS_RATE_HZ:,} packets/s. Beyond it the kernel drops the datagrams "
        "the server had no CPU time to read while the sender competed for the same cores."
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--calls", type=int, default=200_000, help="client calls per timing")
    parser.add_argument("--seconds", type=float, default=3.0, help="seconds per server rate")
    parser.add_argument(
        "--rates", default="1000,10000,50000,100000,200000", help="offered rates [packets/s]"
    )
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run = RunInfo.start()
    body = report(args.calls, args.seconds, [float(r) for r in args.rates.split(",")])
    print(body)
    if args.write:
        write_section("Hardware layer", body, command_line(argv), run)
    return 0


if __name__ == "__main__":
    sys.exit(main())
