"""Traffic lights: one signal head per controlled link, at the stop line of the link's lane.

The map gives each light's links in the order of its SUMO state string, each naming the lane
it controls; a lane with several links (straight, turning) gets its heads side by side. A
head has three lamps (red, yellow, green) facing the approaching traffic; the state string
decides which are lit. Lamps ignore scene lighting, so a lit lamp is as bright at dusk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from panda3d.core import NodePath

from carlaverse.messages import LightsState, MapLane, MapLight
from carlaverse.render import palette
from carlaverse.render.meshes import Color, MeshBuilder

SIDE_OFFSET_M = 0.7  # [m] from the lane's right edge to the pole
HEAD_SPACING_M = 0.5  # [m] between heads of links sharing a lane
LAMP_HEIGHTS_M = (3.3, 2.95, 2.6)  # [m] red, yellow, green lamp centres
LAMP_SIZE_M = 0.26
BLINK_HZ = 1.0  # 'o': yellow blinking, as SUMO's off-blinking state

# state char -> which of (red, yellow, green) are lit; 'o' blinks yellow, 'O' is dark
LIT: dict[str, tuple[bool, bool, bool]] = {
    "r": (True, False, False),
    "s": (True, False, False),
    "u": (True, True, False),
    "y": (False, True, False),
    "g": (False, False, True),
    "G": (False, False, True),
    "o": (False, True, False),
    "O": (False, False, False),
}
LAMPS = (palette.SIGNAL_RED, palette.SIGNAL_YELLOW, palette.SIGNAL_GREEN)


@dataclass(slots=True)
class SignalHead:
    light_id: str
    link: int
    lamps: tuple[NodePath, NodePath, NodePath]
    shown: str = ""


class TrafficLightLayer:
    """Signal heads of every light in the map; `update` colours them from a LightsState."""

    def __init__(self, parent: NodePath, lights: list[MapLight], lanes: list[MapLane]) -> None:
        self.root = parent.attach_new_node("traffic_lights")
        by_id = {lane.id: lane for lane in lanes}
        self.heads: list[SignalHead] = []
        for light in lights:
            per_lane: dict[str, int] = {}
            for link, lane_id in enumerate(light.controlled_lanes):
                lane = by_id.get(lane_id)
                if lane is None or len(lane.centerline) < 2:
                    continue
                slot = per_lane[lane_id] = per_lane.get(lane_id, -1) + 1
                self.heads.append(self._head(light.id, link, lane, slot))

    def _head(self, light_id: str, link: int, lane: MapLane, slot: int) -> SignalHead:
        (x0, y0), (x1, y1) = lane.centerline[-2], lane.centerline[-1]
        heading = math.atan2(y1 - y0, x1 - x0)
        right = lane.width / 2 + SIDE_OFFSET_M + slot * HEAD_SPACING_M
        x = x1 + math.sin(heading) * right
        y = y1 - math.cos(heading) * right
        head = self.root.attach_new_node(f"{light_id}/{link}")
        head.set_pos(x, y, 0.0)
        head.set_h(math.degrees(heading) - 90.0)  # local +y along the lane's direction
        head.attach_new_node(_housing_mesh(slot == 0).node())
        lamps = tuple(_lamp(head, z) for z in LAMP_HEIGHTS_M)
        lamp_head = SignalHead(light_id, link, lamps)
        self._show(lamp_head, "O", 0.0)
        return lamp_head

    def update(self, state: LightsState | None, t: float) -> None:
        """Colour every head from the light's state string at render time `t` [s]."""
        states = {light.id: light.state for light in state.lights} if state else {}
        for head in self.heads:
            text = states.get(head.light_id, "")
            char = text[head.link] if head.link < len(text) else "O"
            self._show(head, char, t)

    def _show(self, head: SignalHead, char: str, t: float) -> None:
        lit = LIT.get(char, LIT["O"])
        if char == "o" and (t * BLINK_HZ) % 1.0 >= 0.5:
            lit = LIT["O"]
        key = "".join("1" if on else "0" for on in lit)
        if key == head.shown:
            return
        head.shown = key
        for lamp, on, (bright, dark) in zip(head.lamps, lit, LAMPS, strict=True):
            lamp.set_color(*(bright if on else dark))


def _housing_mesh(with_pole: bool) -> MeshBuilder:
    mesh = MeshBuilder("signal_housing")
    top, bottom = LAMP_HEIGHTS_M[0] + 0.25, LAMP_HEIGHTS_M[-1] - 0.25
    if with_pole:  # heads sharing a lane share the first head's pole
        mesh.box((0.0, 0.0, 0.0), (0.14, 0.14, top), palette.POLE)
    mesh.box((0.0, 0.0, bottom), (0.36, 0.30, top - bottom), palette.HOUSING)
    return mesh


def _lamp(head: NodePath, z: float) -> NodePath:
    mesh = MeshBuilder("lamp")
    s = LAMP_SIZE_M
    mesh.box((0.0, -0.15 - s / 2, z - s / 2), (s, s, s), _white())
    lamp = head.attach_new_node(mesh.node())
    lamp.set_light_off(1)  # lamps glow: scene lights neither brighten nor darken them
    return lamp


def _white() -> Color:
    return (1.0, 1.0, 1.0, 1.0)
