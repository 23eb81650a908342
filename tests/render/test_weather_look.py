"""Wet roads and rain in real rendered pixels, each checked against a physical statement.

The scenes and the hand-worked pinhole are those of test_light.py: a straight road along x,
nothing else, the eye placed so that the sample points follow from geometry alone.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse.render.cameras import Eye
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from tests.render.test_light import SHADED, H, W, config, level, road_map, shoot, weather
from tests.render.views import Pinhole, brightness

pytestmark = pytest.mark.usefixtures("offscreen_gl")


@pytest.mark.parametrize("quality", SHADED)
def test_a_wet_road_is_darker_seen_across(quality, save_shot) -> None:
    """Seen steeply (60° down) with the sun behind the eye, a road sends back its diffuse
    light only: water filling the pores of asphalt halves that (Lekner & Dorf 1988, Appl.
    Opt. 27), and at near-normal view water's own reflection is 2 % (Fresnel, n = 1.33)."""
    eye = Pinhole(0.0, 0.0, 6.0, 0.0, math.radians(60.0), W, H, math.radians(60))
    spot = (6.0 / math.tan(math.radians(60.0)), 0.0, 0.0)  # the road at the image's centre
    seen = {}
    for wetness in (0.0, 1.0):
        frame = SceneFrame(0.0, (), None, weather(40.0, 270.0, wetness=wetness))  # sun west
        img = shoot(quality, frame, eye, road_map(), fov_deg=60.0)
        save_shot(f"wet_across_{quality}_{wetness:g}", img)
        seen[wetness] = level(img, eye, spot, r=4)
    assert seen[1.0] < 0.85 * seen[0.0], seen


@pytest.mark.parametrize("quality", SHADED)
def test_a_wet_road_is_brighter_towards_a_low_sun(quality, save_shot) -> None:
    """Looking along the road towards a sun 10° high: the road's mirror point for the sun lies
    where the view ray meets it at 10°, h/tan 10° = 6.8 m ahead of an eye 1.2 m up. There and
    beyond, a grazing view, water reflects the bright low sky and the sun (Fresnel at 80° from
    the normal: ~35 % against asphalt's diffuse ~5 %), so the wet road is the brighter."""
    eye = Pinhole(0.0, 0.0, 1.2, 0.0, math.radians(8.0), W, H, math.radians(60))
    mirror = (1.2 / math.tan(math.radians(10.0)), 0.0, 0.0)
    seen = {}
    for wetness in (0.0, 1.0):
        frame = SceneFrame(0.0, (), None, weather(10.0, 90.0, wetness=wetness))  # sun east
        img = shoot(quality, frame, eye, road_map(), fov_deg=60.0)
        save_shot(f"wet_towards_{quality}_{wetness:g}", img)
        seen[wetness] = level(img, eye, mirror)
    assert seen[1.0] > 1.3 * seen[0.0], seen


@pytest.mark.parametrize("quality", SHADED)
def test_a_road_wets_when_the_weather_turns_wet(quality) -> None:
    """A dry day's surfaces are drawn by programs with the wetness compiled in as 0 (cheaper
    per vertex on llvmpipe): when the weather turns wet the renderer must change programs, so
    one that drew the dry frame first draws the wet frame as a renderer that never saw it dry
    does (the scene of the test above, where the wet road is the brighter)."""
    eye = Pinhole(0.0, 0.0, 1.2, 0.0, math.radians(8.0), W, H, math.radians(60))
    dry, wet = (SceneFrame(0.0, (), None, weather(10.0, 90.0, wetness=w)) for w in (0.0, 1.0))
    at = Eye(eye.x, eye.y, eye.z, eye.yaw, eye.pitch)
    with Renderer(config(quality, 60.0), road_map()) as r:
        r.draw(dry, eye=at)
        seen_dry = r.images()[0].astype(int)
        r.draw(wet, eye=at)
        turned = r.images()[0].astype(int)
    fresh = shoot(quality, wet, eye, road_map(), fov_deg=60.0).astype(int)
    assert np.abs(turned - fresh).max() <= 1
    mirror = (1.2 / math.tan(math.radians(10.0)), 0.0, 0.0)
    assert level(turned.astype(np.uint8), eye, mirror) > 1.3 * level(
        seen_dry.astype(np.uint8), eye, mirror
    )


def sky_half(quality: str, precipitation: float, t: float, save_shot) -> np.ndarray:
    """The sky above the horizon, looking north 15° up (away from the road and its street
    lights), clear but for rain: the rows above the horizon's (15° below the image's middle)."""
    eye = Eye(0.0, 0.0, 1.2, math.pi / 2, math.radians(-15.0))
    tan_v = math.tan(math.radians(45.0)) * H / W
    horizon_row = H / 2 * (1 + math.tan(math.radians(15.0)) / tan_v)
    frame = SceneFrame(t, (), None, weather(40.0, 200.0, precipitation=precipitation))
    with Renderer(config(quality), road_map()) as r:
        r.draw(frame, eye=eye)
        img = r.images()[0]
    save_shot(f"rain_{quality}_{precipitation:g}_{t:g}", img)
    return img[: int(horizon_row) - 8]


def fine_detail(img: np.ndarray) -> float:
    """Spread of brightness steps from a pixel to its right neighbour: a smooth sky (its
    gradient spans hundreds of pixels) scores near 0, thin streaks score high."""
    lum = brightness(img)
    return float(np.diff(lum, axis=1).std())


@pytest.mark.parametrize("quality", SHADED)
def test_rain_draws_streaks_against_the_sky(quality, save_shot) -> None:
    """Falling drops, each blurred over a frame's exposure into a streak a pixel or two wide,
    break up the smooth sky: its fine detail grows with rain (the haze rain adds only flattens
    the sky), and at another instant the streaks are elsewhere (drops fall 6.5 m/s: 0.65 m in
    0.1 s)."""
    dry = sky_half(quality, 0.0, 1.0, save_shot)
    wet = sky_half(quality, 0.8, 1.0, save_shot)
    later = sky_half(quality, 0.8, 1.1, save_shot)
    assert fine_detail(wet) > 2.5 * fine_detail(dry), (fine_detail(wet), fine_detail(dry))
    moved = np.abs(brightness(wet) - brightness(later)) > 4
    assert moved.sum() > 20  # streaks left and arrived
