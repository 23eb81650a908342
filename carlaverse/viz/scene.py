"""Log a `WorldModel` into Rerun on the `sim_time` timeline (session seconds).

Entity layout (what tests and blueprints rely on):
    world/map/lanes/<kind>     LineStrips3D, static: lane centre lines by kind
    world/map/areas/<kind>     LineStrips3D, static: junctions and other polygons
    world/egos/<node_id>       Boxes3D, one per ego, labelled, coloured by actor kind
    world/npcs/<npc_id>        Boxes3D, one per NPC
    world/trails/<node_id>     LineStrips3D: where each ego has been
    world/trails/npcs          LineStrips3D: the NPCs' recent paths, one entity for all
    world/lights/<tls_id>      Points3D: one point per controlled link at its stop line,
                               coloured and labelled by the link's state (r y g G o O s u)
    world/impulses/<node_id>   Arrows3D: collision impulse at the contact point
    events                     TextLog: spawns, despawns, contacts
    weather/<quantity>         Scalars, and weather/summary TextDocument
    stats/rate_hz/<node_id>    Scalars: pose rate per node
    stats/latency_ms/<node_id> Scalars: one-way latency per node
Each actor is logged at its own sample's session time, so positions on the timeline are the
published poses exactly; an actor that did not change is not logged again.
"""

from __future__ import annotations

import math

import rerun as rr

from carlaverse import messages as m
from carlaverse.viz.world import Actor, WorldModel

IMPULSE_SCALE = 1e-3  # [m per N·s] arrow length for an impulse
LANE_LIFT_M = 0.02  # [m] above the ground so lanes do not z-fight with a ground plane

KIND_COLORS: dict[str, tuple[int, int, int]] = {
    "car": (66, 135, 245),
    "van": (120, 100, 230),
    "truck": (150, 90, 40),
    "bus": (230, 170, 30),
    "motorcycle": (220, 60, 160),
    "bicycle": (40, 190, 90),
    "pedestrian": (250, 120, 40),
    "other": (150, 150, 150),
}
EGO_COLOR_BOOST = 1.25  # egos are drawn brighter than NPCs of the same kind
LANE_COLORS: dict[str, tuple[int, int, int]] = {
    "road": (90, 90, 90),
    "sidewalk": (170, 170, 150),
    "bike": (60, 150, 90),
    "crossing": (235, 235, 235),
    "walkingarea": (160, 160, 140),
    "rail": (120, 80, 60),
}
LIGHT_COLORS: dict[str, tuple[int, int, int]] = {
    "r": (230, 30, 30),
    "u": (230, 120, 30),  # red-yellow
    "y": (240, 200, 20),
    "g": (40, 200, 60),
    "G": (20, 240, 60),
    "s": (230, 30, 30),  # stop sign
    "o": (120, 120, 120),  # off, blinking
    "O": (80, 80, 80),  # off, no signal
}


