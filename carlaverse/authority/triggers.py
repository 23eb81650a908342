"""Scenario triggers at run time: measure, decide, act, and say so on `world/events`.

Runs on the tick's thread after the engine stepped, so what it measures is where everyone
is this tick (egos dead-reckoned to the tick time, NPCs as the engine left them). Every
firing is one `TriggerFired` event with the measurements that made it fire; a message
action is a `Notice` event for the participants' HMIs. A timed arrival (`arrive:`) steers its
NPC every tick until its front passes the point: the constant acceleration that covers the
remaining distance in the time left, limited to what a car can do, recomputed from where
both road users are now, so a cyclist who slows down or speeds up meets the car at the same
TTC all the same.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from carlaverse.analysis.footprints import time_to_contact
from carlaverse.authority.actors import EgoColumns, EgoNow
from carlaverse.authority.domain import Outbox
from carlaverse.authority.weather import WeatherPublisher
from carlaverse.expr import ExpressionError, compile_condition
from carlaverse.geometry import inside_polygon
from carlaverse.messages import Notice, TriggerFired
from carlaverse.traffic import trigger_spec as ts
from carlaverse.traffic.engine import NpcFrame, TrafficEngine
from carlaverse.traffic.scenario import ScriptedVehicle

log = logging.getLogger(__name__)
MIN_CLOSING_MPS = 0.1  # [m/s] slower than this towards a point is not approaching it


@dataclass(frozen=True, slots=True)
class Body:
    """One road user this tick: centre, heading, velocity, footprint."""

    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    length: float
    width: float

    @property
    def front(self) -> tuple[float, float]:
        half = self.length / 2
        return self.x + half * math.cos(self.yaw), self.y + half * math.sin(self.yaw)

    @property
    def speed(self) -> float:
        return math.hypot(self.vx, self.vy)


class World:
    """Who is where this tick, looked up by id (egos and NPCs alike)."""

    def __init__(self, egos: Sequence[EgoNow], frame: NpcFrame) -> None:
        self._egos = egos
        self._frame = frame
        # Built on the first look-up: a scenario without triggers pays nothing per ego.
        self._ego_index: dict[str, int] | None = None
        self._npc_index: dict[str, int] | None = None

    def body(self, actor: str) -> Body | None:
        if self._ego_index is None:
            self._ego_index = {e: i for i, e in enumerate(EgoColumns.of(self._egos).ids)}
        k = self._ego_index.get(actor)
        if k is not None:
            ego = self._egos[k]
            return Body(ego.x, ego.y, ego.yaw, ego.vx, ego.vy, ego.length, ego.width)
        if self._npc_index is None:
            self._npc_index = {npc: i for i, npc in enumerate(self._frame.ids)}
        i = self._npc_index.get(actor)
        if i is None:
            return None
        r = self._frame.rows[i]
        return Body(*(float(r[f]) for f in ("x", "y", "yaw", "vx", "vy", "length", "width")))


def eta(body: Body, point: tuple[float, float]) -> float:
    """[s] until the front reaches `point` at the current velocity (inf if not closing)."""
    fx, fy = body.front
    dx, dy = point[0] - fx, point[1] - fy
    distance = math.hypot(dx, dy)
    if distance < 1e-3:
        return 0.0
    closing = (body.vx * dx + body.vy * dy) / distance
    return distance / closing if closing > MIN_CLOSING_MPS else math.inf


class Trigger:
    """One trigger's measurements, condition and state."""

    def __init__(self, spec: ts.TriggerSpec, all_ids: list[str]) -> None:
        self.spec = spec
        names = {"t", *spec.measure, *(f"fired_{i}" for i in all_ids)}
        self.condition = compile_condition(spec.when, names)
        self.fired = 0
        self.failed = 0  # ticks its condition could not be computed
        self.held_before = False
        self._last: dict[str, tuple[float, float]] = {}  # crossed: the centre last tick
        self._crossed: set[str] = set()

    def measure(self, world: World) -> dict[str, float]:
        return {name: self._measure(name, m, world) for name, m in self.spec.measure.items()}

    def _measure(self, name: str, m: ts.Measure, world: World) -> float:
        body = world.body(m.actor)
        if body is None:
            return math.nan
        if isinstance(m, ts.Eta):
            return eta(body, m.point)
        if isinstance(m, ts.Speed):
            return body.speed
        if isinstance(m, ts.Distance):
            other = m.point or _centre(world.body(m.other or ""))
            return math.hypot(other[0] - body.x, other[1] - body.y)
        if isinstance(m, ts.Ttc):
            return _ttc(body, world.body(m.other))
        if isinstance(m, ts.Inside):
            return float(inside_polygon(m.polygon, body.x, body.y))
        return self._crossed_line(name, m, body)

    def _crossed_line(self, name: str, m: ts.Crossed, body: Body) -> float:
        last, now = self._last.get(name), (body.x, body.y)
        self._last[name] = now
        if last is not None and _segments_cross(last, now, *m.line):
            self._crossed.add(name)
        return float(name in self._crossed)


