"""Scenario files: the map, the traffic, the lights, the weather and where humans spawn.

A scenario is one YAML file (`scenarios/town.yaml`), validated like every config: unknown keys
are errors that name the file and the field path. Paths inside it (maps, polygons) are
relative to the scenario file. The text is kept byte-for-byte, because `authority/scenario`
serves the scenario exactly as it ran.

    name: town
    seed: 7
    map: {generate: {kind: grid, grid: {junctions: 3, length_m: 120}}}
    traffic: {vehicles: {count: 30}, pedestrians: {count: 20}}
    weather: {initial: {cloudiness: 0.3}, timeline: [{at_s: 600, precipitation: 0.6}]}
    egos: {drive: [{lane: A0B0_2, pos_m: 20}], walk: [{x: 50, y: 40, yaw_deg: 90}]}
    grades: {default_percent: 0, areas: [{polygon: [[0, 0], [30, 0], [30, 120], [0, 120]],
                                          grade_percent: 5, uphill_yaw_deg: 90}]}
    surface: {roughness_class: B, bumps: [{line: [[20, -4], [20, 4]], height_m: 0.08,
                                           length_m: 3}]}   (physics/road_surface.py)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import msgspec

from carlaverse.config import (
    ConfigError,
    StrictStruct,
    convert,
    parse_yaml,
    read_text,
    resolve_path,
)
from carlaverse.messages import ACTOR_KINDS
from carlaverse.patterns import anchored
from carlaverse.physics.road_surface import RoadSurface
from carlaverse.traffic.openscenario import import_triggers
from carlaverse.traffic.soundscape import AudioSpec, check_siren_vehicles, named_vehicles
from carlaverse.traffic.trigger_spec import TriggerSpec, check_triggers

NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Positive = Annotated[float, msgspec.Meta(gt=0)]
Unit = Annotated[float, msgspec.Meta(ge=0, le=1)]
Count = Annotated[int, msgspec.Meta(ge=0)]
DEFAULT_STEP_S = 0.1  # [s] SUMO's step unless the scenario sets one

# --------------------------------------------------------------------------- map


class GridTown(StrictStruct):
    junctions: Annotated[int, msgspec.Meta(ge=2)] = 3  # per direction
    junctions_y: Annotated[int, msgspec.Meta(ge=2)] | None = None  # default: as x
    length_m: Positive = 120.0  # [m] street length between junctions
    attach_length_m: NonNegative = 60.0  # [m] dead-end streets leaving the grid, 0 = none


class SpiderTown(StrictStruct):
    arms: Annotated[int, msgspec.Meta(ge=3)] = 5
    circles: Annotated[int, msgspec.Meta(ge=1)] = 3
    radius_m: Positive = 100.0  # [m] distance between circles
    omit_center: bool = False


class GeneratedMap(StrictStruct):
    """A town built by `netgenerate`."""

    kind: Literal["grid", "spider"] = "grid"
    grid: GridTown = GridTown()
    spider: SpiderTown = SpiderTown()
    lanes: Annotated[int, msgspec.Meta(ge=1, le=4)] = 1  # car lanes per direction
    speed_mps: Positive = 13.89  # [m/s] speed limit
    traffic_lights: bool = True
    sidewalks: bool = True
    crossings: bool = True
    bike_lanes: bool = False
    # Oncoming lanes paired (SUMO `neigh`, `--opposites.guess`): the centre line between them is
    # dashed, as on a town street one may overtake on; without it, solid (no overtaking).
    overtaking: bool = True
    sidewalk_width_m: Positive = 2.0  # [m]
    bike_lane_width_m: Positive = 1.5  # [m]


class PlainMap(StrictStruct):
    """A network from SUMO plain-XML files (nodes, edges, optional connections/crossings)."""

    nodes: str
    edges: str
    connections: str | None = None


class MapSource(StrictStruct):
    """Exactly one of generate / plain / net / opendrive / osm."""

    generate: GeneratedMap | None = None
    plain: PlainMap | None = None
    net: str | None = None  # a SUMO .net.xml, used as is
    opendrive: str | None = None  # .xodr, converted by netconvert
    osm: str | None = None  # .osm, converted by netconvert (polygons by polyconvert)
    polygons: str | None = None  # optional .poly.xml: vegetation, water, buildings
    guess_sidewalks: bool = False  # netconvert --sidewalks.guess (maps without sidewalks)
    netconvert_options: list[str] = []  # extra options, appended verbatim

    def __post_init__(self) -> None:
        given = [n for n in ("generate", "plain", "net", "opendrive", "osm") if getattr(self, n)]
        if len(given) != 1:
            raise ValueError(
                "give exactly one map source (generate, plain, net, opendrive or osm), "
                f"got {given or 'none'}"
            )


# --------------------------------------------------------------------------- traffic


def _default_mix() -> dict[str, float]:
    return {"car": 0.85, "van": 0.1, "truck": 0.05}


class VehicleDemand(StrictStruct):
    count: Count = 20  # NPC vehicles kept in the network
    mix: dict[str, NonNegative] = msgspec.field(default_factory=_default_mix)  # kind -> share
    min_route_edges: Annotated[int, msgspec.Meta(ge=1)] = 3

    def __post_init__(self) -> None:
        unknown = sorted(set(self.mix) - set(ACTOR_KINDS) - {"pedestrian"})
        if unknown or "pedestrian" in self.mix:
            raise ValueError(
                f"unknown vehicle kinds {unknown or ['pedestrian']} in mix; "
                f"use {[k for k in ACTOR_KINDS if k != 'pedestrian']}"
            )
        if self.count and sum(self.mix.values()) <= 0:
            raise ValueError("the vehicle mix needs at least one positive share")


class PedestrianDemand(StrictStruct):
    count: Count = 20  # NPC pedestrians kept walking


class Stop(StrictStruct):
    edge: str
    pos_m: NonNegative  # [m] along the edge
    lane: Annotated[int, msgspec.Meta(ge=0)] | None = None  # default: the rightmost car lane
    duration_s: Positive = 1e6  # [s]


class ScriptedVehicle(StrictStruct):
    """One NPC on a fixed route, for studies that need a specific encounter."""

    id: str
    edges: list[str]
    kind: str = "car"
    depart_s: NonNegative = 0.0  # [s] engine time
    depart_pos_m: NonNegative = 0.0  # [m] along the first edge
    depart_speed_mps: NonNegative = 0.0  # [m/s]
    stop: Stop | None = None


class ScriptedPedestrian(StrictStruct):
    id: str
    edges: list[str]
    depart_s: NonNegative = 0.0  # [s]
    depart_pos_m: NonNegative = 0.0  # [m]
    arrival_pos_m: float = -1.0  # [m] along the last edge, negative counts from its end


class Traffic(StrictStruct):
    vehicles: VehicleDemand = VehicleDemand()
    pedestrians: PedestrianDemand = PedestrianDemand()
    scripted_vehicles: list[ScriptedVehicle] = []
    scripted_pedestrians: list[ScriptedPedestrian] = []
    # [s] default: 0.1, or one tick when the authority ticks slower than 10 Hz. Between steps
    # the authority dead-reckons NPCs to its tick (`NpcFrame.at`); SUMO at the tick rate would
    # cost five times as much for motion that car-following models resolve at 0.1 s anyway.
    step_length_s: Positive | None = None
    action_step_s: NonNegative = 0.2  # [s] NPC decision interval, 0 = every step
    time_to_teleport_s: float = 120.0  # [s] SUMO unjams stuck vehicles, < 0 = never
    top_up_interval_s: Positive = 1.0  # [s] how often NPC counts are restored
    # [m] an ego farther than this from every lane is off-road: NPCs do not react to it
    # (a car park, a plaza); a smaller radius also makes placing egos cheaper.
    ego_match_radius_m: Positive = 10.0
    sumo_warnings: bool = False  # let SUMO print its warnings (noisy with human actors)
    sumo_options: list[str] = []  # extra sumo options, appended verbatim
    # SUMO in a process of its own, stepping beside the authority's tick (false: inside the
    # authority's process, where each step stalls the tick that takes it).
    sumo_process: bool = True


# --------------------------------------------------------------------------- lights, weather


class PhaseSpec(StrictStruct):
    duration_s: Positive  # [s]
    state: Annotated[str, msgspec.Meta(pattern=anchored("[rygGoOsu]+"))]


class LightOverride(StrictStruct):
    id: str  # traffic light (SUMO tls) id
    phases: Annotated[list[PhaseSpec], msgspec.Meta(min_length=1)]
    offset_s: float = 0.0  # [s]


class WeatherValues(StrictStruct):
    sun_altitude_deg: Annotated[float, msgspec.Meta(ge=-90, le=90)] = 45.0
    sun_azimuth_deg: float = 180.0
    cloudiness: Unit = 0.0
    precipitation: Unit = 0.0
    fog_density: Unit = 0.0
    wetness: Unit = 0.0
    wind_speed_mps: NonNegative = 0.0
    wind_direction_deg: float = 0.0


class WeatherKey(StrictStruct):
    """A timeline keyframe: the fields it names are reached at `at_s`, others carry over."""

    at_s: NonNegative  # [s] scenario time
    sun_altitude_deg: Annotated[float, msgspec.Meta(ge=-90, le=90)] | None = None
    sun_azimuth_deg: float | None = None
    cloudiness: Unit | None = None
    precipitation: Unit | None = None
    fog_density: Unit | None = None
    wetness: Unit | None = None
    wind_speed_mps: NonNegative | None = None
    wind_direction_deg: float | None = None


class WeatherSpec(StrictStruct):
    initial: WeatherValues = WeatherValues()
    timeline: list[WeatherKey] = []
    loop_s: Positive | None = None  # [s] repeat the timeline with this period

    def __post_init__(self) -> None:
        times = [k.at_s for k in self.timeline]
        if times != sorted(times):
            raise ValueError(f"weather timeline keyframes must be in time order, got {times}")


# --------------------------------------------------------------------------- road grades

GradePercent = Annotated[float, msgspec.Meta(ge=-40, le=40)]  # [%] rise per 100 m


class GradeArea(StrictStruct):
    """A stretch of road tilted as a plane: it rises `grade_percent` towards `uphill_yaw_deg`.

    A rider heading ψ feels grade · cos(ψ − uphill): the full climb going uphill, the same
    descent coming back, nothing riding across the slope.
    """

    polygon: Annotated[list[tuple[float, float]], msgspec.Meta(min_length=3)]  # [m] map frame
    grade_percent: Annotated[float, msgspec.Meta(ge=0, le=40)]  # [%] along the uphill direction
    uphill_yaw_deg: float  # [deg] counter-clockwise from east, like a spawn's yaw_deg
    name: str = ""  # for the record ("ramp to the bridge")

    def __post_init__(self) -> None:
        if not all(math.isfinite(c) for point in self.polygon for c in point):
            raise ValueError(f"polygon corners must be finite numbers, got {self.polygon}")
        if not math.isfinite(self.uphill_yaw_deg):
            raise ValueError("uphill_yaw_deg must be a finite angle in degrees")


class Grades(StrictStruct):
    """The road's grade where the map carries no elevation: areas (the first that holds the
    point wins), else `default_percent` (felt at any heading), else the node's own config."""

    default_percent: GradePercent | None = None
    areas: list[GradeArea] = []


