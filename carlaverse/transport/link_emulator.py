"""A user-space WAN link emulator: a TCP relay with delay, jitter, loss, stalls and cuts.

A supported feature (issue 44.5): a study gives a participant's link a trial's delay, jitter
and loss through it (`carlaverse.study.links`), and the WAN tests and benchmarks emulate
site-to-site links with it (`carlaverse.testing.linkemu` re-exports it for them).

The kernel of the test machines lacks `netem`, so a site-to-site link is emulated by a relay
between one router and the next: the dialing router connects to the relay, which connects on
to the far router and forwards bytes both ways, each chunk held for the direction's delay.

TCP semantics shape the impairments, because a TCP byte stream cannot be reordered or lose
bytes without breaking the Zenoh framing inside it:
- jitter: each chunk's delivery time is `now + delay ± jitter`, clamped to be no earlier
  than the previous chunk's, as TCP delivers in order (a late chunk delays those behind it
  — head-of-line blocking, exactly what a real TCP link does);
- loss (`LinkProfile.loss`, per chunk ≈ per segment): TCP retransmits a lost segment after
  its retransmission timeout and delivers nothing behind it meanwhile, so a lost chunk is
  delivered one RTO late and holds everything after it. RTO = max(200 ms, SRTT + 4·RTTVAR)
  as Linux computes it (RFC 6298 with Linux's 200 ms TCP_RTO_MIN), SRTT = twice the one-way
  delay, RTTVAR ≈ the jitter. Fast retransmit (three duplicate ACKs) can recover sooner, but
  only when three more segments follow the lost one within an RTT; pose streams are thin
  (one small segment per 20 ms), and a loss near the end of a burst waits for the timer,
  so the timeout is the honest bound. `LinkModel(transport="datagram")` drops the chunk
  instead (UDP / QUIC datagrams: nothing waits, the sample is gone);
- a loss burst (`stall`) holds the direction until the burst ends, as TCP's retransmission
  would: nothing is lost, everything is late;
- a cut (`cut`) holds every direction and refuses new connections (accept, then close at
  once) until `restore`; a cut longer than the Zenoh lease makes the routers close the link
  and redial, which they can once it is restored. `reset` drops every open connection.

`LinkModel` is the pure delivery schedule (also what the in-process stream simulation of
`tools/bench/bench_wan.py` uses); the relay runs its own asyncio loop in a thread, after an
optional `thread_setup` (the WAN harness enters a network namespace there). Timing uses the
loop's monotonic clock with ~1 ms resolution (epoll's): delays are honoured to about ±1 ms
on an idle host. A user-space relay schedules from when *it* reads the bytes and writes when
*it* wakes, so on a loaded host both can be late by the host's scheduling latency (tens of
ms with more runnable threads than cores); `Direction.trace` keeps, per chunk, when it was
read, when it was due and when it was written, so the schedule the link applied and the
host's share of the lateness can be told apart.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import random
import threading
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

log = logging.getLogger(__name__)

CHUNK = 65536  # [bytes] read size
TRACE_CHUNKS = 4096  # chunks whose (read, due, written) times a direction keeps


Transport = Literal["tcp", "datagram"]
RTO_MIN_S = 0.2  # [s] Linux's TCP_RTO_MIN


@dataclass(frozen=True, slots=True)
class LinkProfile:
    """One direction of a link."""

    delay_s: float = 0.0  # [s] one-way delay
    jitter_s: float = 0.0  # [s] uniform ± around the delay
    loss: float = 0.0  # fraction of chunks (≈ segments, datagrams) lost

    def __post_init__(self) -> None:
        if self.delay_s < 0 or self.jitter_s < 0 or self.jitter_s > self.delay_s:
            raise ValueError(
                f"link profile delay {self.delay_s} s, jitter {self.jitter_s} s: both must be "
                ">= 0 and the jitter at most the delay (a chunk cannot arrive before it is sent)"
            )
        if not 0.0 <= self.loss < 1.0:
            raise ValueError(f"link profile loss {self.loss}: expected a fraction in [0, 1)")

    def rto_s(self) -> float:
        """TCP's retransmission timeout on this link (Linux: RFC 6298, 200 ms floor)."""
        return max(RTO_MIN_S, 2 * self.delay_s + 4 * self.jitter_s)


