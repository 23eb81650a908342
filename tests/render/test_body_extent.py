"""Every road user stands on the road and fills exactly the box it declares, in real pixels.

The protocol gives an actor's size as a bounding box (`Extent`: length, width, height) whose
footprint is centred on the actor's position and whose bottom is the actor's z, the ground
(docs/protocol.md, NPC rows; `render/frame.py`). The collision check, the analysis footprints
and the CARLA bridge all use that box. So, independently of how a kind is modelled:

- the picture reaches the road: the lowest point of an unpitched vehicle lies at its z (a
  vehicle rests on its wheels, so that holds near the front and near the back alike);
- its silhouette is the box: seen from above it reaches ±length/2 and ±width/2 from its
  position, seen from the side its top is at its height — nothing beyond, nothing short.

Each edge is measured through the real renderer, whose rig camera is given an orthographic
lens zoomed onto that edge (a pixel row a small fraction of the tolerance), comparing a frame
with the actor to one without. The tolerances are the issue's: 1 cm for ground contact, 0.2 %
of the dimension for the silhouette, each widened by the quantisation (an edge is known to
±half a row). An edge more than half a view away from where the box puts it reads ±inf.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import ActorDraw, SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import HeadPosition, RenderConfig, Resolution, SimpleRig
from tests.render.support import changed

pytestmark = pytest.mark.usefixtures("offscreen_gl")

COLS, ROWS = 256, 128  # every view: the zoomed axis is the rows (image up)
# A silhouette is geometry, not light: in the shaded looks an actor's shadow on the ground
# changes pixels beside it too, so these views are drawn unshaded.
CONFIG = RenderConfig(
    output="offscreen",
    camera=SimpleRig(resolution=Resolution(width=COLS, height=ROWS), head=HeadPosition(z=0.0)),
    quality="flat",
)
CONTACT_TOL_M = 0.01  # the issue: ground contact within 1 cm
CONTACT_PITCH_M = 0.001  # 1 mm per pixel row near the road
SILHOUETTE_TOL = 0.002  # the issue: silhouette within 0.2 % of the extent
PITCH_FRACTION = 0.0005  # a zoomed row is 0.05 % of the dimension it measures
MARGIN_M = 0.3  # room beside the box along the unzoomed axis [m]
STANDOFF_M = 20.0  # camera distance from the edge it looks at [m]
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)

# Vehicles at the protocol's typical extents, and one at a recording's own (a long van), so
# the expectation comes from the actor's box and not from any kind's model.
VEHICLES = [k for k in m.ACTOR_KINDS if k not in ("pedestrian", "other")]
CASES = [(k, m.KIND_EXTENTS[k]) for k in VEHICLES] + [("van", m.Extent(6.3, 2.1, 2.7))]


@dataclass(frozen=True, slots=True)
class View:
    """An orthographic view whose image 'up' points along the direction it measures."""

    eye: Eye
    film_m: tuple[float, float]  # across (columns), along 'up' (rows) [m]

    @property
    def row_m(self) -> float:
        return self.film_m[1] / ROWS

    @property
    def col_m(self) -> float:
        return self.film_m[0] / COLS


@pytest.fixture(scope="module")
def renderer() -> Iterator[Renderer]:
    with Renderer(CONFIG, None) as r:
        yield r


def _shot(r: Renderer, actor: ActorDraw, view: View) -> np.ndarray:
    """Pixels the actor changes in `view` (rows top first, columns left first)."""
    from panda3d.core import OrthographicLens

    lens = OrthographicLens()
    lens.set_film_size(*view.film_m)
    lens.set_near_far(1.0, 2 * STANDOFF_M)
    r.rig.regions[0].get_camera().node().set_lens(lens)
    images = []
    for actors in ((actor,), ()):
        r.draw(SceneFrame(0.0, actors, None, NOON), eye=view.eye)
        images.append(r.images()[0])
    return changed(images[0], images[1], threshold=2)


def _reach_up(mask: np.ndarray, view: View) -> float:
    """How far above the view's centre the highest changed pixel reaches [m]."""
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return -math.inf  # nothing within half a film of where the edge should be
    if rows[0] == 0:
        return math.inf  # it goes on beyond the top of the view
    # row r spans [r, r + 1) from the top; the edge lies within half a row of its top
    return (ROWS / 2 - rows[0]) * view.row_m


def _top_view(actor: ActorDraw, turn: float, reach: float, across: float) -> View:
    """Looking down at the edge `reach` from the actor, `turn` left of its heading (image up)."""
    heading = actor.yaw + turn
    row_m = PITCH_FRACTION * 2 * reach
    x = actor.x + reach * math.cos(heading)
    y = actor.y + reach * math.sin(heading)
    eye = Eye(x, y, actor.z + STANDOFF_M, heading, pitch=math.pi / 2)
    return View(eye, (across + 2 * MARGIN_M, row_m * ROWS))


