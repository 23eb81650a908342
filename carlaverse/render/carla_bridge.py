"""CARLA as a second render backend: fabric actors mirrored into a local CARLA server.

Each frame, every actor of a `SceneFrame` becomes (or moves) a CARLA actor with physics off,
its lamps set from the light bits; the rig's cameras are RGB sensors attached to the
followed actor at the head position, with the rig's yaw, pitch and field of view.

Frames (the conversions are pure functions, tested without CARLA):
    ours   right-handed: x east, y north, z up [m]; yaw counter-clockwise from +x, pitch nose
           down, roll right side down [rad]; actor frame x forward, y left, z up.
    CARLA  Unreal's left-handed: x, y = −ours y, z [m]; yaw clockwise seen from above, pitch
           nose up, roll right side down [deg]; actor frame x forward, y right, z up.
So y and every yaw flip sign, pitch flips sign, roll keeps it, radians become degrees.
"""

from __future__ import annotations

import math
import socket
from dataclasses import dataclass
from typing import Any

from carlaverse import messages as m
from carlaverse.render.frame import ActorDraw, SceneFrame
from carlaverse.render.graphics import RenderError
from carlaverse.render.rig import RigLayout

BLUEPRINTS = {
    "car": "vehicle.tesla.model3",
    "van": "vehicle.mercedes.sprinter",
    "truck": "vehicle.carlamotors.carlacola",
    "bus": "vehicle.mitsubishi.fusorosa",
    "motorcycle": "vehicle.harley-davidson.low_rider",
    "bicycle": "vehicle.diamondback.century",
    "pedestrian": "walker.pedestrian.0001",
    "other": "vehicle.tesla.model3",
}


@dataclass(frozen=True, slots=True)
class UnrealTransform:
    x: float  # [m]
    y: float
    z: float
    pitch: float  # [deg]
    yaw: float
    roll: float


def to_unreal(x: float, y: float, z: float, yaw: float, pitch: float = 0.0,
              roll: float = 0.0) -> UnrealTransform:  # fmt: skip
    """Our world pose (metres, radians) as a CARLA transform (metres, degrees)."""
    return UnrealTransform(x, -y, z, -math.degrees(pitch), -math.degrees(yaw), math.degrees(roll))


def from_unreal(t: UnrealTransform) -> tuple[float, float, float, float, float, float]:
    """A CARLA transform back to (x, y, z, yaw, pitch, roll) in our frame."""
    return (t.x, -t.y, t.z, -math.radians(t.yaw), -math.radians(t.pitch), math.radians(t.roll))


def head_to_unreal(forward: float, left: float, up: float) -> tuple[float, float, float]:
    """A point in our actor frame (x forward, y left, z up) in CARLA's (x fwd, y right, z up)."""
    return (forward, -left, up)


def light_state_bits(bits: int) -> int:
    """Our LIGHT_* bits as carla.VehicleLightState bits (CARLA 0.9.16 values)."""
    table = {
        m.LIGHT_PARKING: 0x1 << 0,  # Position
        m.LIGHT_LOW_BEAM: 0x1 << 1,
        m.LIGHT_HIGH_BEAM: 0x1 << 2,
        m.LIGHT_BRAKE: 0x1 << 3,
        m.LIGHT_RIGHT_BLINKER: 0x1 << 4,
        m.LIGHT_LEFT_BLINKER: 0x1 << 5,
        m.LIGHT_REVERSE: 0x1 << 6,
        m.LIGHT_FOG: 0x1 << 7,
        m.LIGHT_INTERIOR: 0x1 << 8,
    }
    return sum(carla_bit for ours, carla_bit in table.items() if bits & ours)


def server_answers(host: str = "127.0.0.1", port: int = 2000, timeout_s: float = 0.5) -> bool:
    """Whether something accepts TCP connections on CARLA's RPC port."""
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return True
    except OSError:
        return False


class CarlaBridge:
    """Mirrors frames into a CARLA server; one CARLA actor per fabric actor."""

    def __init__(self, host: str = "127.0.0.1", port: int = 2000, timeout_s: float = 5.0) -> None:
        try:
            import carla
        except ImportError as exc:
            raise RenderError("the CARLA bridge needs `pip install 'carlaverse[carla]'`") from exc
        self._carla = carla
        self.client = carla.Client(host, port)
        self.client.set_timeout(timeout_s)
        self.world = self.client.get_world()
        self._library = self.world.get_blueprint_library()
        self.actors: dict[str, Any] = {}
        self.cameras: list[Any] = []

    def _transform(self, t: UnrealTransform) -> Any:
        c = self._carla
        return c.Transform(c.Location(t.x, t.y, t.z), c.Rotation(t.pitch, t.yaw, t.roll))

    def mirror(self, frame: SceneFrame) -> None:
        """Spawn, move and light every actor of the frame; destroy the ones that left it."""
        seen = set()
        for a in frame.actors:
            seen.add(a.actor_id)
            actor = self.actors.get(a.actor_id) or self._spawn(a)
            if actor is None:
                continue
            actor.set_transform(self._transform(to_unreal(a.x, a.y, a.z, a.yaw, a.pitch, a.roll)))
            if a.kind not in ("pedestrian", "bicycle"):
                actor.set_light_state(self._carla.VehicleLightState(light_state_bits(a.lights)))
        for gone in [i for i in self.actors if i not in seen]:
            self.actors.pop(gone).destroy()

    def _spawn(self, a: ActorDraw) -> Any:
        blueprint = self._library.find(BLUEPRINTS.get(a.kind, BLUEPRINTS["other"]))
        pose = self._transform(to_unreal(a.x, a.y, a.z + 0.3, a.yaw))
        actor = self.world.try_spawn_actor(blueprint, pose)
        if actor is not None:
            actor.set_simulate_physics(False)  # the fabric moves it, CARLA only draws it
            self.actors[a.actor_id] = actor
        return actor

    def attach_rig(self, layout: RigLayout, actor_id: str, callback: Any = None) -> None:
        """One RGB camera per rig camera, on the followed actor at the head position."""
        parent = self.actors[actor_id]
        x, y, z = head_to_unreal(layout.head.x, layout.head.y, layout.head.z)
        for view in layout.cameras:
            bp = self._library.find("sensor.camera.rgb")
            bp.set_attribute("image_size_x", str(view.width_px))
            bp.set_attribute("image_size_y", str(view.height_px))
            bp.set_attribute("fov", f"{math.degrees(view.fov_h):.4f}")
            c = self._carla
            rotation = c.Rotation(math.degrees(view.pitch), -math.degrees(view.yaw), 0.0)
            cam = self.world.spawn_actor(bp, c.Transform(c.Location(x, y, z), rotation), parent)
            if callback is not None:
                cam.listen(callback)
            self.cameras.append(cam)

    def close(self) -> None:
        for actor in [*self.cameras, *self.actors.values()]:
            actor.destroy()
        self.cameras.clear()
        self.actors.clear()
