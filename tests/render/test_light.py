"""Sun, sky and night light in real rendered pixels, each checked against a physical statement.

Scenes are synthetic (a straight road, one car) and seen through a pinhole worked out by hand
(tests/render/views.py), so where a shadow, the sun or a pool of light must appear follows
from geometry alone. Each light is checked in both shaded presets: `cpu` lights per vertex,
`full` per pixel (quality.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import HeadPosition, RenderConfig, Resolution, SimpleRig
from carlaverse.render.street_lights import FIRST_M, SPACING_M
from tests.render.support import car
from tests.render.views import AT_EYE, Pinhole, brightness

pytestmark = pytest.mark.usefixtures("offscreen_gl")

W, H = 160, 120
SHADED = ("cpu", "full")
ROAD_M = 14.0  # [m] a road this wide under every sample point


def config(quality: str, fov_deg: float = 90.0, head: HeadPosition = AT_EYE) -> RenderConfig:
    camera = SimpleRig(resolution=Resolution(width=W, height=H), fov_deg=fov_deg, head=head)
    return RenderConfig(output="offscreen", camera=camera, quality=quality)


def road_map() -> m.MapReply:
    """One wide road along x (its own edge lines far from the samples), nothing else."""
    road = m.MapLane("R_0", "road", ROAD_M, [(-60.0, 0.0), (60.0, 0.0)])
    return m.MapReply(m.SCHEMA_VERSION, "light", (-60.0, -30.0, 60.0, 30.0), [road])


def weather(altitude: float, azimuth: float = 180.0, **kw: float) -> m.Weather:
    return m.Weather(0, 0.0, sun_altitude_deg=altitude, sun_azimuth_deg=azimuth, **kw)


def shoot(quality: str, frame: SceneFrame, eye: Pinhole, road: m.MapReply | None = None,
          fov_deg: float = 90.0) -> np.ndarray:  # fmt: skip
    with Renderer(config(quality, fov_deg), road) as r:
        r.draw(frame, eye=Eye(eye.x, eye.y, eye.z, eye.yaw, eye.pitch))
        return r.images()[0]


def level(img: np.ndarray, eye: Pinhole, p: tuple[float, float, float], r: int = 2) -> float:
    """Mean brightness of the (2r+1)² pixels around the projection of world point `p`."""
    col, row = eye.project(p)
    c, w = int(col), int(row)
    return float(brightness(img)[w - r : w + r + 1, c - r : c + r + 1].mean())


# Straight down from 16 m at the car, image up = north: the whole car and its surroundings.
ABOVE = Pinhole(0.0, 0.0, 16.0, math.pi / 2, math.pi / 2, W, H, math.radians(90))


@pytest.mark.parametrize("quality", SHADED)
def test_a_van_shades_the_road_on_the_side_away_from_the_sun(quality, save_shot) -> None:
    """A van (a box 5.2 × 2.0 × 2.3 m) heading east at the origin, the sun 30° high. Sunlight
    reaching the road 2 m behind its rear passes through the body when the sun is ahead (east):
    the shadow of a 2.3 m box reaches 2.3/tan 30° = 4.0 m beyond it. (From 16 m up the roof
    hides the road out to 2.6·16/(16 − 2.3) = 3.0 m from its middle, so the sample, 4.1–5.1 m
    out, sees the road.) The road there is lit by the sky alone, which under a clear sky at
    30° is well under half of what falls beside the van (sky and sun); with the sun behind
    (west) the same spot is in full sun and the shadow lies in front instead."""
    it = car("it", 0.0, 0.0, kind="van")
    behind, ahead = (-it.length / 2 - 2.0, 0.0, 0.0), (it.length / 2 + 2.0, 0.0, 0.0)
    beside = (0.0, it.width / 2 + 2.5, 0.0)  # north of it: the shadow falls along x only
    seen = {}
    for sun_from, azimuth in (("east", 90.0), ("west", 270.0)):
        img = shoot(quality, SceneFrame(0.0, (it,), None, weather(30.0, azimuth)), ABOVE,
                    road_map())  # fmt: skip
        save_shot(f"shadow_{quality}_sun_{sun_from}", img)
        seen[sun_from] = {k: level(img, ABOVE, p) for k, p in
                          (("behind", behind), ("ahead", ahead), ("beside", beside))}  # fmt: skip
    east, west = seen["east"], seen["west"]
    assert east["behind"] < 0.8 * east["beside"], east
    assert east["ahead"] > 0.9 * east["beside"], east
    assert west["ahead"] < 0.8 * west["beside"], west
    assert west["behind"] > 0.9 * west["beside"], west


# From 1.2 m above the origin, turned to look 25° up along a compass bearing.
def looking_up(bearing_deg: float) -> Pinhole:
    return Pinhole(0.0, 0.0, 1.2, math.radians(90.0 - bearing_deg), math.radians(-25.0), W, H,
                   math.radians(90))  # fmt: skip


@pytest.mark.parametrize("quality", SHADED)
@pytest.mark.parametrize(
    ("altitude", "azimuth", "bearing"), [(20.0, 60.0, 40.0), (35.0, 200.0, 215.0)]
)
def test_the_sun_stands_where_the_weather_puts_it(quality, altitude, azimuth, bearing,
                                                   save_shot) -> None:  # fmt: skip
    """The brightest pixel of the sky is the sun's disc, at the direction the weather gives:
    altitude above the horizon, azimuth a compass bearing (0 north = +y, 90 east = +x). Its
    pixel is found by projecting that direction through the pinhole, never by the renderer."""
    eye = looking_up(bearing)
    img = shoot(quality, SceneFrame(0.0, (), None, weather(altitude, azimuth)), eye)
    save_shot(f"sun_{quality}_{altitude:g}_{azimuth:g}", img)
    alt, az = math.radians(altitude), math.radians(azimuth)
    far = 1000.0  # [m] a point along the direction: the sun is at infinity, parallax nil
    sun = (far * math.sin(az) * math.cos(alt), far * math.cos(az) * math.cos(alt),
           eye.z + far * math.sin(alt))  # fmt: skip
    col, row = eye.project(sun)
    assert 5 < col < W - 5 and 5 < row < H - 5  # the view was chosen to hold it
    lum = brightness(img)
    r, c = np.unravel_index(np.argmax(lum), lum.shape)
    assert lum[r, c] > 250  # the disc saturates to white
    assert abs(c + 0.5 - col) < 2.0 and abs(r + 0.5 - row) < 2.0, ((c, r), (col, row))


def sky_colour(img: np.ndarray, eye: Pinhole, bearing_deg: float, up_deg: float) -> np.ndarray:
    b, u = math.radians(bearing_deg), math.radians(up_deg)
    far = 1000.0
    p = (far * math.sin(b) * math.cos(u), far * math.cos(b) * math.cos(u),
         eye.z + far * math.sin(u))  # fmt: skip
    col, row = eye.project(p)
    return img[int(row) - 1 : int(row) + 2, int(col) - 1 : int(col) + 2].reshape(-1, 3).mean(0)


@pytest.mark.parametrize("quality", SHADED)
def test_the_sky_near_a_low_sun_turns_red(quality, save_shot) -> None:
    """Rayleigh scattering goes as λ⁻⁴: along the ~40 air masses of a sun 1° high the blue of
    its light is scattered away long before the red, so the sky around it is red-orange,
    while around a sun 40° high (1.6 air masses) it stays blue-white. Sampled 8° beside the
    sun's bearing, 4° above the horizon (off the disc)."""
    eye = Pinhole(0.0, 0.0, 1.2, math.radians(90.0 - 180.0), math.radians(-10.0), W, H,
                  math.radians(90))  # fmt: skip
    ratio = {}
    for name, altitude in (("dusk", 1.0), ("day", 40.0)):
        img = shoot(quality, SceneFrame(0.0, (), None, weather(altitude, 180.0)), eye)
        save_shot(f"sky_{quality}_{name}", img)
        r, _, b = sky_colour(img, eye, 188.0, 4.0)
        ratio[name] = r / max(b, 1.0)
    assert ratio["dusk"] > 1.0 and ratio["dusk"] > 1.5 * ratio["day"], ratio