def _side_view(actor: ActorDraw, z: float, row_m: float, up: bool) -> View:
    """Looking level at the actor's left side, centred at height z; image up = +z or −z.

    The camera faces the actor's right, so image right is the actor's rear; rolled over
    (up = False) image right is its front.
    """
    left = actor.yaw + math.pi / 2
    x = actor.x + STANDOFF_M * math.cos(left)
    y = actor.y + STANDOFF_M * math.sin(left)
    eye = Eye(x, y, z, actor.yaw - math.pi / 2, roll=0.0 if up else math.pi)
    return View(eye, (actor.length + 2 * MARGIN_M, row_m * ROWS))


def _actor(kind: str, extent: m.Extent, yaw: float = 0.4) -> ActorDraw:
    # away from the origin, heading east-north-east: the placement is exercised, not assumed;
    # z = 0 is the road (the map-less scene's ground lies 2 cm below, out of the way)
    e = extent
    return ActorDraw("it", kind, 3.0, -2.0, 0.0, yaw, e.length, e.width, e.height)


@pytest.mark.parametrize(("kind", "extent"), CASES, ids=[f"{k}-{e.length:g}m" for k, e in CASES])
def test_silhouette_is_the_declared_box(renderer, kind, extent) -> None:
    actor = _actor(kind, extent)
    half_l, half_w = extent.length / 2, extent.width / 2
    edges = {  # name: (view, the reach the box declares)
        "front": (_top_view(actor, 0.0, half_l, extent.width), half_l),
        "rear": (_top_view(actor, math.pi, half_l, extent.width), half_l),
        "left": (_top_view(actor, math.pi / 2, half_w, extent.length), half_w),
        "right": (_top_view(actor, -math.pi / 2, half_w, extent.length), half_w),
    }
    top = _side_view(actor, actor.z + extent.height, PITCH_FRACTION * extent.height, up=True)
    reach = {name: d + _reach_up(_shot(renderer, actor, v), v) for name, (v, d) in edges.items()}
    height = extent.height + _reach_up(_shot(renderer, actor, top), top)
    measured = {
        "length": (reach["front"] + reach["rear"], extent.length, edges["front"][0].row_m),
        "width": (reach["left"] + reach["right"], extent.width, edges["left"][0].row_m),
        "height": (height, extent.height, top.row_m / 2),  # one edge: ±half a row
    }
    for name, (got, declared, pixel_m) in measured.items():
        assert abs(got - declared) <= SILHOUETTE_TOL * declared + pixel_m, (
            f"{kind}: drawn {name} {got:.4f} m, declared {declared:.4f} m "
            f"({(got / declared - 1) * 100:+.2f} %; edges {reach})"
        )


@pytest.mark.parametrize(("kind", "extent"), CASES, ids=[f"{k}-{e.length:g}m" for k, e in CASES])
def test_vehicle_stands_on_the_road_front_and_back(renderer, kind, extent) -> None:
    actor = _actor(kind, extent)
    # image up = −z: the reach of each column is how far below the road it goes (depth)
    view = _side_view(actor, actor.z, CONTACT_PITCH_M, up=False)
    mask = _shot(renderer, actor, view)
    # rolled over, column c looks at (c + ½ − COLS/2)·col_m ahead of the actor's position
    ahead = (np.arange(COLS) + 0.5 - COLS / 2) * view.col_m
    for half, cols in (("front", ahead > 0), ("rear", ahead < 0)):
        lowest = -_reach_up(mask[:, cols], view)  # [m] relative to the road (actor.z)
        assert abs(lowest) <= CONTACT_TOL_M + view.row_m / 2, (
            f"{kind}: the {half} half's lowest point is {lowest * 100:+.1f} cm from the road"
        )


@pytest.mark.parametrize(("kind", "extent"), CASES, ids=[f"{k}-{e.length:g}m" for k, e in CASES])
def test_scene_graph_bounds_are_the_declared_box(renderer, kind, extent) -> None:
    """The exact complement of the pixel tests: the drawn geometry's tight bounds."""
    actor = _actor(kind, extent, yaw=0.0)  # heading +x: the box is axis-aligned
    renderer.draw(SceneFrame(0.0, (actor,), None, NOON), eye=Eye(0.0, -30.0, 5.0, math.pi / 2))
    low, high = renderer.actors.root.get_tight_bounds()
    declared_low = (actor.x - extent.length / 2, actor.y - extent.width / 2, actor.z)
    declared_high = (
        actor.x + extent.length / 2,
        actor.y + extent.width / 2,
        actor.z + extent.height,
    )
    assert tuple(low) == pytest.approx(declared_low, abs=1e-4)
    assert tuple(high) == pytest.approx(declared_high, abs=1e-4)
