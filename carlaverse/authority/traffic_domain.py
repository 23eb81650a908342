"""The authority's global domain on a traffic engine: traffic, lights, weather, collisions.

`TrafficDomain` is the `GlobalDomain` the membership core ticks. One tick, at session time t:

1. dead-reckon every embodied ego to t and carry it in the engine (so NPCs react to it);
2. step the engine up to t (one step normally; a few after a stall, then the lag is dropped),
   then run the scenario's triggers on where everyone is now;
3. run the collision matrix over egos and NPCs: contact events, impulses, hit NPCs stop;
4. publish the NPC batch (at `npc_rate_hz`), lights and weather (on change and at 1 Hz);
5. send each ego what it can hear on `audio/<id>` (at the scenario's `audio.rate_hz`).

Everything that talks to the engine runs on the tick's thread. The snapshot, map and scenario
getters may be called from query threads: they only read immutable messages, swapped in
whole by the tick.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from carlaverse.authority.actors import EgoColumns, build_actors, egos_at
from carlaverse.authority.collisions import CollisionMatrix, TickContacts
from carlaverse.authority.domain import EgoTrack, Outbox
from carlaverse.authority.lights import LightPublisher, apply_overrides
from carlaverse.authority.sound_publisher import SoundPublisher
from carlaverse.authority.triggers import TriggerRunner
from carlaverse.authority.weather import WeatherPublisher
from carlaverse.config import ConfigError
from carlaverse.messages import (
    SCHEMA_VERSION,
    ContactStarted,
    LightsState,
    MapReply,
    NpcBatch,
    ScenarioReply,
    SpawnPoint,
    Weather,
)
from carlaverse.traffic.engine import NpcFrame, TrafficEngine
from carlaverse.traffic.scenario import Scenario, Session, load_scenario
from carlaverse.traffic.spawns import SpawnAllocator

log = logging.getLogger(__name__)


@dataclass(slots=True)
class DomainStats:
    ticks: int = 0
    steps: int = 0
    dropped_s: float = 0.0  # [s] engine time skipped after stalls
    deferred_steps: int = 0  # ticks that left a step to a later one: SUMO was still stepping
    contacts: int = 0
    impulses: int = 0
    npcs_removed: int = 0
    trigger_failures: int = 0  # trigger conditions that could not be computed, counted not raised


class TrafficDomain:
    """Traffic, lights, weather and the collision matrix of one running scenario."""

    def __init__(
        self,
        scenario: Scenario,
        engine: TrafficEngine,
        map_reply: MapReply | None,
        spawns: SpawnAllocator,
        seed: int,
    ) -> None:
        spec = scenario.spec
        self._spec = spec
        self._source = scenario
        self._engine = engine
        self._map = map_reply
        self._spawns = spawns
        self._scenario = ScenarioReply(SCHEMA_VERSION, spec.name, scenario.text, seed)
        apply_overrides(engine, spec.lights)
        self._lights = LightPublisher(engine, spec.session.status_rate_hz)
        self._weather = WeatherPublisher(spec.weather, spec.session.status_rate_hz)
        self._collisions = CollisionMatrix(spec.collisions.npc_npc)
        self._triggers = TriggerRunner(spec.triggers, engine, self._weather)
        self._sound = SoundPublisher(spec.audio, map_reply.areas if map_reply else [])
        self._offset_s: float | None = None  # session time minus engine time
        self._next_npc_t = -math.inf
        self._removals: dict[str, float] = {}  # hit NPC id -> session time it leaves
        self._npc_batch: NpcBatch | None = None
        self.stats = DomainStats()

    @property
    def scenario(self) -> Scenario:
        return self._source

    @property
    def engine(self) -> TrafficEngine:
        return self._engine

    @property
    def session_params(self) -> Session:
        """The scenario's session parameters: tick rate, despawn timeout, publish rates."""
        return self._spec.session

    # ------------------------------------------------------------------ GlobalDomain

    def ego_joined(self, track: EgoTrack) -> None:
        log.info("ego %s (%s) joined the traffic", track.node_id, track.info.actor_kind)

    def ego_left(self, node_id: str) -> None:
        # The next tick no longer finds it among the egos: the engine drops it, contacts end.
        log.info("ego %s left the traffic", node_id)

    def tick(self, t: float, egos: Mapping[str, EgoTrack], out: Outbox) -> None:
        self.stats.ticks += 1
        now = egos_at(t, egos, self._spec.collisions.max_extrapolation_s)
        stepped = self._advance(t, now)
        scenario_s = t - (self._offset_s or 0.0)
        # The engine steps less often than we tick, so the frame is dead-reckoned to now. A
        # tick that stepped it keeps the frame it had and leaves reading the step back to the
        # next tick: SUMO's step and the read-back, its two big costs, fall on different ticks.
        frame = self._engine.last_read() if stepped else self._engine.npcs()
        npcs = frame.at(scenario_s)
        self._triggers.tick(t, scenario_s, now, npcs, out)
        self.stats.trigger_failures = self._triggers.failed
        actors = build_actors(now, npcs, self._spec.collisions)
        self._publish_contacts(t, self._collisions.step(t, actors, out.next_seq), out)
        self._remove_hit_npcs(t)
        self._publish_world(t, npcs, out)
        self._sound.tick(t, now, npcs, self._weather.latest, out)

    def snapshot_parts(self) -> tuple[NpcBatch | None, LightsState | None, Weather | None]:
        return self._npc_batch, self._lights.current, self._weather.latest

    def map_reply(self) -> MapReply | None:
        return self._map

    def scenario_reply(self) -> ScenarioReply | None:
        return self._scenario

    def spawn_point(self, node_kind: str, node_id: str) -> SpawnPoint | None:
        return self._spawns.pick(node_kind, node_id)

    def close(self) -> None:
        self._engine.close()

    def report(self) -> dict[str, Any]:
        """The domain's counters and its engine's, for the authority's `--json` summary."""
        return {**dataclasses.asdict(self.stats), **self._engine.counters()}

    # ------------------------------------------------------------------ one tick

    def _advance(self, t: float, now: EgoColumns) -> bool:
        """Step the engine to the step nearest session time t (the frame is dead-reckoned the
        rest of the way); after a stall, catch up a little, drop the rest. Whether it stepped."""
        engine, step = self._engine, self._engine.step_length_s
        if self._offset_s is None:  # scenario time starts at 0 with the first tick
            self._offset_s = t - engine.time_s
        target = t - self._offset_s
        stepped, placements = False, None
        catch_up = self._spec.session.max_catch_up_steps
        for _ in range(catch_up):
            if engine.time_s + step / 2 > target:
                return stepped
            if engine.stepping:
                # The step before still runs in SUMO's process: a later tick steps instead of
                # this one waiting (catching up one step a tick). A lag longer than a
                # catch-up is dropped below, as after a stall.
                self.stats.deferred_steps += 1
                if target - engine.time_s <= catch_up * step:
                    return stepped
                break
            if placements is None:  # only on ticks that step: one in five by default
                placements = now.placements()
            engine.place_egos(placements)
            engine.step()
            self.stats.steps += 1
            stepped = True
        lag = target - engine.time_s
        if lag > step / 2:
            self._offset_s += lag
            self.stats.dropped_s += lag
            log.warning("traffic fell %.3f s behind the session clock; skipped ahead", lag)
        return stepped

    def _publish_contacts(self, t: float, contacts: TickContacts, out: Outbox) -> None:
        for event in contacts.events:
            out.event(event)
        for node_id, impulse in contacts.impulses:
            out.impulse(node_id, impulse)
            self.stats.impulses += 1
        self.stats.contacts += sum(isinstance(e, ContactStarted) for e in contacts.events)
        for npc_id in contacts.hit_npcs:
            if npc_id not in self._removals:
                self._engine.stop_npc(npc_id)
                self._removals[npc_id] = t + self._spec.collisions.npc_hit_remove_after_s

    def _remove_hit_npcs(self, t: float) -> None:
        for npc_id in [n for n, due in self._removals.items() if due <= t]:
            self._engine.remove_npc(npc_id)
            del self._removals[npc_id]
            self.stats.npcs_removed += 1

    def _publish_world(self, t: float, frame: NpcFrame, out: Outbox) -> None:
        if t >= self._next_npc_t:
            period = 1.0 / self._spec.session.npc_rate_hz
            self._next_npc_t = max(self._next_npc_t + period, t + period / 2)
            self._npc_batch = NpcBatch.pack(out.next_seq(), t, frame.ids, frame.rows)
            out.npc(self._npc_batch)
        lights = self._lights.tick(t, out.next_seq)
        if lights is not None:
            out.lights(lights)
        scenario_s = t - (self._offset_s or 0.0)
        weather = self._weather.tick(t, scenario_s, out.next_seq)
        if weather is not None:
            out.weather(weather)


