"""The own vehicle in the rider's view: cockpit or handlebar, mirrors and HUD, and the eye.

While the rig rides in an actor (`Renderer.draw(follow=...)`) this layer shows what the config
(`own_config.OwnView`) asks for that fits the actor's kind, hung from the rig's anchor so it
moves with the vehicle; with a free or chase camera it shows nothing and its mirrors' buffers
are switched off, costing no frame time.

These parts are seen only by the rig's own cameras: the mirrors' cameras (and any other
camera, such as a shadow map's) do not draw them. Each rig camera keeps its mask less the
mirrors' bit, and the parts are shown to exactly those bits.

The eye: riding a two-wheeler, the anchor takes the vehicle's heading and pitch but not its
lean unless `lean` is set. A rider on a stationary trainer in front of a fixed screen does not
lean, so the horizon stays level on the screen; the picture then matches their own vestibular
sense, which a rolling horizon would contradict.
"""

from __future__ import annotations

from panda3d.core import BitMask32, NodePath

from carlaverse.render.bodies import body_color
from carlaverse.render.cameras import CameraRig, Eye
from carlaverse.render.cockpit import cockpit_mesh, handlebar_mesh, panda
from carlaverse.render.frame import ActorDraw, Dashboard
from carlaverse.render.graphics import Graphics
from carlaverse.render.hud import HeadUpDisplay
from carlaverse.render.lighting import OWN_VEHICLE_MATERIAL
from carlaverse.render.mirrors import MIRROR_MASK, MirrorView
from carlaverse.render.own_config import COCKPIT_KINDS, HANDLEBAR_KINDS, TWO_WHEELERS, OwnView


def riding_eye(actor: ActorDraw, own: OwnView) -> Eye:
    """Where the rig's anchor goes riding in `actor`: its pose, a two-wheeler's lean only
    when the config asks for it."""
    roll = actor.roll if own.lean or actor.kind not in TWO_WHEELERS else 0.0
    return Eye(actor.x, actor.y, actor.z, actor.yaw, actor.pitch, roll)


class OwnVehicle:
    """The parts of the own vehicle the config asks for, under the rig's anchor."""

    def __init__(self, world: NodePath, rig: CameraRig, graphics: Graphics,
                 config: OwnView) -> None:  # fmt: skip
        self.config = config
        self.rig = rig
        self.root = rig.anchor.attach_new_node("own")
        self.root.set_shader_input("surface", OWN_VEHICLE_MATERIAL.input())
        view = BitMask32()
        for region in rig.regions:
            camera = region.get_camera().node()
            camera.set_camera_mask(camera.get_camera_mask() & ~MIRROR_MASK)
            view |= camera.get_camera_mask()
        self.root.hide(BitMask32.all_on())
        self.root.show(view)
        self.root.stash()
        head = rig.layout.head
        self._eye = panda((head.x, head.y, head.z))
        self._parts: dict[str, NodePath] = {}  # per kind: cockpit or handlebar
        self._shown: str | None = None
        self.mirrors = [MirrorView(graphics.outputs[0], world, rig.anchor, self.root, mirror,
                                   head) for mirror in config.mirrors]  # fmt: skip
        self.hud = HeadUpDisplay(self.root, self._eye, config.hud) if config.hud else None
        self._mirrors_on = True
        self._show_mirrors(False)
        self._sky: object = None

    def show(self, actor: ActorDraw | None, dash: Dashboard | None = None) -> None:
        """Show the parts for riding in `actor` (None: a free or chase camera: none)."""
        if actor is None:
            self.root.stash()
            self._show_mirrors(False)
            return
        self.root.unstash()
        if actor.kind != self._shown:
            for node in self._parts.values():
                node.stash()
            part = self._part(actor)
            if part is not None:
                part.unstash()
            self._shown = actor.kind
        self._show_mirrors(actor.kind in COCKPIT_KINDS)
        self._match_sky()
        if self.hud is not None:
            self.hud.show(dash)

    def _part(self, actor: ActorDraw) -> NodePath | None:
        if actor.kind not in self._parts:
            mesh = None
            body = body_color(actor.kind, ego=True)
            if actor.kind in COCKPIT_KINDS and self.config.cockpit is not None:
                mesh = cockpit_mesh(self.config.cockpit, self.rig.layout.head, body)
            elif actor.kind in HANDLEBAR_KINDS and self.config.handlebar is not None:
                mesh = handlebar_mesh(self.config.handlebar, body)
            if mesh is None:
                return None
            self._parts[actor.kind] = self.root.attach_new_node(mesh.node())
        return self._parts[actor.kind]

    def _show_mirrors(self, on: bool) -> None:
        if on == self._mirrors_on:
            return
        self._mirrors_on = on
        for mirror in self.mirrors:
            mirror.set_active(on)
            mirror.glass.unstash() if on else mirror.glass.stash()

    def _match_sky(self) -> None:
        """The mirrors clear to the colour the rig's cameras clear to (the sky's)."""
        if not self.mirrors or not self.rig.regions:
            return
        sky = self.rig.regions[0].get_clear_color()
        if sky != self._sky:
            self._sky = sky
            for mirror in self.mirrors:
                mirror.set_sky((sky[0], sky[1], sky[2], sky[3]))

    def close(self) -> None:
        for mirror in self.mirrors:
            mirror.close()
        self.root.remove_node()
