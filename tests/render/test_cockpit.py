"""The own vehicle in the rider's view, in real pixels: the bonnet fills the bottom of the
driver's view up to where its front edge projects, the A-pillar stands where the config puts
it, a bike's horizon stays level while it leans (unless the config asks for the lean), the
handlebar is where a cyclist sees it, and the HUD reads the speed in whole km/h.

Expected places come from the config's geometry through a pinhole camera (the rig's field of
view, square pixels), worked out here independently of the meshes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import msgspec
import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.config import load_config
from carlaverse.physics.bicycle import BicycleParams
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import ActorDraw, Dashboard, SceneFrame
from carlaverse.render.own_config import Cockpit, Handlebar, Hud, OwnView
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import (
    CameraView,
    HeadPosition,
    RenderConfig,
    Resolution,
    SimpleRig,
    layout,
)
from tests.render.support import changed

pytestmark = pytest.mark.usefixtures("offscreen_gl")

W, H = 320, 180
DRIVER = HeadPosition(x=0.1, y=0.37, z=1.2)
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)


def config(own: OwnView, head: HeadPosition = DRIVER, pitch_deg: float = 0.0,
           fov_deg: float = 90.0) -> RenderConfig:  # fmt: skip
    camera = SimpleRig(resolution=Resolution(width=W, height=H), fov_deg=fov_deg, head=head,
                       pitch_deg=pitch_deg)  # fmt: skip
    return RenderConfig(output="offscreen", camera=camera, own=own)


def me(kind: str = "car", roll: float = 0.0) -> ActorDraw:
    e = m.KIND_EXTENTS[kind]
    return ActorDraw("me", kind, 0.0, 0.0, 0.0, 0.0, e.length, e.width, e.height, roll=roll,
                     ego=True)  # fmt: skip


def riding(cfg: RenderConfig, actor: ActorDraw, dash: Dashboard | None = None,
           weather: m.Weather = NOON) -> np.ndarray:  # fmt: skip
    with Renderer(cfg, None) as r:
        r.draw(SceneFrame(0.0, (actor,), None, weather), follow=actor.actor_id, dash=dash)
        return r.images()[0]


def project(cam: CameraView, head: HeadPosition, p: tuple[float, float, float],
            pitch: float = 0.0) -> tuple[float, float]:  # fmt: skip
    """(column, row) of a vehicle-frame point (forward, left, up) for a camera at the head,
    looking straight ahead and `pitch` [rad] up."""
    f, left, up = p[0] - head.x, p[1] - head.y, p[2] - head.z
    depth = f * math.cos(pitch) + up * math.sin(pitch)
    rise = -f * math.sin(pitch) + up * math.cos(pitch)
    col = (1 - (left / depth) / math.tan(cam.fov_h / 2)) / 2 * cam.width_px
    row = (1 - (rise / depth) / math.tan(cam.fov_v / 2)) / 2 * cam.height_px
    return col, row


@pytest.fixture(scope="module")
def cockpit_shots() -> Iterator[tuple[np.ndarray, np.ndarray]]:
    yield riding(config(OwnView(cockpit=Cockpit())), me()), riding(config(OwnView()), me())


def test_the_bonnet_fills_the_bottom_of_the_drivers_view(cockpit_shots, save_shot) -> None:
    """Along the car's middle, from the bottom of the picture up to the bonnet's front edge,
    the driver sees the car (dashboard, scuttle, bonnet); above it, the road ahead. The edge's
    middle is the highest point of the bonnet seen from the seat: its rear edge, 0.27 m under
    the eye 0.9 m ahead (16.7° down), lies lower than the front, 0.40 m under it 1.85 m ahead
    (12.2° down)."""
    shown, bare = cockpit_shots
    save_shot("cockpit", shown)
    c, cam = Cockpit(), layout(config(OwnView()).camera).cameras[0]
    col, edge = project(cam, DRIVER, (c.hood_front[0], 0.0, c.hood_front[1]))
    column = changed(shown, bare)[:, round(col)]
    below_horizon = np.arange(H) > H / 2
    top = np.flatnonzero(column & below_horizon)[0]
    assert top == pytest.approx(edge, abs=2.0), (top, edge)
    assert column[top:].mean() > 0.97  # all car from there down
    r, g, b = shown[top + 3, round(col)].astype(int)
    assert b > r + 30 and b > g, (r, g, b)  # the bonnet in the car's blue
    assert not column[round(H / 2) : top - 2].any()  # the road between horizon and bonnet


def test_the_left_a_pillar_stands_where_configured(cockpit_shots) -> None:
    shown, bare = cockpit_shots
    c, cam = Cockpit(), layout(config(OwnView()).camera).cameras[0]
    middle = tuple((a + b) / 2 for a, b in zip(c.pillar_base, c.pillar_top, strict=True))
    col, row = project(cam, DRIVER, middle)
    assert 0 < col < W / 2 and 0 < row < H  # the left pillar is left of the driver's axis
    assert changed(shown, bare)[round(row), round(col)]
    assert shown[round(row), round(col)].max() < 90  # dark trim


def test_nothing_of_the_own_vehicle_with_a_free_camera() -> None:
    own = OwnView(cockpit=Cockpit(), handlebar=Handlebar(), hud=Hud())
    frame = SceneFrame(0.0, (me(),), None, NOON)
    images = []
    for cfg in (config(own), config(OwnView())):
        with Renderer(cfg, None) as r:
            r.draw(frame, eye=Eye(-8.0, 0.0, 2.0, 0.0), dash=Dashboard(10.0, 2))
            images.append(r.images()[0])
    assert np.array_equal(images[0], images[1])


# ----------------------------------------------------------------- the bike's view


def _horizon_rows(img: np.ndarray, cols: tuple[int, int]) -> list[int]:
    """The first row from the top that is ground (green over blue) in each column."""
    g, b = img[..., 1].astype(int), img[..., 2].astype(int)
    ground = g > b + 10
    return [int(np.flatnonzero(ground[:, c])[0]) for c in cols]


@pytest.mark.parametrize("roll", [0.3, -0.25])
def test_a_leaning_bike_keeps_the_horizon_level_on_a_fixed_screen(roll: float) -> None:
    """The rider on a trainer does not lean: unless `lean` is set, the picture is the one of
    an upright eye, its horizon a level line through the middle of an unpitched view."""
    head = HeadPosition(x=-0.05, y=0.0, z=1.6)
    cols = (W // 4, 3 * W // 4)
    level = _horizon_rows(riding(config(OwnView(), head), me("bicycle", roll)), cols)
    assert abs(level[0] - level[1]) <= 1, level
    assert level[0] == pytest.approx(H / 2, abs=2.0)
    leaning = _horizon_rows(riding(config(OwnView(lean=True), head), me("bicycle", roll)), cols)
    # Rolled by φ about its axis (ISO: right side down for φ > 0) the camera sees the
    # horizon through the middle turned by φ the other way on the screen: its right end
    # higher, Δrow = −Δcol·tan φ (rows counted downwards).
    expected = -(cols[1] - cols[0]) * math.tan(roll)
    assert leaning[1] - leaning[0] == pytest.approx(expected, abs=3.0), leaning


def test_the_bike_rig_puts_the_eye_where_a_cyclist_has_it() -> None:
    """rigs/rig-bike-desktop, the default of a bike node's view: the eye at the physics'
    rider eye height (BicycleParams.head_height_m, 1.6 m), on the bike's centre line over
    the bottom bracket region, no lean."""
    from carlaverse.cli.join_view import KIND_RIGS

    assert KIND_RIGS["bicycle"] == "rigs/rig-bike-desktop"
    rig = load_config(KIND_RIGS["bicycle"], RenderConfig)
    assert isinstance(rig.camera, SimpleRig)
    head = rig.camera.head
    assert head.z == pytest.approx(BicycleParams().head_height_m)
    assert head.y == 0.0 and abs(head.x) <= 0.15
    assert not rig.own.lean and rig.own.handlebar is not None


def test_the_handlebar_is_where_the_cyclist_looks_down_on_it(save_shot) -> None:
    rig = load_config("rigs/rig-bike-desktop", RenderConfig)
    assert isinstance(rig.camera, SimpleRig)
    camera = msgspec.structs.replace(rig.camera, resolution=Resolution(width=W, height=H))
    cfg = msgspec.structs.replace(rig, output="offscreen", camera=camera)
    bare = msgspec.structs.replace(cfg, own=OwnView())
    shown = riding(cfg, me("bicycle"))
    save_shot("bike_view", shown)
    bar = changed(shown, riding(bare, me("bicycle")))
    cam, pitch = layout(cfg.camera).cameras[0], math.radians(camera.pitch_deg)
    h = Handlebar()
    col, row = project(cam, camera.head, (h.clamp[0], 0.0, h.clamp[1]), pitch)
    assert 0 < row < H, row  # the stem's clamp is in the picture ...
    assert bar[round(row) - 1 : round(row) + 2, round(col) - 1 : round(col) + 2].any()
    rows, cols = np.nonzero(bar)
    assert rows.min() > H / 2  # ... and the bar only in its lower half, around the middle
    assert abs(cols.mean() - W / 2) < 3


# ----------------------------------------------------------------- HUD


HUD = Hud()


def _hud(dash: Dashboard | None, hud: Hud | None = HUD) -> np.ndarray:
    return riding(config(OwnView(hud=hud)), me(), dash)


def test_the_hud_reads_the_speed_in_whole_kmh(save_shot) -> None:
    """13.9 m/s is 50.0 km/h and 13.8 m/s 49.7 km/h: both read 50, one picture; 33.3 m/s
    reads 120, another picture, different only where the display hangs (9° below the eye's
    horizontal, 2.5 m ahead). Without the loop's state there is nothing to show."""
    fifty, also_fifty = _hud(Dashboard(13.9, 3)), _hud(Dashboard(13.8, 3))
    fast = _hud(Dashboard(33.3, 3))
    save_shot("hud_50", fifty)
    assert np.array_equal(fifty, also_fifty)
    text = changed(fifty, fast)
    assert text.sum() > 10
    cam = layout(config(OwnView()).camera).cameras[0]
    centre_row = H / 2 + math.tan(math.radians(9.0)) / math.tan(cam.fov_v / 2) * H / 2
    rows, cols = np.nonzero(text)
    assert abs(rows.mean() - centre_row) < 6 and abs(cols.mean() - W / 2) < 30
    assert np.array_equal(_hud(None), _hud(None, hud=None))  # no state, no display
    assert not np.array_equal(_hud(Dashboard(13.9, 4)), fifty)  # the gear is shown