def load_domain(
    scenario_name_or_path: str | Path,
    seed_override: int | None = None,
    *,
    cache_dir: Path | None = None,
    sumo_process: bool | None = None,
) -> TrafficDomain:
    """Build a scenario's network, start SUMO on it and return the domain that ticks it.

    SUMO runs in a process of its own unless `sumo_process` (default: the scenario's
    `traffic.sumo_process`) says otherwise; tests that look into libsumo keep it in theirs.

    Raises ConfigError (naming the scenario file) for a scenario that does not fit its map,
    SumoMissingError when SUMO is not installed, SumoToolError when a map fails to convert.
    """
    from carlaverse.traffic.mapdata import build_map_reply, read_net
    from carlaverse.traffic.netbuild import build_map
    from carlaverse.traffic.spawns import resolve_spawns
    from carlaverse.traffic.sumo_engine import SumoEngine, SumoSettings
    from carlaverse.traffic.sumo_process import SumoProcess

    scenario = load_scenario(scenario_name_or_path)
    spec = scenario.spec
    built = build_map(scenario, cache_dir)
    net = read_net(built.net)
    try:
        spawns = SpawnAllocator(resolve_spawns(net, spec.egos))
        map_reply = build_map_reply(net, spec.name, built.polygons)
    except ValueError as exc:
        raise ConfigError(str(scenario.path), str(exc)) from exc
    seed = spec.seed if seed_override is None else seed_override
    separate = spec.traffic.sumo_process if sumo_process is None else sumo_process
    settings = SumoSettings(built.net, seed, spec.step_length_s, spec.traffic)
    engine: TrafficEngine
    try:
        engine = SumoProcess(settings) if separate else SumoEngine(settings)
    except ValueError as exc:
        raise ConfigError(str(scenario.path), str(exc)) from exc
    try:
        return TrafficDomain(scenario, engine, map_reply, spawns, seed)
    except ValueError as exc:
        engine.close()
        raise ConfigError(str(scenario.path), str(exc)) from exc
    except BaseException:
        engine.close()
        raise