@pytest.mark.parametrize("quality", SHADED)
def test_night_is_darker_than_day(quality, save_shot) -> None:
    """The same street with the sun 45° up and 20° below the horizon: without the sun, lit by a
    town's sky glow and its street lights, the scene's light falls by orders of magnitude
    (100 klux to some 10 lux). An eye (or camera) adapts only partly, so the picture must
    still be far darker: under half as bright."""
    eye = Pinhole(-20.0, -4.0, 1.2, 0.0, math.radians(5.0), W, H, math.radians(90))
    mean = {}
    for name, altitude in (("day", 45.0), ("night", -20.0)):
        img = shoot(quality, SceneFrame(0.0, (), None, weather(altitude)), eye, road_map())
        save_shot(f"street_{quality}_{name}", img)
        mean[name] = float(brightness(img).mean())
    assert mean["night"] < mean["day"] / 2, mean


# Behind and above the car, looking along the road it faces (east).
CHASE = Pinhole(-9.0, 0.0, 3.0, 0.0, math.radians(12.0), W, H, math.radians(90))


@pytest.mark.parametrize("quality", SHADED)
def test_headlights_light_the_road_ahead_at_night(quality, save_shot) -> None:
    """A car at the origin facing east, night (sun 20° below the horizon). Its dipped beams
    (LIGHT_LOW_BEAM) light the road ahead of it: 12 m ahead the road must be brighter with
    them on than off; 5 m behind it, where a headlamp sends nothing, it must not change."""
    ahead, behind = (12.0, 0.0, 0.0), (-5.0, 0.0, 0.0)
    seen = {}
    for name, bits in (("off", 0), ("on", m.LIGHT_LOW_BEAM)):
        it = car("it", 0.0, 0.0, lights=bits)
        img = shoot(quality, SceneFrame(0.0, (it,), None, weather(-20.0)), CHASE, road_map())
        save_shot(f"headlights_{quality}_{name}", img)
        seen[name] = (level(img, CHASE, ahead), level(img, CHASE, behind))
    (off_ahead, off_behind), (on_ahead, on_behind) = seen["off"], seen["on"]
    assert on_ahead > 1.5 * off_ahead and on_ahead > off_ahead + 10, seen
    assert abs(on_behind - off_behind) < 3, seen