class TriggerRunner:
    """Every trigger of a scenario, evaluated once per tick."""

    def __init__(
        self,
        specs: list[ts.TriggerSpec],
        engine: TrafficEngine,
        weather: WeatherPublisher,
    ) -> None:
        ids = [s.id for s in specs]
        self._triggers = [Trigger(s, ids) for s in specs]
        self._engine = engine
        self._weather = weather
        self._arrivals: dict[str, ts.Arrival] = {}  # NPC id -> its timed arrival
        self.fired = 0
        self.failed = 0  # condition evaluations that failed, all triggers together

    def tick(
        self, t: float, scenario_s: float, egos: Sequence[EgoNow], frame: NpcFrame, out: Outbox
    ) -> None:
        world = World(egos, frame)
        counts = {f"fired_{tr.spec.id}": float(tr.fired) for tr in self._triggers}
        for trigger in self._triggers:
            values = trigger.measure(world)
            holds = self._holds(trigger, {**values, **counts, "t": scenario_s})
            fresh = holds and not trigger.held_before
            trigger.held_before = holds
            if fresh and (trigger.fired == 0 or trigger.spec.repeat):
                self._fire(trigger, values, t, out)
        # A commanded speed holds from the engine's next step on, for one step: the step, not
        # the tick, is the interval to plan over (the engine may step less often than we tick).
        self._steer(world, self._engine.step_length_s)

    def _holds(self, trigger: Trigger, values: dict[str, float]) -> bool:
        """The condition, or False where it cannot be computed this tick (a division by a
        measurement that is zero now, say): counted and said once per trigger, never raised
        into the authority's tick, which would end the session for every participant."""
        try:
            return trigger.condition(values)
        except ExpressionError as exc:
            trigger.failed += 1
            self.failed += 1
            if trigger.failed == 1:
                log.warning("trigger %s: %s; counted as not holding while it fails",
                            trigger.spec.id, exc)  # fmt: skip
            return False

    def _fire(self, trigger: Trigger, values: dict[str, float], t: float, out: Outbox) -> None:
        trigger.fired += 1
        self.fired += 1
        done = [self._act(action, t, out) for action in trigger.spec.actions]
        finite = {k: (v if math.isfinite(v) else None) for k, v in values.items()}
        out.event(TriggerFired(out.next_seq(), t, trigger.spec.id, done, finite))
        log.info("trigger %s fired: %s", trigger.spec.id, "; ".join(done))

    def _act(self, action: ts.Action, t: float, out: Outbox) -> str:
        """Do one action; what was done (or why it failed) in a few words."""
        try:
            return _ACTIONS[type(action)](self, action, t, out)
        except ValueError as exc:  # the engine refused: say so, keep the session running
            log.warning("trigger action failed: %s", exc)
            return f"failed: {exc}"

    def _spawn(self, a: ts.Spawn, t: float, out: Outbox) -> str:
        self._engine.spawn_npc(
            ScriptedVehicle(id=a.id, edges=a.edges, kind=a.kind, depart_pos_m=a.depart_pos_m,
                            depart_speed_mps=a.speed_mps)
        )  # fmt: skip
        if a.arrive is not None:
            self._arrivals[a.id] = a.arrive
        return f"spawn {a.id}"

    def _release(self, a: ts.Release, t: float, out: Outbox) -> str:
        self._engine.release_npc(a.npc)
        if a.arrive is not None:
            self._arrivals[a.npc] = a.arrive
        return f"release {a.npc}"

    def _light(self, a: ts.Light, t: float, out: Outbox) -> str:
        self._engine.set_light_state(a.id, a.state)
        return f"light {a.id} {a.state}"

    def _set_weather(self, a: ts.SetWeather, t: float, out: Outbox) -> str:
        values = a.values()
        self._weather.override(values)
        return "weather " + " ".join(f"{k}={v:g}" for k, v in values.items())

    def _message(self, a: ts.Message, t: float, out: Outbox) -> str:
        out.event(Notice(out.next_seq(), t, a.text, a.to, a.duration_s))
        return f"message to {a.to or 'everyone'}"

    # ------------------------------------------------------------------ timed arrivals

    def _steer(self, world: World, dt: float) -> None:
        for npc_id, arrival in list(self._arrivals.items()):
            body = world.body(npc_id)
            if body is None:
                continue  # spawned this tick, not on the road yet
            speed = arrival_speed(body, world.body(arrival.of), arrival, dt)
            try:
                self._engine.command_speed(npc_id, speed)
            except ValueError as exc:
                log.warning("timed arrival of %s ended: %s", npc_id, exc)
                speed = None
            if speed is None:
                del self._arrivals[npc_id]


