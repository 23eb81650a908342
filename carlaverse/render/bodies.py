"""What each vehicle kind looks like: its body and glass, where its wheels turn, a cyclist's legs.

A body is built in a unit frame (x across −0.5..0.5, y along −0.5..0.5 with +y forward, z up
0..1) that the actor layer scales to an actor's extent, so 200 cars share one mesh. The unit
box is the protocol's bounding box: whatever a kind is made of — body, glass, mirrors, wheels,
handlebar, rider, lamps — reaches the box's faces and none goes beyond, and every vehicle rests
on its wheels at z = 0, the road under the actor's reference point. Glass is a second mesh on
the body's faces, standing `GLASS_PROUD` off them: a polygon offset did not reliably win over
a face seen square-on. For the same reason the bodies' end faces stop at `END`, short of the
box's ends, which the lamps (`lamps`) reach.

Wheels, a two-wheeler's handlebar and a cyclist's legs move, so they are not in the scaled
body: an unevenly scaled frame would shear a turning wheel. `wheel_places`, `bar_place` and
`leg_geometry` put them in metres for the actor's own extent. Wheels are sized for the kind's
typical extent (`KIND_EXTENTS`) and scaled uniformly by the smaller of the length and height
ratios, so they stay round and in the box.
Two-wheelers and their riders are modelled in metres at the typical extent (`_Sculpt.metric`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from panda3d.core import NodePath

from carlaverse.messages import KIND_EXTENTS, Extent
from carlaverse.render import palette
from carlaverse.render.meshes import Color, MeshBuilder, Point3
from carlaverse.render.shapes import beam, facing, profile_x

GLASS_PROUD = 0.003  # [unit frame] a pane's distance off the face it lies on
END = 0.495  # bodies' end faces: lamps stand 0.005 proud of them (2 cm on a car) and reach 0.5
FRAME: Color = (0.12, 0.12, 0.13, 1.0)  # bicycle parts, a rider's trousers, cargo chassis
CARGO: Color = (0.86, 0.86, 0.84, 1.0)  # a truck's box
JACKET: Color = (0.18, 0.22, 0.32, 1.0)  # riders
BASKET: Color = (0.45, 0.32, 0.18, 1.0)


@dataclass(frozen=True, slots=True)
class Wheels:
    """A kind's wheels at its typical extent."""

    radius_m: float  # [m] to the tread
    tyre_m: float  # [m] tread width
    axles: tuple[float, ...]  # along the length from its middle, as a fraction of it (+ ahead)
    paired: bool  # a wheel at each side of an axle (else one, in line: a two-wheeler)

    def wheelbase_m(self, length_m: float) -> float:
        """[m] front axle to the middle of the rear ones, for the actor's length."""
        rear = self.axles[1:]
        return (self.axles[0] - sum(rear) / len(rear)) * length_m


# Typical sizes: a car on 205/55 R16 (0.32 m), a van on 16" light-truck tyres, a truck and a
# city bus on 22.5" (0.5 m), a motorcycle on 17" (0.3 m), a bicycle on 700C (0.34 m); the
# axles give wheelbases of 2.7 m, 3.4 m, 6.0 m (front to the rear tandem's middle), 6.0 m,
# 1.4 m and 1.0 m.
WHEELS: dict[str, Wheels] = {
    "car": Wheels(0.32, 0.20, (0.3, -0.3), paired=True),
    "van": Wheels(0.35, 0.22, (0.33, -0.33), paired=True),
    "truck": Wheels(0.5, 0.3, (0.36, -0.24, -0.37), paired=True),
    "bus": Wheels(0.5, 0.3, (0.28, -0.22), paired=True),
    "motorcycle": Wheels(0.3, 0.12, (0.33, -0.33), paired=False),
    "bicycle": Wheels(0.34, 0.04, (0.28, -0.28), paired=False),
}
WHEEL_INSET = 0.01  # a paired wheel's outer face this far inside the box's side (unit frame)
BODY_SIDE = 0.47  # four-wheelers' flanks: the wheels stand 2 % proud, mirrors reach the box


