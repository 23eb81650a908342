"""The own vehicle in a rider's view: cockpit, handlebar, mirrors and HUD, as configured.

    own:                                 # the `own:` section of a render config (rig file)
      cockpit: {}                        # a car's bonnet, dashboard and A-pillars (defaults)
      handlebar: {}                      # a bicycle's bar
      mirrors:
        - {name: rear, at: [0.65, 0.05, 1.30], size: [0.24, 0.07], yaw_deg: 180}
      hud: {}                            # speed, gear, indicators
      lean: false                        # a two-wheeler's view rolls with its lean

Positions are in the vehicle frame, the frame of `camera.head`: x forward of the actor's
reference point (the middle of its footprint), y to the left, z up from the road [m]. A part
is drawn when the camera rides in an actor (`Renderer.draw(follow=...)`) of a kind it fits:
the cockpit in a car, van, truck or bus, the handlebar on a bicycle or motorcycle; mirrors in
either. Everything is off by default, so a bare `RenderConfig()` shows the world alone; the
shipped rigs switch them on.

The defaults are a compact hatchback (4.3 × 1.8 × 1.46 m) whose driver's eye is at
(0.1, 0.37, 1.2) (`rigs/rig-desktop`), and an upright city bike whose rider's eye is 1.6 m up
over the bottom bracket (`rigs/rig-bike-desktop`). Another vehicle model sets its own numbers
in its rig file. No Panda3D here: the config decodes and validates on its own.
"""

from __future__ import annotations

from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct

Metres = Annotated[float, msgspec.Meta(gt=0.0)]
XZ = tuple[float, float]  # (forward, up) [m]
XYZ = tuple[float, float, float]  # (forward, left, up) [m]


class Cockpit(StrictStruct):
    """A car's bonnet, dashboard and A-pillars as its driver sees them [m]."""

    hood_front: XZ = (1.95, 0.80)  # the bonnet's front edge (its middle; the corners drop)
    hood_rear: XZ = (1.0, 0.93)  # its rear edge, at the foot of the windscreen
    hood_half_width_m: Metres = 0.80
    dash_rear: XZ = (0.55, 0.92)  # the dashboard top's edge nearest the driver
    dash_half_width_m: Metres = 0.72
    pillar_base: XYZ = (1.0, 0.70, 0.95)  # where the left A-pillar meets the scuttle (y > 0)
    pillar_top: XYZ = (0.45, 0.66, 1.40)  # and the roof; the right one is its mirror image
    pillar_width_m: Metres = 0.08


class Handlebar(StrictStruct):
    """A bicycle's swept-back bar and stem as the rider sees them [m]."""

    grip: XZ = (0.42, 1.05)  # the grips' inner ends
    half_width_m: Metres = 0.30  # centre to a grip's outer end
    clamp: XZ = (0.52, 1.08)  # where the stem holds the bar
    head_tube: XZ = (0.40, 0.90)  # the stem's foot


class Mirror(StrictStruct):
    """A mirror: its glass in the cockpit, facing the eye, shows a camera's view flipped
    left to right, as a reflection does."""

    name: str
    at: XYZ  # the glass's middle [m]
    size: tuple[Metres, Metres] = (0.24, 0.07)  # width, height [m]
    yaw_deg: float = 180.0  # where its camera looks, left positive: 180 straight back
    pitch_deg: float = 0.0  # up positive
    # horizontal field of view; None: a flat mirror's, the angle the glass subtends at the eye
    fov_deg: Annotated[float, msgspec.Meta(gt=0.0, lt=180.0)] | None = None
    # its image's width [px], rounded to a power of two (the height: its share of it)
    texture_px: Annotated[int, msgspec.Meta(ge=16, le=2048)] = 256


class Hud(StrictStruct):
    """Speed, gear and indicators as a head-up display: a virtual image ahead of the eye."""

    distance_m: Metres = 2.5  # the virtual image's distance from the eye
    down_deg: float = 9.0  # below the eye's horizontal
    left_deg: float = 0.0  # left of straight ahead
    text_height_m: Metres = 0.09  # [m] at that distance (2 degrees at 2.5 m)


class OwnView(StrictStruct):
    """What the rider sees of their own vehicle (all off by default)."""

    cockpit: Cockpit | None = None
    handlebar: Handlebar | None = None
    mirrors: tuple[Mirror, ...] = ()
    hud: Hud | None = None
    lean: bool = False  # a two-wheeler's view rolls with its lean (else the horizon stays level)


COCKPIT_KINDS = frozenset({"car", "van", "truck", "bus"})
HANDLEBAR_KINDS = frozenset({"bicycle", "motorcycle"})
TWO_WHEELERS = HANDLEBAR_KINDS
