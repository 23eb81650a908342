"""Pixels from the real renderer (offscreen): where things appear and what colour they are."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.recording.synthetic import synthetic_map
from carlaverse.render.frame import SceneFrame, frame_from_view, npc_attributes
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import (
    HeadPosition,
    PhysicalRig,
    RenderConfig,
    Resolution,
    SimpleRig,
    layout,
    project_column,
)
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.world_view import WorldView
from tests.render.support import car, changed, footprint, green, head_frame, red, yellow

pytestmark = pytest.mark.usefixtures("offscreen_gl")

SMALL = Resolution(width=320, height=180)
HEAD = HeadPosition(x=0.0, y=0.0, z=1.2)
SIMPLE = RenderConfig(output="offscreen", camera=SimpleRig(resolution=SMALL, fov_deg=90, head=HEAD))
THREE = RenderConfig(
    output="offscreen",
    camera=PhysicalRig(
        displays=3, resolution=SMALL, display_width_m=0.6, bezel_m=0.02, distance_m=0.7, head=HEAD
    ),
)
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)


def _view_with(npcs: np.ndarray, ids: list[str]) -> WorldView:
    """A real world view holding our ego 'me' at the origin and one NPC batch."""
    view = WorldView("render", InterpolationSettings())
    view.intake.present("me")
    view.intake.pose("me", m.encode_pose(m.Pose(1, 0.0, 0.0, 0.0)), rx_t=0.0)
    view.intake.npc(m.NpcBatch.pack(1, 0.0, ids, npcs), rx_t=0.0)
    view.intake.weather(NOON)
    view.update(0.0)
    return view


@pytest.mark.parametrize(
    ("rig", "camera", "x", "y", "yaw"),
    [
        (SIMPLE, 0, 25.0, 4.0, 0.3),
        (SIMPLE, 0, 14.0, -6.0, -1.2),
        (THREE, 0, 18.0, 16.0, 2.0),
        (THREE, 2, 10.0, -12.0, 0.7),
    ],
)
def test_npc_appears_at_the_predicted_column(rig, camera, x, y, yaw, save_shot) -> None:
    rows = np.zeros(1, dtype=m.NPC_DTYPE)
    rows[0]["x"], rows[0]["y"], rows[0]["yaw"] = x, y, yaw
    rows[0]["length"], rows[0]["width"], rows[0]["height"] = 4.5, 1.8, 1.5
    batch = m.NpcBatch.pack(1, 0.0, ["npc-1"], rows)
    extents, lamps = npc_attributes(batch)
    # Camera maths, not light: in the shaded looks the NPC's shadow on the ground changes
    # pixels too (beside it, where the sun sends it), so the silhouette is drawn unshaded.
    rig = msgspec.structs.replace(rig, quality="flat")
    with Renderer(rig, None) as r:
        view = _view_with(rows, ["npc-1"])
        frame = frame_from_view(view, 0.0, extents=extents, npc_lights=lamps)
        assert {a.actor_id for a in frame.actors} == {"me", "npc-1"}
        r.draw(frame, follow="me")
        with_npc = r.camera_images()[camera]
        r.draw(SceneFrame(0.0, (frame.actor("me"),), None, NOON), follow="me")
        without = r.camera_images()[camera]
    save_shot(f"npc_column_{camera}_{x:g}_{y:g}", with_npc)
    cols = np.flatnonzero(changed(with_npc, without).any(axis=0))
    assert cols.size, "the NPC is not in the picture"
    cam = layout(rig.camera).cameras[camera]
    eye, npc = frame.actor("me"), frame.actor("npc-1")
    predicted = [project_column(cam, *head_frame(eye, HEAD, p)) for p in footprint(npc)]
    # pixel c covers columns [c, c + 1): the outermost lit pixels straddle the predicted edges
    assert cols.min() == pytest.approx(min(predicted), abs=2.0)
    assert cols.max() + 1 == pytest.approx(max(predicted), abs=2.0)


@pytest.mark.parametrize(
    ("state", "lit", "dark"), [("rrrr", red, green), ("GGGG", green, red), ("yyyy", yellow, green)]
)
def test_light_colour_follows_its_state(state, lit, dark, save_shot) -> None:
    eye = car("me", -30.0, -1.75, ego=True)
    lights = m.LightsState(1, 0.0, [m.TrafficLight("J0", state, 0, 3.0)])
    with Renderer(SIMPLE, synthetic_map()) as r:
        r.draw(SceneFrame(0.0, (eye,), lights, NOON), follow="me")
        img = r.images()[0]
    save_shot(f"light_{state}", img)
    assert lit(img).sum() >= 6, f"no lamp shows {state[0]!r}"
    assert dark(img).sum() == 0


def test_blinking_yellow_and_brake_lamps(save_shot) -> None:
    eye = car("me", -30.0, -1.75, ego=True)
    ahead = car("lead", -20.0, -1.75, lights=m.LIGHT_BRAKE | m.LIGHT_LEFT_BLINKER)
    lights = m.LightsState(1, 0.0, [m.TrafficLight("J0", "oooo", 0, 3.0)])
    with Renderer(SIMPLE, synthetic_map()) as r:
        shots = {}
        for t in (0.1, 0.6):  # 1 Hz signal blink, 1.5 Hz blinker: on at 0.1 s, off at 0.6 s
            r.draw(SceneFrame(t, (eye, ahead), lights, NOON), follow="me")
            shots[t] = r.images()[0]
            save_shot(f"blink_{t}", shots[t])
    assert yellow(shots[0.1]).sum() > yellow(shots[0.6]).sum() + 4  # signal and blinker lit
    assert red(shots[0.1]).sum() >= 4 and red(shots[0.6]).sum() >= 4  # brake lamps steady


def _contrast(img: np.ndarray, mask: np.ndarray, sky: np.ndarray) -> float:
    return float(np.abs(img[mask].astype(float).mean(axis=0) - sky).sum())


def test_fog_lowers_contrast_with_distance(save_shot) -> None:
    eye = car("me", 0.0, 0.0, ego=True)
    boxes = [car(f"box{d}", d, side, kind="van") for d, side in ((12, 3.0), (30, -5.0), (60, 2.0))]
    fog = m.Weather(0, 0.0, sun_altitude_deg=60, fog_density=0.5)
    contrast = {}
    with Renderer(SIMPLE, None) as r:
        for name, weather in (("clear", NOON), ("fog", fog)):
            r.draw(SceneFrame(0.0, (eye,), None, weather), follow="me")
            empty = r.images()[0]
            sky = empty[2, 2].astype(float)  # fog takes the sky's colour
            contrast[name] = []
            for box in boxes:
                r.draw(SceneFrame(0.0, (eye, box), None, weather), follow="me")
                img = r.images()[0]
                mask = changed(img, empty, threshold=3)
                assert mask.sum() > 4, f"{box.actor_id} not visible in {name}"
                contrast[name].append(_contrast(img, mask, sky))
            r.draw(SceneFrame(0.0, (eye, *boxes), None, weather), follow="me")
            save_shot(f"fog_{name}", r.images()[0])
    near, mid, far = contrast["fog"]
    assert near > mid > far and far < 0.5 * near, contrast
    clear = contrast["clear"]
    assert min(clear) > 0.7 * max(clear), contrast  # without fog distance changes little


def test_same_input_same_image() -> None:
    frame = SceneFrame(
        1.25,
        (car("me", -30, -1.75, ego=True), car("n", -10, -1.75, lights=m.LIGHT_BRAKE)),
        m.LightsState(1, 1.2, [m.TrafficLight("J0", "GrGr", 0, 2.0)]),
        NOON,
    )
    images = []
    for _ in range(2):
        with Renderer(THREE, synthetic_map()) as r:
            r.draw(frame, follow="me")
            images.append(r.images()[0])
    assert np.array_equal(images[0], images[1])
    moved = SceneFrame(1.25, (frame.actors[0], car("n", -12, -1.75)), frame.lights, NOON)
    with Renderer(THREE, synthetic_map()) as r:
        r.draw(moved, follow="me")
        assert not np.array_equal(r.images()[0], images[0])