@dataclass(frozen=True, slots=True)
class WheelPlace:
    """One wheel of one actor, in metres in its frame (x right, y forward, z up)."""

    x: float
    y: float
    radius_m: float
    tyre_m: float
    front: bool  # on the steered axle


def wheel_places(kind: str, size: Extent) -> list[WheelPlace]:
    """Where an actor of `kind` and extent `size` has its wheels (none for other kinds)."""
    wheels = WHEELS.get(kind)
    if wheels is None:
        return []
    typical = KIND_EXTENTS[kind]
    scale = min(size.length / typical.length, size.height / typical.height)
    r = wheels.radius_m * scale
    tyre = wheels.tyre_m * size.width / typical.width
    side = size.width * (0.5 - WHEEL_INSET) - tyre / 2
    return [
        WheelPlace(x, along * size.length, r, tyre, front=along == wheels.axles[0])
        for along in wheels.axles
        for x in ((-side, side) if wheels.paired else (0.0,))
    ]


# ----------------------------------------------------------------- bodies


class _Sculpt:
    """A kind's body and glass meshes in the unit frame; `metric` converts metres at the
    kind's typical extent into it."""

    def __init__(self, kind: str) -> None:
        self.body = MeshBuilder(f"actor/{kind}")
        self.glass = MeshBuilder(f"actor/{kind}/glass")
        e = KIND_EXTENTS.get(kind, KIND_EXTENTS["other"])
        self.size = (e.width, e.length, e.height)

    def metric(self, p: Point3) -> Point3:
        return (p[0] / self.size[0], p[1] / self.size[1], p[2] / self.size[2])

    def box_m(self, center: Point3, size: Point3, color: Color) -> None:
        self.body.box(self.metric(center), self.metric(size), color)

    def beam_m(self, a: Point3, b: Point3, thick_m: float, color: Color) -> None:
        """A round-ish member (tube, limb) `thick_m` across, from a to b [m]."""
        sx, sy, _ = self.size
        beam(self.body, self.metric(a), self.metric(b), thick_m / sx, thick_m / sy, color)

    def pane(self, corners: list[Point3], outward: Point3) -> None:
        """A window on a face, `GLASS_PROUD` off it along `outward` (the face's normal)."""
        n = math.sqrt(sum(c * c for c in outward)) or 1.0
        off = [c / n * GLASS_PROUD for c in outward]
        lifted = [(x + off[0], y + off[1], z + off[2]) for x, y, z in corners]
        facing(self.glass, lifted, outward, palette.GLASS)

    def node(self) -> NodePath:
        root = NodePath(self.body.name)
        root.attach_new_node(self.body.node())
        if not self.glass.empty:
            root.attach_new_node(self.glass.node())
        return root


def _along_edge(a: tuple[float, float], b: tuple[float, float], t: float) -> tuple[float, float]:
    return (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t)


def _slope_pane(s: _Sculpt, a: tuple[float, float], b: tuple[float, float],
                span: tuple[float, float], half_x: float) -> None:  # fmt: skip
    """A pane on the sloped face a→b (y, z) of a profile, between fractions `span` of it."""
    (y0, z0), (y1, z1) = _along_edge(a, b, span[0]), _along_edge(a, b, span[1])
    out = (0.0, b[1] - a[1], a[0] - b[0])  # the edge turned a quarter: outward for a→b ccw
    if out[1] * (a[0] + b[0]) < 0:
        out = (0.0, -out[1], -out[2])
    s.pane([(-half_x, y0, z0), (half_x, y0, z0), (half_x, y1, z1), (-half_x, y1, z1)], out)


def _side_panes(s: _Sculpt, x: float, panes: list[list[tuple[float, float]]]) -> None:
    """Windows on both flanks at ±x, each a (y, z) outline."""
    for sign in (-1.0, 1.0):
        for outline in panes:
            s.pane([(sign * x, y, z) for y, z in outline], (sign, 0.0, 0.0))


def _mirrors(s: _Sculpt, y: float, z: float, size: tuple[float, float], body: Color,
             inner: float = BODY_SIDE) -> None:  # fmt: skip
    """Door mirrors from the flank at `inner` out to the box's sides: they fill its width."""
    for sign in (-1.0, 1.0):
        s.body.box((sign * (inner + 0.5) / 2, y, z), (0.5 - inner, *size), body)


