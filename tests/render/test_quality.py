"""Quality presets: which one a config means, what each draws, and that each draws the same
frame the same way twice."""

from __future__ import annotations

import math

import numpy as np
import pytest
from panda3d.core import CardMaker

from carlaverse import messages as m
from carlaverse.config import ConfigError, convert
from carlaverse.recording.synthetic import synthetic_map
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import SceneFrame
from carlaverse.render.quality import PRESETS, is_software, resolve
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import RenderConfig
from tests.render.support import car
from tests.render.test_light import H, W, config, weather

LLVMPIPE = "llvmpipe (LLVM 15.0.6, 256 bits) / Mesa/X.org"
GPU = "NVIDIA H100 80GB HBM3/PCIe/SSE2 / NVIDIA Corporation"


def test_auto_takes_cpu_on_a_software_rasteriser_and_full_on_a_gpu() -> None:
    assert is_software(LLVMPIPE) and not is_software(GPU)
    assert resolve("auto", LLVMPIPE) is PRESETS["cpu"]
    assert resolve("auto", GPU) is PRESETS["full"]
    assert resolve("flat", GPU) is PRESETS["flat"]  # asked for by name: taken as asked


def test_the_config_names_a_quality_or_is_refused_with_the_field() -> None:
    assert convert({}, RenderConfig, "rig.yaml").quality == "auto"
    assert convert({"quality": "cpu"}, RenderConfig, "rig.yaml").quality == "cpu"
    with pytest.raises(ConfigError, match=r"quality"):
        convert({"quality": "ultra"}, RenderConfig, "rig.yaml")


def test_full_costs_more_than_cpu_which_costs_more_than_flat() -> None:
    """What each preset draws is ordered as its name promises (quality.py)."""
    full, cpu, flat = PRESETS["full"], PRESETS["cpu"], PRESETS["flat"]
    assert full.per_pixel and not cpu.per_pixel and not flat.shaded
    assert full.shadow_map_px > cpu.shadow_map_px > flat.shadow_map_px == 0
    assert full.multisamples > cpu.multisamples == flat.multisamples == 0
    assert full.headlights > cpu.headlights > flat.headlights == 0


@pytest.mark.usefixtures("offscreen_gl")
@pytest.mark.parametrize("quality", ["cpu", "full"])
def test_multisampling_blends_a_slanted_edge(quality, save_shot) -> None:
    """A white emissive card tilted 10° across a night sky: with k samples per pixel a pixel
    the edge crosses shows the covered share of white (full: 4×); with one sample (cpu) a
    pixel is all card or all sky. Pixels strictly between sky and card count the blends."""
    with Renderer(config(quality), None) as r:
        maker = CardMaker("card")
        maker.set_frame(-1.5, 1.5, 0.0, 2.0)  # [m] across, up: above the eye, against the sky
        card = r.world.attach_new_node(maker.generate())
        card.set_pos(0.0, 6.0, 1.4)
        card.set_r(10.0)
        card.set_light_off(1)  # emissive: its own colour, whatever the light
        card.set_color(1.0, 1.0, 1.0, 1.0)
        r.draw(SceneFrame(0.0, (), None, weather(-20.0)), eye=Eye(0.0, 0.0, 1.2, math.pi / 2))
        img = r.images()[0]
    save_shot(f"edge_{quality}", img)
    lum = img.astype(float).mean(axis=2)
    upper = lum[: H // 2]  # the card's top edge against the sky
    blends = int(((upper > 80) & (upper < 200)).sum())
    if quality == "full":
        assert blends > 10, blends
    else:
        assert blends <= 2, blends


@pytest.mark.usefixtures("offscreen_gl")
@pytest.mark.parametrize("quality", ["cpu", "full"])
def test_same_frame_same_pixels_by_night_in_rain(quality) -> None:
    """Rain, glare and headlights depend on the frame's render time and actors only, never on
    a clock or the order of earlier frames: two renderers draw the same frame identically."""
    me = car("me", -30.0, -1.75, ego=True, lights=m.LIGHT_LOW_BEAM)
    oncoming = car("n", -10.0, 1.75, yaw=math.pi, lights=m.LIGHT_LOW_BEAM)
    rain = weather(-20.0, precipitation=0.8, wetness=0.9, cloudiness=0.5)
    frame = SceneFrame(2.5, (me, oncoming), None, rain)
    images = []
    for _ in range(2):
        with Renderer(config(quality), synthetic_map()) as r:
            r.draw(frame, follow="me")
            images.append(r.images()[0])
    assert images[0].shape == (H, W, 3)
    assert np.array_equal(images[0], images[1])


@pytest.mark.usefixtures("offscreen_gl")
def test_the_cpu_lamps_own_program_draws_what_the_vehicles_program_did() -> None:
    """Lit per vertex, the vehicles' lamps get a program that only glows (the lighting is dead
    code there; llvmpipe ran it for every lamp vertex). A lamp is emissive either way, so the
    picture of a car's lit rear, by day and by a foggy night, is the one the vehicles' program
    draws for it (within a rounding)."""
    rear = car("c", 6.0, 0.0, lights=m.LIGHT_BRAKE | m.LIGHT_LOW_BEAM | m.LIGHT_LEFT_BLINKER)
    eye = Eye(0.0, 0.0, 1.0, 0.0, math.radians(5.0))
    for w in (weather(40.0), weather(-20.0, fog_density=0.3)):
        frame = SceneFrame(0.0, (rear,), None, w)
        with Renderer(config("cpu"), None) as r:
            assert r.actors.lamp_prototype.get_shader() is not None  # its own program
            r.draw(frame, eye=eye)
            own = r.images()[0].astype(int)
            r.actors.lamp_prototype.clear_shader()  # the vehicles' program, as before
            r.draw(frame, eye=eye)
            shared = r.images()[0].astype(int)
        assert np.abs(own - shared).max() <= 1
        assert (np.abs(own - background(w)).max(axis=-1) > 12).sum() > 50  # the car is seen


def background(w: m.Weather) -> np.ndarray:
    """The same view without the car."""
    with Renderer(config("cpu"), None) as r:
        r.draw(SceneFrame(0.0, (), None, w), eye=Eye(0.0, 0.0, 1.0, 0.0, math.radians(5.0)))
        return r.images()[0].astype(int)