def test_the_hud_arrow_is_on_the_side_of_the_indicator() -> None:
    plain = _hud(Dashboard(13.9, 3))
    for side, dash in (("left", Dashboard(13.9, 3, left=True)),
                       ("right", Dashboard(13.9, 3, right=True))):  # fmt: skip
        cols = np.nonzero(changed(_hud(dash), plain))[1]
        assert cols.size > 3, side
        assert (cols.mean() < W / 2) == (side == "left"), (side, cols.mean())


def test_rain_wets_the_road_not_the_dashboard() -> None:
    """Wetness darkens and mirrors the sky on upward faces out in the weather; the dashboard
    is under the car's roof and stays as dry as on a dry day. (Found in docs/images' rain
    frame: the dashboard's top went from grey 8 to 31, mirroring the sky.)"""
    cfg = msgspec.structs.replace(config(OwnView(cockpit=Cockpit())), quality="cpu")
    dry = riding(cfg, me())
    wet = riding(cfg, me(), weather=msgspec.structs.replace(NOON, wetness=0.9))
    dash = (slice(H - 34, H - 22), slice(W - 90, W - 10))  # the dash top below the bonnet
    assert dry[dash].mean() < 60  # the dark dashboard, not the bonnet or the road
    assert np.abs(wet[dash].astype(int) - dry[dash].astype(int)).mean() < 2.0