def _car(s: _Sculpt, body: Color) -> None:
    w = BODY_SIDE
    profile_x(s.body, [(-END, 0.14), (END, 0.14), (END, 0.40), (0.44, 0.50), (0.22, 0.56),
                       (-0.38, 0.56), (-END, 0.50)], -w, w, body)  # fmt: skip
    front, top_f, top_r, rear = (0.25, 0.54), (0.0, 1.0), (-0.30, 1.0), (-0.44, 0.54)
    profile_x(s.body, [rear, front, top_f, top_r], -0.40, 0.40, body)
    _slope_pane(s, front, top_f, (0.08, 0.92), 0.36)
    _slope_pane(s, top_r, rear, (0.1, 0.9), 0.34)

    def a_line(z: float) -> float:  # the windscreen's edge, 4 % behind it
        return 0.25 - 0.25 * (z - 0.54) / 0.46 - 0.04

    def c_line(z: float) -> float:
        return -0.44 + 0.14 * (z - 0.54) / 0.46 + 0.04

    _side_panes(s, 0.40, [
        [(a_line(0.60), 0.60), (-0.08, 0.60), (-0.08, 0.95), (a_line(0.95), 0.95)],
        [(-0.13, 0.60), (c_line(0.60), 0.60), (c_line(0.95), 0.95), (-0.13, 0.95)],
    ])  # fmt: skip
    _mirrors(s, 0.22, 0.56, (0.04, 0.06), body, inner=0.40)


def _van(s: _Sculpt, body: Color) -> None:
    w = BODY_SIDE
    base, top = (0.44, 0.42), (0.33, 0.95)
    profile_x(s.body, [(-END, 0.09), (END, 0.09), (END, 0.33), base, top, (0.30, 1.0),
                       (-END, 1.0)], -w, w, body)  # fmt: skip
    _slope_pane(s, base, top, (0.12, 0.92), 0.40)

    def a_line(z: float) -> float:
        return 0.44 - 0.11 * (z - 0.42) / 0.53 - 0.03

    _side_panes(s, w, [[(0.12, 0.58), (a_line(0.58), 0.58), (a_line(0.9), 0.9), (0.12, 0.9)]])
    for x0, x1 in ((-0.42, -0.04), (0.04, 0.42)):  # the rear doors' windows
        s.pane([(x0, -END, 0.62), (x1, -END, 0.62), (x1, -END, 0.85), (x0, -END, 0.85)],
               (0.0, -1.0, 0.0))  # fmt: skip
    _mirrors(s, 0.38, 0.5, (0.04, 0.1), body)


def _truck(s: _Sculpt, body: Color) -> None:
    w = BODY_SIDE
    base, top = (END, 0.42), (0.475, 0.78)
    profile_x(s.body, [(0.26, 0.08), (END, 0.08), base, top, (0.45, 0.82), (0.26, 0.82)],
              -w, w, body)  # fmt: skip
    _slope_pane(s, base, top, (0.08, 0.92), 0.42)
    _side_panes(s, w, [[(0.30, 0.5), (0.44, 0.5), (0.44, 0.76), (0.30, 0.76)]])
    _mirrors(s, 0.46, 0.55, (0.02, 0.12), body)
    s.body.box((0.0, -0.13, 0.1), (0.7, 0.74, 0.23), FRAME)  # chassis under the box
    s.body.box((0.0, (0.24 - END) / 2, 0.33), (1.0, 0.24 + END, 0.67), CARGO)


