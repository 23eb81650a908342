"""The README's pictures: what a participant sees, drawn from one fixed moment in `town`.

    python tools/docs_images.py [--out docs/images] [--quality cpu] [--only NAME ...] [--check]

Every frame is the same scene: the `town` map as the authority builds it (SUMO network,
generated scenery), and a fixed set of road users placed on its lanes by hand, so the
pictures do not depend on a traffic run. The own car drives east on A0B0 (y = 58.4 m)
towards junction B0, a car and a van ahead in its lane, a bus and a car coming the other
way, a cyclist, a motorcyclist behind it and pedestrians on the pavements. Each shot rides
with one of them through a shipped rig (`configs/rigs/`), at a size fit for a README:

    cockpit          rig-desktop          the driver's view: bonnet, A-pillars, mirrors, HUD
    bike             rig-bike-desktop     a cyclist's eye over the handlebar and bike computer
    walk             rig-walk-desktop     a pedestrian's eyes on the pavement
    night            rig-desktop          the drive by night: low beams, street lights, windows
    rain             rig-desktop          the drive in rain: streaks, overcast, a wet road
    three-displays   rig-three-displays   the physical rig's three displays, side by side

By day the sun stands ahead of the driver, 40 degrees up, so the vehicles ahead cast their
shadows towards the camera. Nothing is random and the moment is fixed, so the same code
draws the same pixels (`--check` after a run passes).

`--quality` picks the render preset (`cpu` draws on llvmpipe, the machine's GL without a
GPU; `full` is for a GPU). PNGs are written optimised (zlib level 9). `--check` compares
freshly drawn frames with the files in `--out` and exits 1 naming those that differ by more
than a rounding (mean absolute difference over 1 grey level), so a renderer change that
moves the pictures shows up.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from carlaverse import messages as m
from carlaverse.config import load_config
from carlaverse.render.frame import ActorDraw, Dashboard, SceneFrame
from carlaverse.render.rig import PhysicalRig, RenderConfig, Resolution, SimpleRig

DEFAULT_OUT = Path("docs/images")
SCENARIO = "town"
T = 10.0  # [s] the session time every frame shows (rain drops and blinkers are timed off it)
CHECK_TOLERANCE = 1.0  # [grey levels] mean |difference| allowed by --check


@dataclass(frozen=True, slots=True)
class Shot:
    name: str  # the PNG is <name>.png
    rig: str  # a shipped render config
    follow: str  # the actor whose head the rig rides on
    weather: m.Weather
    size: tuple[int, int]  # [px] of one display
    displays: int = 1  # displays of a physical rig, side by side in one buffer

    @property
    def file(self) -> str:
        return f"{self.name}.png"

    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) of the PNG: a physical rig's displays span one buffer."""
        return self.size[0] * self.displays, self.size[1]


# A clear morning, the sun ahead of the driver (east-south-east; the own car faces east) and
# above the view: every vehicle ahead casts its shadow back towards the camera, and the sun
# stands nearly along the street, so the buildings south of it leave the road in sunlight.
DAY = m.Weather(0, T, sun_altitude_deg=40.0, sun_azimuth_deg=110.0, cloudiness=0.2)
# The sun well below the horizon: past civil twilight (-6 deg), lamps on.
NIGHT = m.Weather(0, T, sun_altitude_deg=-20.0, sun_azimuth_deg=300.0, cloudiness=0.1)
RAIN = m.Weather(0, T, sun_altitude_deg=40.0, sun_azimuth_deg=110.0, cloudiness=0.9,
                 precipitation=0.8, wetness=0.9)  # fmt: skip

SHOTS = (
    Shot("cockpit", "rigs/rig-desktop", "me", DAY, (960, 540)),
    Shot("bike", "rigs/rig-bike-desktop", "cyclist", DAY, (960, 540)),
    Shot("walk", "rigs/rig-walk-desktop", "walker", DAY, (960, 540)),
    Shot("night", "rigs/rig-desktop", "me", NIGHT, (960, 540)),
    Shot("rain", "rigs/rig-desktop", "me", RAIN, (960, 540)),
    Shot("three-displays", "rigs/rig-three-displays", "me", DAY, (640, 360), displays=3),
)


def _road_user(actor_id: str, kind: str, x: float, y: float, yaw: float, speed: float,
               lights: int = 0, ego: bool = False) -> ActorDraw:  # fmt: skip
    e = m.KIND_EXTENTS[kind]
    return ActorDraw(actor_id, kind, x, y, 0.0, yaw, e.length, e.width, e.height,
                     lights=lights, ego=ego, speed=speed, yaw_rate=0.0, steer=0.0)  # fmt: skip


EAST, WEST, NORTH = 0.0, math.pi, math.pi / 2
EASTBOUND, WESTBOUND = 58.4, 61.6  # [m] y of A0B0_1 and B0A0_1 (3.2 m lanes)
SOUTH_PAVEMENT, NORTH_PAVEMENT = 55.8, 64.2  # [m] y of A0B0_0 and B0A0_0


