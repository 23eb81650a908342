"""Road users in real pixels: wheels under every body that roll and steer, lamps that light and
blink on the right side, walkers whose legs part with speed, cyclists whose legs pedal.

Each expectation comes from a physical or documented statement, measured through the real
renderer (offscreen) with an orthographic camera where a length is read off the picture:

- only the tyres touch the road: under a vehicle's body there is road clearance (cars
  0.12–0.2 m; a bicycle's pedal passes ~0.1 m above the road), and the axles lie near its ends
  (wheelbase / length: car 2.64/4.28 = 0.62, van 3.4/5.2 = 0.65, truck 5.4–6.0/9 ≈ 0.63, city
  bus 6/12 = 0.5, motorcycle 1.4/2.1 = 0.67, bicycle 1.0/1.8 = 0.56);
- a wheel rolling without slip turns by s / r; a steered vehicle's front wheels point along
  δ, and a vehicle turning at yaw rate ω at speed v without slip steers δ = atan(L·ω / v)
  (kinematic bicycle model, L the wheelbase);
- brake lamps outshine tail lamps (UN ECE R7: stop lamp 60–185 cd, rear position 4–17 cd);
  an indicator flashes 90 ± 30 times a minute (UN ECE R48), on the side it signals;
- a walker's feet are a step apart at double support (Perry & Burnfield: 0.71 m at 1.37 m/s)
  and together standing;
- a bicycle's crank turns once per 2π·r·G of road (r the wheel's radius, G the gear ratio).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import ActorDraw, SceneFrame
from carlaverse.render.gait import GEAR_RATIO
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import HeadPosition, RenderConfig, Resolution, SimpleRig
from tests.render.support import changed

pytestmark = pytest.mark.usefixtures("offscreen_gl")

COLS, ROWS = 320, 240
CONFIG = RenderConfig(
    output="offscreen",
    camera=SimpleRig(resolution=Resolution(width=COLS, height=ROWS), head=HeadPosition(z=0.0)),
)
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)
VEHICLES = ["car", "van", "truck", "bus", "motorcycle", "bicycle"]
STANDOFF_M = 20.0


@pytest.fixture(scope="module")
def renderer() -> Iterator[Renderer]:
    with Renderer(CONFIG, None) as r:
        yield r


def vehicle(kind: str, x: float = 0.0, yaw: float = 0.0, actor_id: str = "it",
            **extra: object) -> ActorDraw:  # fmt: skip
    e = m.KIND_EXTENTS[kind]
    return ActorDraw(actor_id, kind, x, 0.0, 0.0, yaw, e.length, e.width, e.height, **extra)


def ortho(r: Renderer, film: tuple[float, float]) -> None:
    """Give the rig's camera an orthographic lens of `film` (across, up) [m]."""
    from panda3d.core import OrthographicLens

    lens = OrthographicLens()
    lens.set_film_size(*film)
    lens.set_near_far(0.5, 2 * STANDOFF_M)
    r.rig.regions[0].get_camera().node().set_lens(lens)


def shot(r: Renderer, actors: tuple[ActorDraw, ...], eye: Eye, t: float = 0.0) -> np.ndarray:
    r.draw(SceneFrame(t, actors, None, NOON), eye=eye)
    return r.images()[0]


def from_left(a: ActorDraw, z: float) -> Eye:
    """Level, from the actor's left side, at height z: image right is the actor's rear."""
    left = a.yaw + math.pi / 2
    return Eye(a.x + STANDOFF_M * math.cos(left), a.y + STANDOFF_M * math.sin(left), z,
               a.yaw - math.pi / 2)  # fmt: skip


def dark(img: np.ndarray, limit: int = 60) -> np.ndarray:
    return img.max(axis=2) < limit


# ----------------------------------------------------------------- wheels


@pytest.mark.parametrize("kind", VEHICLES)
def test_wheels_touch_the_road_near_both_ends_with_clearance_between(renderer, kind) -> None:
    a = vehicle(kind)
    film = (a.length + 2.0, ROWS * 0.005)  # 5 mm rows, centred 0.3 m up
    ortho(renderer, film)
    eye = from_left(a, 0.3)
    img = shot(renderer, (a,), eye)
    mask = changed(img, shot(renderer, (), eye)) & dark(img)
    z = 0.3 + (ROWS / 2 - np.arange(ROWS) - 0.5) * 0.005  # [m] each row's height
    band = mask[(z > 0.01) & (z < 0.04)]  # below any body, pedal or crank
    along = -(np.arange(COLS) + 0.5 - COLS / 2) * film[0] / COLS  # image right: the rear
    columns = band.any(axis=0)
    for name, lo, hi in (("front", 0.2, 0.4), ("rear", -0.4, -0.2)):
        part = (along > lo * a.length) & (along < hi * a.length)
        assert columns[part].any(), f"{kind}: no tyre on the road at the {name}"
    middle = np.abs(along) < 0.12 * a.length
    assert not columns[middle].any(), f"{kind}: something touches the road between the axles"