DRIVER = HeadPosition(x=0.0, y=0.4, z=1.2)  # [m] a driver's eye in the car frame


@pytest.mark.parametrize("quality", SHADED)
def test_the_camera_car_lights_its_own_road(quality, save_shot) -> None:
    """Riding in the car (the camera follows it, its body hidden), its own beams still light
    the road in front of the driver: 12 m ahead of the car, seen from the driver's eye."""
    eye = Pinhole(DRIVER.x, DRIVER.y, DRIVER.z, 0.0, 0.0, W, H, math.radians(90))
    seen = {}
    for name, bits in (("off", 0), ("on", m.LIGHT_LOW_BEAM)):
        me = car("me", 0.0, 0.0, lights=bits, ego=True)
        with Renderer(config(quality, head=DRIVER), road_map()) as r:
            r.draw(SceneFrame(0.0, (me,), None, weather(-20.0)), follow="me")
            img = r.images()[0]
        save_shot(f"own_beams_{quality}_{name}", img)
        seen[name] = level(img, eye, (12.0, 0.0, 0.0))
    assert seen["on"] > 1.5 * seen["off"] and seen["on"] > seen["off"] + 10, seen


@pytest.mark.parametrize("quality", SHADED)
def test_street_lights_pool_on_the_road_at_night_only(quality, save_shot) -> None:
    """Street lights stand beside an edge's rightmost lane (index 0), every SPACING_M from
    FIRST_M after its start (street_lights.py): on lane R_0, which starts at x = −60, at
    x = −50, −18, 14, 46, their lamps LAMP_HEIGHT_M up over the lane's right edge. Under the
    lamp at x = 14 the road gets I/h²; midway to the next (x = 30, 16 m from both) twice
    I·h/(h² + 16²)^{3/2}, 6.5 times less. By day (the sun in the north, so the poles' shadows
    fall off the road) the lamps are off and both spots equal, but for the asphalt's grain."""
    lamp_x = -60.0 + FIRST_M + SPACING_M * 2  # 14 m
    y = -ROAD_M / 2 + 1.0  # [m] a metre inside the lane's right edge
    eye = Pinhole(lamp_x + SPACING_M / 4, 0.0, 20.0, math.pi / 2, math.pi / 2, W, H,
                  math.radians(90))  # fmt: skip
    seen = {}
    for name, altitude in (("day", 45.0), ("night", -20.0)):
        img = shoot(quality, SceneFrame(0.0, (), None, weather(altitude, 0.0)), eye, road_map())
        save_shot(f"street_lights_{quality}_{name}", img)
        under, mid = (level(img, eye, (x, y, 0.0)) for x in (lamp_x, lamp_x + SPACING_M / 2))
        seen[name] = (under, mid)
    (day_under, day_mid), (night_under, night_mid) = seen["day"], seen["night"]
    assert night_under > 1.5 * night_mid and night_under > night_mid + 10, seen
    assert abs(day_under - day_mid) < 0.1 * day_mid, seen


def building_map() -> m.MapReply:
    """A road, and north of it one building 30 m long, 12 m deep (its facade faces the road)."""
    road = m.MapLane("R_0", "road", 7.0, [(-60.0, 0.0), (60.0, 0.0)])
    house = m.MapArea("house", "building", [(-15.0, 12.0), (15.0, 12.0), (15.0, 24.0),
                                            (-15.0, 24.0)])  # fmt: skip
    return m.MapReply(m.SCHEMA_VERSION, "windows", (-60.0, -30.0, 60.0, 40.0), [road], [house])


@pytest.mark.parametrize("quality", SHADED)
def test_windows_light_up_at_night(quality, save_shot) -> None:
    """Facades carry their lit windows on an emission stage (scene_buildings.py): by night a
    share of the windows glows warm, far brighter than the unlit wall around them; by day
    (sun 45° high behind the eye) nothing on the facade is much brighter than the wall."""
    eye = Pinhole(0.0, -8.0, 6.0, math.pi / 2, math.radians(-8.0), W, H, math.radians(90))
    glowing = {}
    for name, altitude in (("day", 45.0), ("night", -20.0)):
        frame = SceneFrame(0.0, (), None, weather(altitude, 180.0))
        img = shoot(quality, frame, eye, building_map())
        save_shot(f"windows_{quality}_{name}", img)
        top, bottom = (int(eye.project((0.0, 12.0, z))[1]) for z in (15.0, 1.0))
        facade = img[max(top, 0) : bottom].astype(int)
        lum = facade.mean(axis=2)
        warm = facade[..., 0] > facade[..., 2] + 40
        glowing[name] = int(((lum > 2.5 * np.median(lum)) & warm).sum())
    assert glowing["night"] > 30 and glowing["day"] == 0, glowing