def _bus(s: _Sculpt, body: Color) -> None:
    w = BODY_SIDE
    profile_x(s.body, [(-END, 0.08), (END, 0.08), (END, 0.95), (0.475, 1.0), (-0.475, 1.0),
                       (-END, 0.95)], -w, w, body)  # fmt: skip
    s.pane([(-0.42, END, 0.35), (0.42, END, 0.35), (0.42, END, 0.92), (-0.42, END, 0.92)],
           (0.0, 1.0, 0.0))  # fmt: skip
    s.pane([(-0.38, -END, 0.6), (0.38, -END, 0.6), (0.38, -END, 0.9), (-0.38, -END, 0.9)],
           (0.0, -1.0, 0.0))  # fmt: skip
    bays = [(-0.46 + 0.15 * k, -0.46 + 0.15 * k + 0.135) for k in range(6)]
    _side_panes(s, w, [[(y0, 0.45), (y1, 0.45), (y1, 0.88), (y0, 0.88)] for y0, y1 in bays])
    _mirrors(s, 0.47, 0.8, (0.03, 0.1), body)


def _motorcycle(s: _Sculpt, body: Color) -> None:
    """In metres at 2.1 × 0.8 × 1.5: engine, tank, seat, fork, nacelle, a rider on the pegs."""
    s.beam_m((0, -0.35, 0.5), (0, 0.4, 0.55), 0.3, FRAME)  # engine and frame
    s.beam_m((0, 0.05, 0.82), (0, 0.45, 0.85), 0.3, body)  # tank
    s.box_m((0, -0.3, 0.74), (0.28, 0.6, 0.08), FRAME)  # seat
    s.box_m((0, -0.77, 0.66), (0.18, 0.54, 0.08), body)  # tail, its lamp to the box's end
    s.beam_m((0, 0.55, 1.0), (0, 0.693, 0.3), 0.09, FRAME)  # fork
    s.box_m((0, 0.96, 0.8), (0.28, 0.16, 0.2), body)  # nacelle, its lamp to the box's front
    s.beam_m((0, -0.3, 0.85), (0, -0.05, 1.3), 0.36, JACKET)
    s.box_m((0, -0.02, 1.28), (0.26, 0.28, 0.22), FRAME)  # helmet: the top
    for side in (-1.0, 1.0):
        s.beam_m((side * 0.18, -0.08, 1.26), (side * 0.3, 0.5, 1.07), 0.08, JACKET)
        s.beam_m((side * 0.13, -0.3, 0.85), (side * 0.17, 0.12, 0.78), 0.13, FRAME)
        s.beam_m((side * 0.17, 0.12, 0.78), (side * 0.17, -0.05, 0.35), 0.11, FRAME)


# The bicycle in metres at 1.8 × 0.6 × 1.7: bottom bracket, hips on the saddle, the bar
BOTTOM_BRACKET = (-0.08, 0.28)  # (forward, up) [m]
HIP = (-0.27, 0.98)
HIP_HALF_WIDTH_M = 0.09


def _bicycle(s: _Sculpt, body: Color) -> None:
    bb = (0.0, *BOTTOM_BRACKET)
    rear, front = (0.0, -0.504, 0.34), (0.0, 0.504, 0.34)
    for a, b in ((bb, (0, -0.24, 0.92)), ((0, -0.22, 0.82), (0, 0.37, 0.84)),
                 (bb, (0, 0.39, 0.74)), (bb, rear), ((0, -0.23, 0.85), rear),
                 ((0, 0.40, 0.74), front), ((0, 0.36, 0.88), (0, 0.36, 1.0))):  # fmt: skip
        s.beam_m(a, b, 0.04, body)
    s.box_m((0, -0.28, 0.93), (0.14, 0.26, 0.05), FRAME)  # saddle
    s.box_m((0, -0.675, 0.78), (0.14, 0.45, 0.02), FRAME)  # rear rack: the back
    s.beam_m((0, -0.8, 0.78), rear, 0.02, FRAME)
    s.box_m((0, 0.725, 0.82), (0.34, 0.35, 0.24), BASKET)  # front basket: the front
    s.beam_m((0, 0.37, 0.9), (0, 0.56, 0.9), 0.03, FRAME)
    s.beam_m((0, *HIP), (0, -0.05, 1.45), 0.34, JACKET)  # torso
    s.box_m((0, 0.0, 1.47), (0.2, 0.22, 0.23), palette.SKIN)  # head: the top
    for side in (-1.0, 1.0):
        s.beam_m((side * 0.17, -0.07, 1.41), (side * 0.26, 0.29, 1.02), 0.07, JACKET)