class LinkModel:
    """Delivery schedule of one direction: in order for TCP, independent for datagrams."""

    def __init__(self, profile: LinkProfile, rng: random.Random, transport: Transport = "tcp"):
        self.profile = profile
        self.rng = rng
        self.transport = transport
        self.last_due = 0.0
        self.lost = 0  # chunks retransmitted (tcp) or dropped (datagram)

    def schedule(self, now: float) -> float | None:
        """When a chunk sent at `now` is delivered; None if a datagram is lost."""
        p = self.profile
        due = now + p.delay_s + (self.rng.uniform(-p.jitter_s, p.jitter_s) if p.jitter_s else 0)
        if p.loss and self.rng.random() < p.loss:
            self.lost += 1
            if self.transport == "datagram":
                return None
            due += p.rto_s()  # retransmitted; every later chunk waits behind it
        if self.transport == "datagram":
            return due
        self.last_due = max(due, self.last_due)
        return self.last_due


class Direction(LinkModel):
    """One direction of the relay: its TCP schedule plus stalls and its trace."""

    def __init__(self, profile: LinkProfile, rng: random.Random) -> None:
        super().__init__(profile, rng, "tcp")
        self.blocked_until = 0.0  # [s] loop time; a loss burst holds deliveries until then
        # [s] loop time per chunk: read from the sender, due by the schedule, written on
        self.trace: deque[tuple[float, float, float]] = deque(maxlen=TRACE_CHUNKS)

    def schedule(self, now: float) -> float:
        due = super().schedule(now)
        assert due is not None  # a TCP schedule never drops
        return due