# --------------------------------------------------------------------------- egos, session


class Spawn(StrictStruct):
    """A spawn point: either world coordinates or a lane and a distance along it."""

    x: float | None = None  # [m]
    y: float | None = None  # [m]
    z: float = 0.0  # [m]
    yaw_deg: float = 0.0  # [deg] counter-clockwise from east
    lane: str | None = None  # SUMO lane id; the pose follows the lane
    pos_m: NonNegative = 0.0  # [m] along the lane

    def __post_init__(self) -> None:
        if (self.lane is None) == (self.x is None or self.y is None):
            raise ValueError("a spawn point has either x and y, or a lane (with pos_m)")


class ActorPhysics(StrictStruct):
    mass_kg: Positive
    restitution: Unit


def _default_physics() -> dict[str, ActorPhysics]:
    table = {
        "car": (1500.0, 0.2),
        "van": (2500.0, 0.2),
        "truck": (12000.0, 0.1),
        "bus": (15000.0, 0.1),
        "motorcycle": (250.0, 0.3),
        "bicycle": (95.0, 0.3),
        "pedestrian": (75.0, 0.1),
        "other": (1000.0, 0.2),
    }
    return {k: ActorPhysics(mass_kg=m, restitution=e) for k, (m, e) in table.items()}


class CollisionSpec(StrictStruct):
    actors: dict[str, ActorPhysics] = msgspec.field(default_factory=_default_physics)
    npc_npc: bool = False  # also track NPC-NPC contacts (events only, no one to push)
    npc_hit_remove_after_s: NonNegative = 10.0  # [s] a hit NPC stops, then leaves
    max_extrapolation_s: NonNegative = 0.5  # [s] dead-reckon an ego's pose at most this far

    def physics(self, kind: str) -> ActorPhysics:
        return (
            self.actors.get(kind)
            or self.actors.get("other")
            or ActorPhysics(mass_kg=1000.0, restitution=0.2)
        )