def quaternion(roll: float, pitch: float, yaw: float) -> rr.Quaternion:
    """Body-to-world rotation for intrinsic Z-Y-X (yaw, pitch, roll) angles [rad]."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return rr.Quaternion(
        xyzw=[
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ]
    )


def actor_color(actor: Actor) -> tuple[int, int, int]:
    base = KIND_COLORS.get(actor.kind, KIND_COLORS["other"])
    if not actor.ego:
        return base
    return tuple(min(255, round(c * EGO_COLOR_BOOST)) for c in base)  # type: ignore[return-value]


def actor_path(actor: Actor) -> str:
    return f"world/{'egos' if actor.ego else 'npcs'}/{actor.id}"


class SceneLogger:
    """Writes what changed in a WorldModel to one explicit recording stream."""

    def __init__(self, rec: rr.RecordingStream, trails: bool = True) -> None:
        self.rec = rec
        self.trails = trails
        self.frames = 0
        self._styles: dict[str, tuple[str, m.Extent]] = {}  # entity -> what its box last showed
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    def _at(self, t: float) -> None:
        self.rec.set_time("sim_time", duration=t)

    def render(self, world: WorldModel) -> None:
        """Log everything that changed since the last call, and clear the change flags."""
        if world.map_dirty and world.map is not None:
            self.log_map(world.map)
            world.map_dirty = False
            world.lights_dirty = world.lights is not None  # now they can be placed
        self._clear_removed(world)
        for actor in world.egos.values():
            if actor.dirty:
                self.log_actor(actor)
                self._log_trail(actor)
        moved = [a for a in world.npcs.values() if a.dirty]
        for actor in moved:
            self.log_actor(actor)
        if moved and self.trails:
            self._log_npc_trails(world, max(a.t for a in moved))
        if world.lights_dirty and world.lights is not None:
            self.log_lights(world.lights, world.map)
            world.lights_dirty = False
        if world.weather_dirty and world.weather is not None:
            self.log_weather(world.weather)
            world.weather_dirty = False
        self._log_impulses(world)
        self._log_events(world)
        self.log_stats(world)
        self.frames += 1

    # ------------------------------------------------------------------ map

    def log_map(self, road_map: m.MapReply) -> None:
        by_kind: dict[str, list[list[tuple[float, float, float]]]] = {}
        for lane in road_map.lanes:
            strip = [(x, y, LANE_LIFT_M) for x, y in lane.centerline]
            by_kind.setdefault(lane.kind, []).append(strip)
        for kind, strips in by_kind.items():
            color = LANE_COLORS.get(kind, (128, 128, 128))
            radius = 0.4 if kind == "crossing" else 0.15  # [m] crossings drawn as wide bands
            self.rec.log(
                f"world/map/lanes/{kind}",
                rr.LineStrips3D(strips, colors=[color], radii=[radius]),
                static=True,
            )
        areas: dict[str, list[list[tuple[float, float, float]]]] = {}
        for area in road_map.areas:
            ring = [(x, y, 0.0) for x, y in area.polygon]
            areas.setdefault(area.kind, []).append([*ring, ring[0]] if ring else ring)
        for kind, strips in areas.items():
            self.rec.log(f"world/map/areas/{kind}", rr.LineStrips3D(strips), static=True)

    # ------------------------------------------------------------------ actors

    def log_actor(self, actor: Actor) -> None:
        """The actor's box at its sample's time; what does not change is logged only once."""
        self._at(actor.t)
        e = actor.extent
        x, y, z = actor.xyz
        path = actor_path(actor)
        style = (actor.kind, e)
        center, rotation = [(x, y, z + e.height / 2)], [quaternion(*actor.rpy)]
        if self._styles.get(path) == style:
            # the hot path: rerun keeps the rest (latest-at), so only move the box
            self.rec.log(path, rr.Boxes3D.from_fields(centers=center, quaternions=rotation))
        else:
            self._styles[path] = style
            box = rr.Boxes3D(
                centers=center,
                half_sizes=[(e.length / 2, e.width / 2, e.height / 2)],
                quaternions=rotation,
                labels=[actor.id],
                colors=[actor_color(actor)],
                fill_mode="solid" if actor.ego else None,
            )
            self.rec.log(path, box)
        actor.dirty = False

    def _log_trail(self, actor: Actor) -> None:
        if self.trails and len(actor.trail) > 1:
            strip = rr.LineStrips3D([list(actor.trail)], colors=[actor_color(actor)], radii=[0.08])
            self.rec.log(f"world/trails/{actor.id}", strip)

    def _log_npc_trails(self, world: WorldModel, t: float) -> None:
        """All NPC trails as one entity: one call per frame instead of one per NPC."""
        self._at(t)
        npcs = [a for a in world.npcs.values() if len(a.trail) > 1]
        strips = [list(a.trail) for a in npcs]
        colors = [actor_color(a) for a in npcs]
        self.rec.log("world/trails/npcs", rr.LineStrips3D(strips, colors=colors, radii=[0.05]))

    def _clear_removed(self, world: WorldModel) -> None:
        for actor_id, ego, t in world.removed:
            self._at(t)
            path = f"world/{'egos' if ego else 'npcs'}/{actor_id}"
            self.rec.log(path, rr.Clear(recursive=True))
            self._styles.pop(path, None)
            if ego:
                self.rec.log(f"world/trails/{actor_id}", rr.Clear(recursive=True))
        world.removed.clear()

    # ------------------------------------------------------------------ lights, weather

    def log_lights(self, state: m.LightsState, road_map: m.MapReply | None) -> None:
        self._at(state.t)
        stop_lines = _stop_lines(road_map)
        placed = {light.id: light for light in road_map.lights} if road_map else {}
        for light in state.lights:
            points, colors, labels = [], [], []
            controlled = placed[light.id].controlled_lanes if light.id in placed else []
            for i, char in enumerate(light.state):
                lane = controlled[i] if i < len(controlled) else ""
                xy = stop_lines.get(lane) or (
                    placed[light.id].position if light.id in placed else None
                )
                if xy is None:
                    continue
                points.append((xy[0], xy[1], 3.0))  # [m] signal head height
                colors.append(LIGHT_COLORS.get(char, (128, 128, 128)))
                labels.append(f"{light.id}:{i} {char}")
            if points:
                self.rec.log(
                    f"world/lights/{light.id}",
                    rr.Points3D(points, colors=colors, labels=labels, radii=[0.6]),
                )
        text = ", ".join(f"{light.id}={light.state}" for light in state.lights)
        self.rec.log("events/lights", rr.TextLog(f"lights {text}", level="DEBUG"))

    def log_weather(self, weather: m.Weather) -> None:
        self._at(weather.t)
        for name in ("cloudiness", "precipitation", "fog_density", "wetness"):
            self.rec.log(f"weather/{name}", rr.Scalars(getattr(weather, name)))
        self.rec.log("weather/sun_altitude_deg", rr.Scalars(weather.sun_altitude_deg))
        self.rec.log("weather/wind_speed_mps", rr.Scalars(weather.wind_speed_mps))
        summary = (
            f"sun {weather.sun_altitude_deg:.0f}° alt / {weather.sun_azimuth_deg:.0f}° az, "
            f"clouds {weather.cloudiness:.0%}, rain {weather.precipitation:.0%}, "
            f"fog {weather.fog_density:.0%}, wet {weather.wetness:.0%}, "
            f"wind {weather.wind_speed_mps:.1f} m/s from {weather.wind_direction_deg:.0f}°"
        )
        self.rec.log("weather/summary", rr.TextDocument(summary))

    # ------------------------------------------------------------------ events, stats

    def _log_impulses(self, world: WorldModel) -> None:
        for node_id, imp in world.impulses:
            self._at(imp.t)
            vector = [c * IMPULSE_SCALE for c in imp.impulse]
            magnitude = math.sqrt(sum(c * c for c in imp.impulse))
            self.rec.log(
                f"world/impulses/{node_id}",
                rr.Arrows3D(
                    origins=[imp.point], vectors=[vector], colors=[(255, 40, 40)],
                    labels=[f"{magnitude:.0f} N·s from {imp.other_id}"],
                ),
            )  # fmt: skip
            text = (
                f"impulse on {node_id}: {magnitude:.0f} N·s from {imp.other_id} ({imp.other_kind})"
            )
            self.rec.log("events", rr.TextLog(text, level="WARN"))
        world.impulses.clear()

    def _log_events(self, world: WorldModel) -> None:
        for event in world.events:
            self._at(event.t)
            self.rec.log("events", rr.TextLog(event.text, level=event.level))
        world.events.clear()

    def log_stats(self, world: WorldModel) -> None:
        self._at(world.session_t)
        for node_id, stats in world.nodes.items():
            if stats.rate_hz is not None:
                self.rec.log(f"stats/rate_hz/{node_id}", rr.Scalars(stats.rate_hz))
            if stats.latency_s is not None:
                self.rec.log(f"stats/latency_ms/{node_id}", rr.Scalars(stats.latency_s * 1e3))


def _stop_lines(road_map: m.MapReply | None) -> dict[str, tuple[float, float]]:
    """Lane id -> the end of its centre line, where its signal stands."""
    if road_map is None:
        return {}
    return {lane.id: lane.centerline[-1] for lane in road_map.lanes if lane.centerline}
