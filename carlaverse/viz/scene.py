"""Log a session into Rerun on the `sim_time` timeline (session seconds).

Entity layout (what tests and blueprints rely on):
    world/map/lanes/<kind>     LineStrips3D, static: lane centre lines by kind
    world/map/areas/<kind>     LineStrips3D, static: junctions and other polygons
    world/egos/, world/npcs/,  the actors where the world view draws them, at its render
    world/trails/              time (see `actors`)
    world/raw/                 with `--raw`: the samples as received (see `raw`)
    world/lights/<tls_id>      Points3D: one point per controlled link at its stop line,
                               coloured and labelled by the link's state (r y g G o O s u)
    world/impulses/<node_id>   Arrows3D: collision impulse at the contact point
    events                     TextLog: spawns, despawns, contacts
    weather/<quantity>         Scalars, and weather/summary TextDocument
    stats/rate_hz/<node_id>    Scalars: pose rate per node
    stats/latency_ms/<node_id> Scalars: one-way latency per node
Actors come from the world model's `WorldView` (one render time per frame, interpolated or
projected as its settings say), everything else from the `WorldModel`; only what changed is
logged.
"""

from __future__ import annotations

import math

import rerun as rr

from carlaverse import messages as m
from carlaverse.viz.actors import KIND_COLORS, ActorLayer, quaternion
from carlaverse.viz.model import WorldModel
from carlaverse.viz.raw import RawTap
from carlaverse.world.world_view import WorldView

__all__ = ["KIND_COLORS", "LIGHT_COLORS", "SceneLogger", "quaternion"]

IMPULSE_SCALE = 1e-3  # [m per N·s] arrow length for an impulse
LANE_LIFT_M = 0.02  # [m] above the ground so lanes do not z-fight with a ground plane

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


class SceneLogger:
    """Writes a session to one explicit recording stream: actors every frame, the rest on
    change."""

    def __init__(self, rec: rr.RecordingStream, trails: bool = True, raw: bool = False) -> None:
        self.rec = rec
        self.actors = ActorLayer(rec, trails)
        # with --raw the sources (live, playback) tap the samples here, drawn beside the actors
        self.raw = RawTap() if raw else None
        self.frames = 0
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    def _at(self, t: float) -> None:
        self.rec.set_time("sim_time", duration=t)

    def render(self, world: WorldModel, view: WorldView, now: float) -> float:
        """Log one frame at session time `now`; returns the render time the actors show [s]."""
        if world.map_dirty and world.map is not None:
            self.log_map(world.map)
            world.map_dirty = False
            world.lights_dirty = world.lights is not None  # now they can be placed
        render_t = self.actors.draw(view, now, world.looks)
        if self.raw is not None:
            self.raw.log(self.rec)
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
        return render_t

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