class Session(StrictStruct):
    tick_hz: Positive = 50.0  # [Hz] authority tick and traffic step
    despawn_timeout_s: Positive = 3.0  # [s] telemetry silence before a despawn
    npc_rate_hz: Positive = 20.0  # [Hz] world/npc batches
    status_rate_hz: Positive = 1.0  # [Hz] lights and weather repeated even when unchanged
    max_catch_up_steps: Annotated[int, msgspec.Meta(ge=1)] = 5  # per tick, after a stall


class ScenarioSpec(StrictStruct, kw_only=True):
    name: str
    description: str = ""
    seed: int = 42
    map: MapSource
    traffic: Traffic = Traffic()
    lights: list[LightOverride] = []
    weather: WeatherSpec = WeatherSpec()
    egos: dict[str, list[Spawn]] = {}  # node kind (drive, bike, walk, ...) -> spawn points
    session: Session = Session()
    collisions: CollisionSpec = CollisionSpec()
    grades: Grades = Grades()
    surface: RoadSurface = RoadSurface()  # roughness, speed bumps, kerbs, potholes
    audio: AudioSpec = AudioSpec()
    triggers: list[TriggerSpec] = []  # scripted encounters (trigger_spec.py)
    openscenario: str | None = None  # an .xosc whose events become more triggers

    def __post_init__(self) -> None:
        named = named_vehicles(self.traffic.scripted_vehicles, self.triggers)
        check_siren_vehicles(self.audio, named)
        check_triggers(self.triggers)

    @property
    def step_length_s(self) -> float:
        return self.traffic.step_length_s or max(DEFAULT_STEP_S, 1.0 / self.session.tick_hz)


@dataclass(frozen=True, slots=True)
class Scenario:
    """A validated scenario, where it came from and its exact text."""

    spec: ScenarioSpec
    path: Path
    text: str

    @property
    def base_dir(self) -> Path:
        return self.path.parent

    def resolve(self, relative: str) -> Path:
        """A file named in the scenario, relative to the scenario file."""
        return resolve_path(relative, self.base_dir)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a scenario by path or by shipped name ('town', 'crossing', ...)."""
    path = resolve_path(name_or_path)
    text = read_text(path)
    spec = convert(parse_yaml(text, str(path)), ScenarioSpec, str(path))
    if spec.openscenario:
        imported = import_triggers(resolve_path(spec.openscenario, path.parent))
        spec = msgspec.structs.replace(spec, triggers=[*spec.triggers, *imported])
        try:
            check_triggers(spec.triggers)
        except ValueError as exc:
            raise ConfigError(str(path), str(exc)) from exc
    return Scenario(spec, path, text)
