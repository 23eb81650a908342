"""SUMO in a process of its own, stepping on the other core while the authority ticks.

libsumo never releases the GIL, and SUMO's step with the NPC read-back is the largest single
cost of a big session: 10–20 ms at 500 NPCs and a few hundred carried egos, all of it on the
ticks that step. `SumoProcess` runs the same `SumoEngine` in a child process instead. A tick
that steps hands the egos over and returns at once; the child steps, reads the NPCs back and
sends the frame, which a later tick picks up. A frame carries its own engine time, and the
domain dead-reckons every frame to its tick (`NpcFrame.at`), as it does between steps anyway.

At most one step is in flight: stepping again first waits for the step before, so the NPCs
the authority sees are never more than one step old, and a stalled child stalls the tick
rather than piling up work. Everything else the domain asks (scenario triggers, light
overrides) is a call answered in order after any step in flight; stopping and removing a hit
NPC need no answer.

The pipe joins two processes of this program: its messages are pickled Python objects, and
nothing from the network crosses it. The child ends when the pipe does, so SUMO never
outlives the authority that started it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import pickle
import signal
import socket
import subprocess
import sys
import time
import traceback
from collections.abc import Sequence
from multiprocessing.connection import Connection
from typing import Any

from carlaverse.traffic.engine import (
    EgoPlacement,
    EgoPlacements,
    EngineFailed,
    LightPhase,
    LightReading,
    NpcFrame,
)
from carlaverse.traffic.scenario import ScriptedVehicle
from carlaverse.traffic.sumo_engine import SumoEngine, SumoSettings

log = logging.getLogger(__name__)

START_TIMEOUT_S = 120.0  # [s] SUMO loading a city's network and inserting its first NPCs
REPLY_TIMEOUT_S = 30.0  # [s] one step or call; far above any step SUMO takes
CLOSE_TIMEOUT_S = 5.0  # [s] for SUMO to close before the child is killed

# What the child answers. A step: ("stepped", time_s, frame, lights or None if unchanged,
# counters). A call: ("value", value, lights) or ("error", message, lights). Starting:
# ("ready", time_s, frame, lights, counters) or ("raise", exception). Failing: ("fatal", text).


class SumoProcessError(EngineFailed):
    """The SUMO process died, failed or stopped answering."""


class SumoProcess:
    """A `TrafficEngine`: a `SumoEngine` in a child process, stepped one step ahead.

    Not thread-safe: one thread at a time (the authority's tick) talks on its pipe. Two would
    take each other's replies; one's check for a step come back would then find none, and
    end the process as unanswering."""

    def __init__(self, settings: SumoSettings) -> None:
        # A fresh interpreter, not a fork: the authority may already run Zenoh's threads, and
        # a fork of a threaded process can inherit a lock some other thread held.
        ours, theirs = socket.socketpair()
        self._process = subprocess.Popen(
            [sys.executable, "-m", __name__, str(theirs.fileno())],
            pass_fds=(theirs.fileno(),),
            stdin=subprocess.DEVNULL,
        )
        theirs.close()
        self._conn = Connection(ours.detach())
        self._conn.send(settings)
        self._step_s = settings.step_length_s
        self._closed = False
        self._in_flight = False  # a step sent whose frame has not come back
        # Steps that had to wait for the one before (SUMO slower than the session, or starved
        # of CPU): the tick paid for them.
        self.late_steps = 0
        self._steps = 0
        self._placements = EgoPlacements.of([])
        reply = self._receive(START_TIMEOUT_S, "starting")
        if reply[0] == "raise":
            self.close()
            raise reply[1]
        _, self._t0, self._frame, self._lights, self._counters = reply

    # ------------------------------------------------------------------ stepping

    @property
    def time_s(self) -> float:
        # The time the last step sent reaches: the domain decides when to step by it.
        return self._t0 + self._steps * self._step_s

    @property
    def step_length_s(self) -> float:
        return self._step_s

    @property
    def stepping(self) -> bool:
        self._collect()
        return self._in_flight

    def place_egos(self, egos: Sequence[EgoPlacement]) -> None:
        self._placements = EgoPlacements.of(egos)  # columns: cheap to pickle

    def step(self) -> None:
        if self._closed:
            raise SumoProcessError("the SUMO process is closed")
        if self._in_flight:
            self._await_step()
            self.late_steps += 1
        self._send(("step", self._placements))
        self._in_flight = True
        self._steps += 1

    def npcs(self) -> NpcFrame:
        self._collect()
        return self._frame

    def last_read(self) -> NpcFrame:
        self._collect()
        return self._frame

    def light_readings(self) -> list[LightReading]:
        self._collect()
        return self._lights

    def counters(self) -> dict[str, int]:
        # The child's as of the last step back (no call, no wait), and the steps that waited.
        return {**self._counters, "sumo_late_steps": self.late_steps}

    # ------------------------------------------------------------------ NPC reactions, triggers

    def stop_npc(self, npc_id: str) -> None:
        self._send(("fire", "stop_npc", (npc_id,)))

    def remove_npc(self, npc_id: str) -> None:
        self._send(("fire", "remove_npc", (npc_id,)))

    def spawn_npc(self, vehicle: ScriptedVehicle) -> None:
        self._call("spawn_npc", vehicle)

    def release_npc(self, npc_id: str) -> None:
        self._call("release_npc", npc_id)

    def command_speed(self, npc_id: str, speed_mps: float | None) -> None:
        self._call("command_speed", npc_id, speed_mps)

    def set_light_state(self, light_id: str, state: str) -> None:
        self._call("set_light_state", light_id, state)

    def light_programs(self) -> dict[str, list[LightPhase]]:
        programs: dict[str, list[LightPhase]] = self._call("light_programs")
        return programs

    def set_light_program(
        self, light_id: str, phases: Sequence[LightPhase], offset_s: float
    ) -> None:
        self._call("set_light_program", light_id, list(phases), offset_s)

    # ------------------------------------------------------------------ lifetime

    @property
    def pid(self) -> int:
        return self._process.pid

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self._conn.send(("close",))
        except (OSError, ValueError):
            pass  # the child is gone already
        try:
            self._process.wait(CLOSE_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait(CLOSE_TIMEOUT_S)
        self._conn.close()

    # ------------------------------------------------------------------ the pipe

    def _send(self, message: tuple[Any, ...]) -> None:
        if self._closed:
            raise SumoProcessError("the SUMO process is closed")
        try:
            self._conn.send(message)
        except (OSError, ValueError) as exc:
            raise self._dead(f"taking {message[0]!r}") from exc

    def _call(self, name: str, *args: Any) -> Any:
        self._send(("call", name, args))
        while True:
            reply = self._receive(REPLY_TIMEOUT_S, f"answering {name}")
            if reply[0] == "stepped":
                self._take_step(reply)
                continue
            kind, value, self._lights = reply
            if kind == "error":
                raise ValueError(value)
            return value

    def _collect(self) -> None:
        """Take a step's frame if it has come back; never waits."""
        while self._in_flight and not self._closed and self._conn.poll(0):
            self._take_step(self._receive(0.0, "stepping"))

    def _await_step(self) -> None:
        while self._in_flight:
            self._take_step(self._receive(REPLY_TIMEOUT_S, "stepping"))

    def _take_step(self, reply: tuple[Any, ...]) -> None:
        if reply[0] != "stepped":
            raise SumoProcessError(f"the SUMO process answered {reply[0]!r} to a step")
        _, _t, self._frame, lights, self._counters = reply
        if lights is not None:
            self._lights = lights
        self._in_flight = False

    def _receive(self, timeout_s: float, doing: str) -> tuple[Any, ...]:
        deadline = time.monotonic() + timeout_s
        while True:
            # Wake now and then to notice a child that died without closing the pipe.
            if self._conn.poll(min(0.5, max(0.0, deadline - time.monotonic()))):
                try:
                    reply: tuple[Any, ...] = self._conn.recv()
                except (EOFError, OSError) as exc:
                    raise self._dead(doing) from exc
                if reply[0] == "fatal":
                    self.close()
                    log.error("SUMO's process failed while %s:\n%s", doing, reply[1])
                    cause = reply[1].strip().splitlines()[-1]
                    raise SumoProcessError(f"SUMO failed while {doing}: {cause}")
                return reply
            if self._process.poll() is not None:
                raise self._dead(doing)
            if time.monotonic() >= deadline:
                self.close()
                raise SumoProcessError(
                    f"the SUMO process did not answer within {timeout_s:g} s while {doing}"
                )

    def _dead(self, doing: str) -> SumoProcessError:
        try:
            code: int | None = self._process.wait(CLOSE_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            code = None
        self.close()
        return SumoProcessError(f"the SUMO process exited (code {code}) while {doing}")


def _serve(conn: Connection, settings: SumoSettings) -> None:
    """The child: one `SumoEngine`, driven by the requests on the pipe until it closes."""
    try:
        engine = SumoEngine(settings)
    except Exception as exc:  # sent back whole: the parent raises what SumoEngine raised
        conn.send(("raise", _portable(exc)))
        return
    try:
        lights = engine.light_readings()
        conn.send(("ready", engine.time_s, engine.npcs(), lights, engine.counters()))
        while True:
            try:
                request = conn.recv()
            except EOFError:
                return  # the authority is gone: so is SUMO
            kind = request[0]
            if kind == "step":
                engine.place_egos(request[1])
                engine.step()
                now = engine.light_readings()
                changed = now if now != lights else None
                lights = now
                conn.send(("stepped", engine.time_s, engine.npcs(), changed, engine.counters()))
            elif kind == "fire":
                getattr(engine, request[1])(*request[2])
            elif kind == "call":
                try:
                    value = getattr(engine, request[1])(*request[2])
                except ValueError as exc:
                    lights = engine.light_readings()
                    conn.send(("error", str(exc), lights))
                else:
                    lights = engine.light_readings()
                    conn.send(("value", value, lights))
            else:  # "close"
                return
    except Exception:
        with contextlib.suppress(OSError, ValueError):  # unless the parent is gone too
            conn.send(("fatal", traceback.format_exc()))
    finally:
        engine.close()


def _portable(exc: Exception) -> Exception:
    """The exception itself if it survives the pipe, else a SumoProcessError with its text."""
    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:
        return SumoProcessError(f"{type(exc).__name__}: {exc}")
    return exc


def main(argv: Sequence[str]) -> int:
    """`python -m carlaverse.traffic.sumo_process FD`: serve the socket inherited as FD."""
    # Ctrl-C reaches the whole process group: the authority closes SUMO, in order.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # A batch process never preempts the process that woke it: a step request would
    # otherwise put SUMO on the tick's core for the whole step (the tick waited up to 5 ms
    # for a core in its send). SUMO has a step's time of slack; the tick has none.
    with contextlib.suppress(AttributeError, OSError):
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
    conn = Connection(int(argv[0]))
    try:
        settings = conn.recv()
    except EOFError:
        return 0
    _serve(conn, settings)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