def _other(s: _Sculpt, body: Color) -> None:
    s.body.box((0, 0, 0), (1.0, 1.0, 1.0), body)


SCULPTORS = {"car": _car, "van": _van, "truck": _truck, "bus": _bus,
             "motorcycle": _motorcycle, "bicycle": _bicycle}  # fmt: skip


def body_color(kind: str, ego: bool) -> Color:
    body = palette.ACTOR_COLORS.get(kind, palette.ACTOR_COLORS["other"])
    if ego:
        r, g, b = (min(1.0, c * palette.EGO_TINT) for c in body[:3])
        body = (r, g, b, 1.0)
    return body


def prototype(kind: str, ego: bool) -> NodePath:
    """One kind's body (and glass) in the unit frame; an ego's a little brighter than an NPC's."""
    sculpt = _Sculpt(kind)
    SCULPTORS.get(kind, _other)(sculpt, body_color(kind, ego))
    return sculpt.node()


# ----------------------------------------------------------------- a two-wheeler's handlebar

# In metres at the kind's typical extent: the middle of the bar's bottom face and its size
# (across, along, up). It turns with the steer about its stem, a vertical axis through its
# middle, as the front wheel turns (`running_gear.Handlebar`); straight, it spans the width.
BARS: dict[str, tuple[Point3, Point3]] = {
    "motorcycle": ((0.0, 0.52, 1.05), (0.8, 0.04, 0.04)),  # with its mirrors
    "bicycle": ((0.0, 0.295, 1.0), (0.6, 0.03, 0.03)),
}


@dataclass(frozen=True, slots=True)
class BarPlace:
    """A handlebar of one actor, in metres in its frame (x right, y forward, z up)."""

    stem: Point3  # the middle of the bar's bottom face, on the axis it turns about
    size: Point3  # across, along, up


def bar_place(kind: str, size: Extent) -> BarPlace | None:
    """Where an actor of `kind` and extent `size` has its handlebar (None: it has none)."""
    bar = BARS.get(kind)
    if bar is None:
        return None
    t = KIND_EXTENTS[kind]
    k = (size.width / t.width, size.length / t.length, size.height / t.height)
    (x, y, z), (across, along, up) = bar
    return BarPlace((x * k[0], y * k[1], z * k[2]), (across * k[0], along * k[1], up * k[2]))


def bar_prototype() -> NodePath:
    """A unit box standing on the middle of its bottom face: each bar instances it, scaled."""
    mesh = MeshBuilder("handlebar")
    mesh.box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), FRAME)
    return NodePath(mesh.node())


# ----------------------------------------------------------------- a cyclist's legs


@dataclass(frozen=True, slots=True)
class LegGeometry:
    """A cyclist's legs for one bicycle extent, in metres in its frame (forward, up)."""

    hip: tuple[float, float]
    bottom_bracket: tuple[float, float]
    thigh_m: float
    shin_m: float
    crank_m: float
    hip_half_width_m: float
    thickness_m: float


THIGH_SHARE = 0.44 / 0.93  # of the leg (Drillis & Contini: thigh 0.245 H, shank 0.246 H + foot)
LEG_REACH = 1.039  # leg / farthest pedal distance: the knee a little bent at the bottom (~32°)


def leg_geometry(size: Extent) -> LegGeometry:
    """The rider's hips, the bottom bracket and the leg lengths for a bicycle of extent `size`."""
    t = KIND_EXTENTS["bicycle"]
    along, up = size.length / t.length, size.height / t.height
    hip = (HIP[0] * along, HIP[1] * up)
    bb = (BOTTOM_BRACKET[0] * along, BOTTOM_BRACKET[1] * up)
    crank = 0.17 * min(along, up)
    leg = LEG_REACH * (math.dist(hip, bb) + crank)
    side = HIP_HALF_WIDTH_M * size.width / t.width
    return LegGeometry(hip, bb, THIGH_SHARE * leg, (1 - THIGH_SHARE) * leg, crank, side,
                       0.11 * min(along, up))  # fmt: skip