def arrival_speed(npc: Body, other: Body | None, arrival: ts.Arrival, dt: float) -> float | None:
    """The NPC's speed for the next step, or None once its front passed the point."""
    fx, fy = npc.front
    dx, dy = arrival.point[0] - fx, arrival.point[1] - fy
    if dx * math.cos(npc.yaw) + dy * math.sin(npc.yaw) <= 0:
        return None  # passed: back to normal driving
    remaining = math.hypot(dx, dy)
    time_left = (eta(other, arrival.point) if other else math.inf) - arrival.ttc_s
    v0 = npc.speed
    if not math.isfinite(time_left):
        accel = -arrival.max_decel_mps2  # the other is not coming: wait where it is
    elif time_left <= dt:
        accel = arrival.max_accel_mps2  # late: as fast as it can
    else:  # constant acceleration covering `remaining` in `time_left`
        accel = 2 * (remaining - v0 * time_left) / time_left**2
    accel = min(max(accel, -arrival.max_decel_mps2), arrival.max_accel_mps2)
    return min(max(v0 + accel * max(dt, 0.0), 0.0), arrival.max_speed_mps)


_ACTIONS: Mapping[type, Callable[..., str]] = {
    ts.Spawn: TriggerRunner._spawn,
    ts.Release: TriggerRunner._release,
    ts.Light: TriggerRunner._light,
    ts.SetWeather: TriggerRunner._set_weather,
    ts.Message: TriggerRunner._message,
}


def _centre(body: Body | None) -> tuple[float, float]:
    return (math.nan, math.nan) if body is None else (body.x, body.y)


def _ttc(a: Body, b: Body | None) -> float:
    if b is None:
        return math.nan
    ttc = time_to_contact(
        np.array([b.x - a.x, b.y - a.y]), np.array([b.vx - a.vx, b.vy - a.vy]),
        np.array(a.yaw), np.array(b.yaw), (a.length, a.width), (b.length, b.width),
    )  # fmt: skip
    return float(ttc)


def _segments_cross(p: tuple, q: tuple, a: tuple, b: tuple) -> bool:
    def side(o: tuple, u: tuple, v: tuple) -> float:
        return (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])

    return side(p, q, a) * side(p, q, b) < 0 and side(a, b, p) * side(a, b, q) <= 0