def actors(night: bool) -> tuple[ActorDraw, ...]:
    """Everyone in the picture; by night every vehicle has its low beams on."""
    beam = m.LIGHT_LOW_BEAM if night else 0
    return (
        _road_user("me", "car", 100.0, EASTBOUND, EAST, 11.0, beam, ego=True),
        _road_user("lead", "car", 118.0, EASTBOUND, EAST, 10.0, beam | m.LIGHT_BRAKE, True),
        _road_user("van", "van", 140.0, EASTBOUND, EAST, 9.0, beam),
        _road_user("bus", "bus", 150.0, WESTBOUND, WEST, 10.0, beam),
        _road_user("oncoming", "car", 128.0, WESTBOUND, WEST, 12.0, beam),
        _road_user("moto", "motorcycle", 84.0, EASTBOUND, EAST, 12.0, beam, ego=True),
        _road_user("cyclist", "bicycle", 70.0, EASTBOUND - 0.8, EAST, 5.0, ego=True),
        _road_user("walker", "pedestrian", 110.0, SOUTH_PAVEMENT, EAST, 1.3, ego=True),
        _road_user("stroller", "pedestrian", 124.0, SOUTH_PAVEMENT, WEST, 1.2),
        _road_user("passer", "pedestrian", 132.0, NORTH_PAVEMENT, EAST, 1.4),
        _road_user("crosser", "pedestrian", 166.0, NORTH_PAVEMENT - 0.6, NORTH, 1.1),
    )  # fmt: skip


def dashboard(shot: Shot) -> Dashboard:
    if shot.follow == "cyclist":
        return Dashboard(speed_mps=5.0)
    return Dashboard(speed_mps=11.0, gear=3)


def town_map() -> m.MapReply:
    """The map the authority serves for `town` (SUMO network, scenery seeded by its name)."""
    from carlaverse.traffic.mapdata import build_map_reply, read_net
    from carlaverse.traffic.netbuild import build_map
    from carlaverse.traffic.scenario import load_scenario

    scenario = load_scenario(SCENARIO)
    built = build_map(scenario)
    return build_map_reply(read_net(built.net), scenario.spec.name, built.polygons)


def config(shot: Shot, quality: str) -> RenderConfig:
    """The shipped rig, drawn offscreen at the shot's size and quality."""
    cfg = load_config(shot.rig, RenderConfig)
    size = Resolution(width=shot.size[0], height=shot.size[1])
    if not isinstance(cfg.camera, SimpleRig | PhysicalRig):
        raise ValueError(f"{shot.rig}: a {type(cfg.camera).__name__} has no one resolution")
    camera = msgspec.structs.replace(cfg.camera, resolution=size)
    return msgspec.structs.replace(cfg, output="offscreen", quality=quality, camera=camera)


def draw(shot: Shot, road_map: m.MapReply, quality: str) -> np.ndarray:
    from carlaverse.render.renderer import Renderer

    frame = SceneFrame(T, actors(shot.weather is NIGHT), None, shot.weather)
    with Renderer(config(shot, quality), road_map) as renderer:
        renderer.draw(frame, follow=shot.follow, dash=dashboard(shot))
        image = renderer.images()[0]
    if image.shape[1::-1] != shot.image_size:
        raise RuntimeError(f"{shot.name}: drew {image.shape[1::-1]}, expected {shot.image_size}")
    return image


def save(path: Path, image: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(image).save(path, optimize=True, compress_level=9)


def differs(path: Path, image: np.ndarray) -> str:
    """Why a drawn frame does not match the file ('' when it does)."""
    from PIL import Image

    if not path.is_file():
        return f"{path}: missing"
    with Image.open(path) as stored:
        old = np.asarray(stored.convert("RGB"))
    if old.shape != image.shape:
        return f"{path}: {old.shape[1::-1]} on file, {image.shape[1::-1]} drawn"
    mean = float(np.abs(old.astype(int) - image.astype(int)).mean())
    if mean > CHECK_TOLERANCE:
        return f"{path}: differs by {mean:.2f} grey levels on average"
    return ""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="folder of the PNGs")
    parser.add_argument("--quality", default="cpu", choices=("auto", "full", "cpu", "flat"),
                        help="render preset (default cpu: llvmpipe, no GPU)")  # fmt: skip
    parser.add_argument("--only", nargs="+", choices=[s.name for s in SHOTS],
                        help="draw these shots alone")  # fmt: skip
    parser.add_argument("--check", action="store_true",
                        help="compare with the files in --out instead of writing")  # fmt: skip
    args = parser.parse_args(argv)
    road_map = town_map()
    args.out.mkdir(parents=True, exist_ok=True)
    problems = []
    for shot in SHOTS:
        if args.only and shot.name not in args.only:
            continue
        image = draw(shot, road_map, args.quality)
        path = args.out / shot.file
        if args.check:
            problems.append(differs(path, image))
        else:
            save(path, image)
            print(f"{path}: {shot.image_size[0]}x{shot.image_size[1]}, "
                  f"{path.stat().st_size // 1024} KiB")  # fmt: skip
    for problem in filter(None, problems):
        print(f"docs_images: {problem}", file=sys.stderr)
    return 1 if any(problems) else 0


if __name__ == "__main__":
    sys.exit(main())
