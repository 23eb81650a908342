"""Colours and heights of everything the renderer draws, in one place (RGBA, 0..1; metres)."""

from __future__ import annotations

from carlaverse.render.meshes import Color

GROUND: Color = (0.36, 0.42, 0.30, 1.0)
ASPHALT: Color = (0.22, 0.22, 0.23, 1.0)
JUNCTION: Color = (0.24, 0.24, 0.25, 1.0)
SIDEWALK: Color = (0.62, 0.61, 0.58, 1.0)
WALKINGAREA: Color = (0.58, 0.57, 0.54, 1.0)
BIKE_LANE: Color = (0.55, 0.25, 0.22, 1.0)
RAIL: Color = (0.35, 0.28, 0.22, 1.0)
MARKING: Color = (0.92, 0.92, 0.90, 1.0)
STOP_LINE: Color = (0.95, 0.95, 0.93, 1.0)
VEGETATION: Color = (0.22, 0.45, 0.20, 1.0)
TREE_TRUNK: Color = (0.35, 0.25, 0.15, 1.0)
TREE_CROWN: Color = (0.16, 0.38, 0.16, 1.0)
WATER: Color = (0.18, 0.33, 0.52, 1.0)
BUILDING: Color = (0.70, 0.66, 0.60, 1.0)
POLE: Color = (0.25, 0.25, 0.27, 1.0)
KERB: Color = (0.70, 0.69, 0.66, 1.0)
ROOF: Color = (0.30, 0.29, 0.29, 1.0)
# Facade plaster colours, one per building (its id picks): white, cream, sand, ochre, brick
# red, grey, pale green.
FACADES: tuple[Color, ...] = (
    (0.92, 0.91, 0.88, 1.0),
    (0.93, 0.87, 0.74, 1.0),
    (0.84, 0.76, 0.62, 1.0),
    (0.86, 0.70, 0.46, 1.0),
    (0.72, 0.42, 0.32, 1.0),
    (0.70, 0.70, 0.70, 1.0),
    (0.78, 0.84, 0.74, 1.0),
)
TREE_CROWNS: tuple[Color, ...] = (  # greens of different species
    (0.16, 0.38, 0.16, 1.0),
    (0.22, 0.42, 0.14, 1.0),
    (0.12, 0.32, 0.15, 1.0),
    (0.28, 0.45, 0.18, 1.0),
)
SIGN_POLE: Color = (0.62, 0.63, 0.65, 1.0)  # galvanised steel
HOUSING: Color = (0.08, 0.08, 0.09, 1.0)

LANE_COLORS: dict[str, Color] = {
    "road": ASPHALT,
    "sidewalk": SIDEWALK,
    "bike": BIKE_LANE,
    "crossing": ASPHALT,
    "walkingarea": WALKINGAREA,
    "rail": RAIL,
}
# Surfaces stack a little so coplanar layers never z-fight. [m]
LANE_Z: dict[str, float] = {
    "road": 0.02,
    "bike": 0.025,
    "crossing": 0.03,
    "rail": 0.02,
    "sidewalk": 0.12,  # a kerb's height
    "walkingarea": 0.12,
}
JUNCTION_Z = 0.015
MARKING_LIFT = 0.01
GROUND_Z = -0.02
WATER_Z = 0.017  # above parks (a pond lies in one), under lanes (bridges)

ACTOR_COLORS: dict[str, Color] = {
    "car": (0.20, 0.38, 0.75, 1.0),
    "van": (0.85, 0.85, 0.82, 1.0),
    "truck": (0.60, 0.35, 0.15, 1.0),
    "bus": (0.90, 0.68, 0.12, 1.0),
    "motorcycle": (0.75, 0.15, 0.55, 1.0),
    "bicycle": (0.15, 0.70, 0.35, 1.0),
    "pedestrian": (0.95, 0.50, 0.15, 1.0),
    "other": (0.55, 0.55, 0.55, 1.0),
}
EGO_TINT = 1.2  # egos drawn a little brighter than NPCs of the same kind
GLASS: Color = (0.10, 0.14, 0.18, 1.0)
SKIN: Color = (0.85, 0.68, 0.55, 1.0)
TYRE: Color = (0.05, 0.05, 0.05, 1.0)

# Lamps: (lit, unlit). Lamps are unlit by the scene lights: they glow in any weather.
BRAKE_LAMP: tuple[Color, Color] = ((1.0, 0.05, 0.05, 1.0), (0.35, 0.02, 0.02, 1.0))
BLINKER_LAMP: tuple[Color, Color] = ((1.0, 0.60, 0.0, 1.0), (0.30, 0.20, 0.05, 1.0))
SIGNAL_RED: tuple[Color, Color] = ((1.0, 0.08, 0.05, 1.0), (0.18, 0.04, 0.04, 1.0))
SIGNAL_YELLOW: tuple[Color, Color] = ((1.0, 0.80, 0.0, 1.0), (0.18, 0.15, 0.03, 1.0))
SIGNAL_GREEN: tuple[Color, Color] = ((0.05, 1.0, 0.25, 1.0), (0.03, 0.16, 0.06, 1.0))

SKY_CLEAR: Color = (0.45, 0.65, 0.92, 1.0)
SKY_OVERCAST: Color = (0.62, 0.64, 0.66, 1.0)
SKY_NIGHT: Color = (0.02, 0.03, 0.06, 1.0)
