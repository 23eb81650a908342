"""The renderer: a Panda3D world built from the map, drawn from a camera rig each frame.

    renderer = Renderer(config, road_map)            # builds the static scene once
    renderer.draw(frame, follow="car-1")             # or eye=Eye(...) for a free camera
    images = renderer.camera_images()                # one (h, w, 3) array per camera

The scene is in rooms: `scene_static` builds the static map meshes (roads, paint, land,
buildings, trees, signs), `traffic_lights` the signal heads, `actors` the moving layer,
`lighting` the sky, sun, shadows, night lights and rain (per quality preset, `quality`),
`cameras` the rig, `graphics` the engine and its outputs.
"""

from __future__ import annotations

import numpy as np
from panda3d.core import NodePath

from carlaverse.messages import MapReply
from carlaverse.render.actors import ActorLayer
from carlaverse.render.cameras import CameraRig, Eye, overview_eye
from carlaverse.render.frame import ActorDraw, Dashboard, SceneFrame
from carlaverse.render.graphics import Graphics
from carlaverse.render.lighting import SceneLighting
from carlaverse.render.own_vehicle import OwnVehicle, riding_eye
from carlaverse.render.rig import RenderConfig, RigLayout, layout
from carlaverse.render.scene_static import build_static
from carlaverse.render.shadows import VIEW_MASK
from carlaverse.render.traffic_lights import TrafficLightLayer

EMPTY_BOUNDS = (-100.0, -100.0, 100.0, 100.0)


class FollowError(LookupError):
    """The actor a camera should follow is not in the frame."""


class Renderer:
    def __init__(
        self, config: RenderConfig, road_map: MapReply | None, title: str = "carlaverse"
    ) -> None:
        self.config = config
        self.layout: RigLayout = layout(config.camera)
        self.graphics = Graphics(
            self.layout.outputs, config.output == "offscreen", title, config.quality
        )
        self.world = NodePath("world")
        self.bounds = road_map.bounds if road_map else EMPTY_BOUNDS
        road = self._build_map(road_map)
        self.lights = TrafficLightLayer(
            self.world, road_map.lights if road_map else [], road_map.lanes if road_map else []
        )
        self.actors = ActorLayer(self.world)
        self.lighting = SceneLighting(self.world, self.graphics, road, road_map, self.bounds,
                                      config.draw_distance_m)  # fmt: skip
        self.lighting.vehicles(self.actors.root)
        self.lighting.lamps(self.actors.lamp_prototype)
        self.rig = CameraRig(self.world, self.graphics, self.layout, config.draw_distance_m,
                             VIEW_MASK)  # fmt: skip
        self.rig.set_sky(self.lighting.weather.sky)
        self.own = OwnVehicle(self.world, self.rig, self.graphics, config.own)
        self.frames = 0

    def _build_map(self, road_map: MapReply | None) -> NodePath:
        """Static meshes, flattened: the whole map costs a handful of draw calls."""
        static = self.world.attach_new_node("map")
        road = static.attach_new_node("road")  # kept apart: wetness darkens it alone
        scene = build_static(road_map, self.bounds, textured=self.graphics.preset.textured)
        for parent, group in ((static, scene.land), (road, scene.road)):
            for mesh in group:
                if not mesh.empty:
                    parent.attach_new_node(mesh.node())
        road.flatten_strong()
        return road

    @property
    def gl_renderer(self) -> str:
        return self.graphics.gl_renderer()

    def draw(self, frame: SceneFrame, follow: str | None = None, eye: Eye | None = None,
             dash: Dashboard | None = None) -> None:  # fmt: skip
        """Draw `frame` from the rig, anchored at actor `follow` or at `eye` (else overview);
        `dash` is the followed vehicle's own dashboard, for a HUD (`own_vehicle`)."""
        self.rig.place(self._eye(frame, follow, eye))
        self.own.show(frame.actor(follow) if follow is not None else None, dash)
        if self.lighting.update(frame, self.rig.head, follow):
            self.rig.set_sky(self.lighting.weather.sky)
        self.lights.update(frame.lights, frame.t)
        self.actors.update(frame.actors, frame.t, hide=follow)
        self.graphics.render()
        self.frames += 1

    def _eye(self, frame: SceneFrame, follow: str | None, eye: Eye | None) -> Eye:
        if follow is not None:
            actor = frame.actor(follow)
            if actor is None:
                known = ", ".join(sorted(a.actor_id for a in frame.actors if a.ego)) or "none"
                raise FollowError(f"no actor {follow!r} at t = {frame.t:.3f} s (egos: {known})")
            return riding_eye(actor, self.config.own)
        return eye or overview_eye(self.bounds)

    def images(self) -> list[np.ndarray]:
        """The last frame of every output (window or buffer)."""
        return [self.graphics.image(i) for i in range(len(self.graphics.outputs))]

    def camera_images(self) -> list[np.ndarray]:
        """The last frame cut per camera of the rig, in the rig's order."""
        outputs = self.images()
        crops = []
        for view in self.layout.cameras:
            img = outputs[view.output]
            h, w = img.shape[:2]
            left, right, bottom, top = view.viewport
            rows = slice(round(h * (1 - top)), round(h * (1 - bottom)))
            crops.append(img[rows, round(w * left) : round(w * right)])
        return crops

    def close(self) -> None:
        self.own.close()
        self.lighting.close()
        self.graphics.close()
        self.world.remove_node()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def actor_eye(actor: ActorDraw) -> Eye:
    return Eye(actor.x, actor.y, actor.z, actor.yaw, actor.pitch, actor.roll)