def _blob_angle(mask: np.ndarray) -> float:
    """[deg] the principal axis of a blob from the image's vertical, top to the right positive."""
    rows, cols = np.nonzero(mask)
    x, y = cols - cols.mean(), -(rows - rows.mean())
    values, vectors = np.linalg.eigh(np.cov(np.vstack([x, y])))
    major = vectors[:, np.argmax(values)]
    angle = math.degrees(math.atan2(major[0], major[1]))
    return (angle + 90.0) % 180.0 - 90.0


FILM_BELOW_M = 6.0  # [m] the view from below, top to bottom


def _wheels_from_below(r: Renderer, a: ActorDraw) -> dict[str, tuple[float, tuple[float, float]]]:
    """Angle and centroid (col, row) of each wheel's dark footprint, looking up from below.

    From below, with the camera's up along the actor's rear (Eye pitch −90° turns Panda's
    camera up through the heading), image right is the actor's right: the front wheels are in
    the lower half. A wheel pointing δ to the left of the heading, (cos δ, sin δ) in (forward,
    left), is the image direction (right, up) = (−sin δ, −cos δ): an axis whose top leans right
    by δ. So a left steer reads as a positive angle.
    """
    ortho(r, (FILM_BELOW_M * COLS / ROWS, FILM_BELOW_M))  # square pixels
    eye = Eye(a.x, a.y, -3.0, a.yaw, pitch=-math.pi / 2)
    img = shot(r, (a,), eye)
    tyres = dark(img, 50) & changed(img, shot(r, (), eye))
    h, w = tyres.shape
    out = {}
    for name, rows, cols in (("rear_right", slice(0, h // 2), slice(w // 2, w)),
                             ("front_right", slice(h // 2, h), slice(w // 2, w)),
                             ("front_left", slice(h // 2, h), slice(0, w // 2))):  # fmt: skip
        part = np.zeros_like(tyres)
        part[rows, cols] = tyres[rows, cols]
        assert part.sum() > 50, f"no {name} wheel seen from below"
        rr, cc = np.nonzero(part)
        out[name] = (_blob_angle(part), (cc.mean(), rr.mean()))
    return out


def test_front_wheels_turn_by_the_steer_angle_sent(renderer) -> None:
    wheels = _wheels_from_below(renderer, vehicle("car", steer=math.radians(20.0)))
    assert wheels["front_left"][0] == pytest.approx(20.0, abs=2.0)
    assert wheels["front_right"][0] == pytest.approx(20.0, abs=2.0)
    assert wheels["rear_right"][0] == pytest.approx(0.0, abs=1.0)
    straight = _wheels_from_below(renderer, vehicle("car", steer=0.0, actor_id="straight"))
    assert straight["front_left"][0] == pytest.approx(0.0, abs=1.0)


@pytest.mark.parametrize(("yaw_rate", "speed"), [(0.5, 6.0), (-0.3, 4.0), (0.2, -2.0)])
def test_front_wheels_steer_from_yaw_rate_and_speed(renderer, yaw_rate, speed) -> None:
    """No steer sent (an NPC row): δ = atan(L·ω/v), L measured between the wheels' centres."""
    a = vehicle("car", yaw_rate=yaw_rate, speed=speed, actor_id=f"npc{yaw_rate}")
    wheels = _wheels_from_below(renderer, a)
    px_m = FILM_BELOW_M / ROWS
    wheelbase = abs(wheels["front_right"][1][1] - wheels["rear_right"][1][1]) * px_m
    expected = math.degrees(math.atan(wheelbase * yaw_rate / speed))
    assert wheels["front_left"][0] == pytest.approx(expected, abs=2.0), wheelbase


def _sample_rotated(img: np.ndarray, center: tuple[float, float], radius: float,
                    angle: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Pixels inside the disc, and the pixels found `angle` [rad] clockwise from each on screen
    (where a picture turned counter-clockwise by `angle` brought them)."""
    cx, cy = center
    rows, cols = np.mgrid[0 : img.shape[0], 0 : img.shape[1]]
    x, y = cols - cx, -(rows - cy)  # y up
    inside = np.hypot(x, y) < radius
    c, s = math.cos(-angle), math.sin(-angle)
    sx, sy = c * x[inside] - s * y[inside], s * x[inside] + c * y[inside]
    src_c = np.clip(np.rint(sx + cx).astype(int), 0, img.shape[1] - 1)
    src_r = np.clip(np.rint(cy - sy).astype(int), 0, img.shape[0] - 1)
    return img[inside], img[src_r, src_c]


def test_wheels_roll_by_distance_over_radius(renderer) -> None:
    """A side view riding along with the car: after it rolls s, the front wheel's picture is
    the first picture turned by s/r counter-clockwise (seen from the left, forward is image
    left: the top of a rolling wheel moves forward, its contact point is still)."""
    ortho(renderer, (3.2, 2.4))  # 1 cm pixels
    frames = []
    for x in (0.0, 0.12):
        a = vehicle("car", x=x, actor_id="roller")
        eye = from_left(vehicle("car", x=a.x + 1.35), 0.6)  # centred above the front axle
        frames.append(shot(renderer, (a,), eye, t=x))
    z = 0.6 + (ROWS / 2 - np.arange(ROWS) - 0.5) * 0.01  # [m] each row's height
    wheel = dark(frames[0]) & (z < 0.7)[:, None]  # the tyre and the rim's windows, not glass
    rows, cols = np.nonzero(wheel[:, COLS // 4 : 3 * COLS // 4])
    cols = cols + COLS // 4
    radius_px = (rows.max() - rows.min() + 1) / 2
    center = ((cols.min() + cols.max() + 1) / 2 - 0.5, (rows.min() + rows.max() + 1) / 2 - 0.5)
    rolled = 0.12 / (radius_px * 0.01)  # [rad] s / r with r as drawn
    gray = [f.astype(float).mean(axis=2) for f in frames]

    def misfit(angle: float) -> float:
        _, before = _sample_rotated(gray[0], center, 0.8 * radius_px, angle)
        after, _ = _sample_rotated(gray[1], center, 0.8 * radius_px, 0.0)
        return float(np.abs(after - before).mean())

    scan = {round(math.degrees(k), 1): misfit(k) for k in np.radians(np.arange(-34, 35, 1.0))}
    best = min(scan, key=scan.__getitem__)
    assert best == pytest.approx(math.degrees(rolled), abs=2.0), (best, math.degrees(rolled))
    assert scan[best] < 0.3 * scan[0.0]


# ----------------------------------------------------------------- lamps


def _from_behind(r: Renderer, a: ActorDraw, t: float) -> np.ndarray:
    r.rig.regions[0].get_camera().node().set_lens(_perspective())
    eye = Eye(a.x - 7.0, a.y, 1.0, a.yaw)
    return shot(r, (a,), eye, t)


def _perspective():  # a Panda3D lens
    from panda3d.core import PerspectiveLens

    lens = PerspectiveLens()
    lens.set_fov(40.0, 30.0)
    lens.set_near_far(0.1, 100.0)
    return lens


def _brightness(img: np.ndarray, mask: np.ndarray) -> float:
    return float(img[mask].astype(float).sum())


def test_brake_lamps_outshine_tail_lamps_which_outshine_unlit(renderer) -> None:
    shots = {name: _from_behind(renderer, vehicle("car", lights=bits), 0.0)
             for name, bits in (("off", 0), ("tail", m.LIGHT_LOW_BEAM), ("brake", m.LIGHT_BRAKE),
                                ("both", m.LIGHT_BRAKE | m.LIGHT_LOW_BEAM))}  # fmt: skip
    lamps = changed(shots["brake"], shots["off"])
    assert lamps.sum() > 10, "the brake bit lights nothing"
    cols = np.nonzero(lamps)[1]
    assert cols.min() < COLS / 2 < cols.max(), "a stop lamp on each side"
    seen = {name: _brightness(img, lamps) for name, img in shots.items()}
    assert seen["brake"] > seen["tail"] > seen["off"], seen
    assert seen["both"] == pytest.approx(seen["brake"], rel=0.05)  # the stop lamp dominates


@pytest.mark.parametrize(("bit", "side"), [(m.LIGHT_LEFT_BLINKER, "left"),
                                           (m.LIGHT_RIGHT_BLINKER, "right")])  # fmt: skip
def test_an_indicator_blinks_on_its_own_side(renderer, bit, side) -> None:
    """Seen from behind along the heading, the car's left is the image's left. At 1.5 Hz
    (90 flashes a minute) with half the period lit, t = 0.1 s is lit and 0.45 s dark."""
    car = vehicle("car", lights=bit)
    lit, dark_ = (_from_behind(renderer, car, t) for t in (0.1, 0.45))
    blink = changed(lit, dark_)
    assert blink.sum() >= 6, "nothing blinks"
    cols = np.nonzero(blink)[1]
    if side == "left":
        assert cols.max() < COLS / 2, cols
    else:
        assert cols.min() > COLS / 2, cols
    r, g, b = (lit[blink][:, k].astype(float).mean() for k in range(3))
    assert r > 150 and r > b + 80 and g > b, (r, g, b)  # amber
    steady = _from_behind(renderer, vehicle("car"), 0.1)
    assert changed(dark_, steady).sum() < 4  # dark half-period: as with the indicator off


# ----------------------------------------------------------------- walkers and cyclists


def _walker(x: float, speed: float) -> ActorDraw:
    e = m.KIND_EXTENTS["pedestrian"]
    return ActorDraw("walker", "pedestrian", x, 0.0, 0.0, 0.0, e.length, e.width, e.height,
                     speed=speed)  # fmt: skip


def _feet_spread(r: Renderer, speed: float, frames: int = 24, dt: float = 0.05) -> list[float]:
    """[m] how far apart the walker's lower legs reach, frame by frame, seen from the side
    by a camera that walks along."""
    spreads = []
    z = 1.0 + (ROWS / 2 - np.arange(ROWS) - 0.5) * 0.01  # [m] each row's height
    ortho(r, (3.2, 2.4))
    # the level camera sees the map-less ground edge-on: the empty view is the same all along
    empty = shot(r, (), from_left(_walker(0.0, speed), 1.0))
    for k in range(frames):
        a = _walker(speed * dt * k, speed)
        img = shot(r, (a,), from_left(a, 1.0), t=dt * k)
        low = changed(img, empty)[(z > 0.03) & (z < 0.3)]
        cols = np.nonzero(low.any(axis=0))[0]
        spreads.append((cols.max() - cols.min() + 1) * 0.01 if cols.size else 0.0)
    return spreads


def test_walkers_legs_part_mid_stride_and_stand_together_at_rest(renderer) -> None:
    """Over a second at 1.4 m/s (a stride of ~1.4 m takes ~1 s) the feet are a step apart at
    double support: below 0.3 m the legs reach at least 0.45 m apart (0.71 m less the legs'
    convergence towards the hip, (1 − 0.3/0.93) of it). Standing, one leg hides the other:
    no wider than a leg and a bit, 0.2 m."""
    walking = _feet_spread(renderer, 1.4)
    standing = _feet_spread(renderer, 0.0)
    assert max(walking) >= 0.45, walking
    assert max(standing) <= 0.2, standing


def _legs(img: np.ndarray) -> np.ndarray:
    """Between the wheels (their inner edges are 0.16 m either side of the middle) and over the
    road: the legs and cranks, and the frame, which does not move."""
    along = -(np.arange(COLS) + 0.5 - COLS / 2) * 0.01
    z = 0.6 + (ROWS / 2 - np.arange(ROWS) - 0.5) * 0.01
    return img[(z > 0.08) & (z < 0.95)][:, np.abs(along) < 0.13].astype(int)


def test_a_cyclist_pedals_once_per_development(renderer) -> None:
    """The crank turns once per 2π·r·G of road: a 700C wheel (ETRTO 622 bead + 28 mm tyre:
    r = 0.339 m) with the city gear G = 42/20. After that distance the legs are where they
    started; a quarter of it later they are not. The camera rides along at 5 m/s."""
    development = 2 * math.pi * 0.339 * GEAR_RATIO
    assert pytest.approx(42 / 20) == GEAR_RATIO
    steps = 40
    crops = {}
    ortho(renderer, (3.2, 2.4))
    for k in range(steps + 1):
        x = development * k / steps
        a = vehicle("bicycle", x=x, speed=5.0, actor_id="cyclist")
        crops[k] = _legs(shot(renderer, (a,), from_left(a, 0.6), t=x / 5.0))

    def moved(k: int) -> float:
        return float((np.abs(crops[k] - crops[0]) > 24).any(axis=-1).mean())

    assert moved(steps // 4) > 0.05, moved(steps // 4)
    assert moved(steps) < 0.1 * moved(steps // 4), (moved(steps), moved(steps // 4))