class LinkEmulator:
    """Relay `listen` -> `target` with `forward` (dialer to target) and `backward` profiles."""

    def __init__(
        self,
        listen: tuple[str, int],
        target: tuple[str, int],
        forward: LinkProfile = LinkProfile(),
        backward: LinkProfile | None = None,
        seed: int = 0,
        thread_setup: Callable[[], None] | None = None,
        name: str = "link",
    ) -> None:
        self.listen = listen
        self.target = target
        self.name = name
        self.thread_setup = thread_setup  # run in the relay's thread first (enter a netns)
        rng = random.Random(seed)
        self.forward = Direction(forward, random.Random(rng.random()))
        self.backward = Direction(backward or forward, random.Random(rng.random()))
        self.counts: Counter[str] = Counter()
        self.held = 0  # chunks waiting on a cut right now
        self.port = 0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._restored: asyncio.Event | None = None
        self._cut = False
        self._writers: set[asyncio.StreamWriter] = set()
        self._server: asyncio.AbstractServer | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=f"linkemu-{name}", daemon=True)

    # ------------------------------------------------------------ control (any thread)

    def start(self, timeout: float = 5.0) -> LinkEmulator:
        """Start relaying; returns once listening (raises what prevented it)."""
        self._thread.start()
        if not self._ready.wait(timeout):
            raise TimeoutError(f"link emulator {self.name} did not start in {timeout} s")
        if self._error is not None:
            raise RuntimeError(f"link emulator {self.name}: {self._error}") from self._error
        return self

    @property
    def address(self) -> tuple[str, int]:
        return self.listen[0], self.port

    def set_profile(self, forward: LinkProfile, backward: LinkProfile | None = None) -> None:
        def apply() -> None:
            self.forward.profile, self.backward.profile = forward, backward or forward

        self._call(apply)

    def cut(self) -> None:
        """Blackhole the link: hold every byte, refuse new connections."""
        self._call(self._set_cut, True)

    def restore(self) -> None:
        """End a cut: held bytes flow (late), new connections are accepted again."""
        self._call(self._set_cut, False)

    def stall(self, seconds: float, backward: bool = True, forward: bool = True) -> None:
        """A loss burst of `seconds`: the chosen directions deliver nothing until it ends."""

        def apply() -> None:
            assert self._loop is not None
            until = self._loop.time() + seconds
            for direction, on in ((self.forward, forward), (self.backward, backward)):
                if on:
                    direction.blocked_until = max(direction.blocked_until, until)

        self._call(apply)

    def reset(self) -> None:
        """Drop every open connection at once (a middlebox losing its state)."""

        def apply() -> None:
            for writer in list(self._writers):
                writer.transport.abort()
            self.counts["reset"] += 1

        self._call(apply)

    def close(self) -> None:
        loop = self._loop
        if loop is not None and loop.is_running():
            asyncio.run_coroutine_threadsafe(self._shutdown(), loop).result(timeout=5)
        self._thread.join(timeout=5)

    def _call(self, fn: object, *args: object) -> None:
        loop = self._loop
        if loop is None:
            raise RuntimeError(f"link emulator {self.name} is not running")

        async def invoke() -> None:
            fn(*args)  # type: ignore[operator]

        asyncio.run_coroutine_threadsafe(invoke(), loop).result(timeout=5)

    def _set_cut(self, cut: bool) -> None:
        assert self._restored is not None
        self._cut = cut
        self.counts["cut" if cut else "restore"] += 1
        if cut:
            self._restored.clear()
        else:
            self._restored.set()

    # ------------------------------------------------------------ relay (loop thread)

    def _run(self) -> None:
        try:
            if self.thread_setup is not None:
                self.thread_setup()
            self._loop = asyncio.new_event_loop()
            self._loop.run_until_complete(self._serve())
        except BaseException as exc:  # reported to start(); the thread ends here
            self._error = exc
            self._ready.set()
        finally:
            if self._loop is not None:
                self._finish_tasks(self._loop)
                self._loop.close()

    @staticmethod
    def _finish_tasks(loop: asyncio.AbstractEventLoop) -> None:
        """Let cancelled connection tasks unwind before the loop closes."""
        pending = asyncio.all_tasks(loop)
        for task in pending:
            task.cancel()
        if pending:
            loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))

    async def _serve(self) -> None:
        self._restored = asyncio.Event()
        self._restored.set()
        self._server = await asyncio.start_server(self._accept, *self.listen)
        self.port = self._server.sockets[0].getsockname()[1]
        self._ready.set()
        with contextlib.suppress(asyncio.CancelledError):
            await self._server.serve_forever()

    async def _shutdown(self) -> None:
        if self._server is not None:
            self._server.close()
        for writer in list(self._writers):
            writer.transport.abort()
        for task in asyncio.all_tasks():
            if task is not asyncio.current_task():
                task.cancel()

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if self._cut:
            self.counts["refused"] += 1
            writer.transport.abort()
            return
        try:
            up_reader, up_writer = await asyncio.open_connection(*self.target)
        except OSError as exc:
            self.counts["target_unreachable"] += 1
            log.debug("%s: cannot reach %s: %s", self.name, self.target, exc)
            writer.transport.abort()
            return
        self.counts["accepted"] += 1
        self._writers.update((writer, up_writer))
        try:
            await asyncio.gather(
                self._pump(reader, up_writer, self.forward),
                self._pump(up_reader, writer, self.backward),
            )
        except asyncio.CancelledError:
            # `close` with connections open: this task is asyncio's connection callback,
            # whose cancellation asyncio (3.11) reports as an error with a traceback; the
            # relay ends here on purpose, so the connection's end is quiet.
            return
        finally:
            self._writers.difference_update((writer, up_writer))

    async def _pump(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, direction: Direction
    ) -> None:
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[tuple[float, float, bytes]] = asyncio.Queue()
        sender = asyncio.create_task(self._deliver(queue, writer, direction))
        try:
            while data := await reader.read(CHUNK):
                read_t = loop.time()
                queue.put_nowait((read_t, direction.schedule(read_t), data))
        except OSError:
            self.counts["read_error"] += 1
        end_t = loop.time()
        queue.put_nowait((end_t, direction.schedule(end_t), b""))  # end of stream, in order
        await sender

    async def _deliver(
        self, queue: asyncio.Queue[tuple[float, float, bytes]], writer: asyncio.StreamWriter,
        direction: Direction,
    ) -> None:  # fmt: skip
        loop = asyncio.get_running_loop()
        try:
            while True:
                read_t, due, data = await queue.get()
                await self._hold(loop, due, direction)
                if not data:
                    break
                writer.write(data)
                direction.trace.append((read_t, due, loop.time()))
                await writer.drain()
        except OSError:
            self.counts["write_error"] += 1
        finally:
            writer.close()

    async def _hold(self, loop: asyncio.AbstractEventLoop, due: float, d: Direction) -> None:
        assert self._restored is not None
        while True:
            if self._cut:
                self.held += 1
                await self._restored.wait()
                self.held -= 1
                continue
            wait = max(due, d.blocked_until) - loop.time()
            if wait <= 0:
                return
            await asyncio.sleep(wait)
