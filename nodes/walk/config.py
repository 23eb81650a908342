"""The walk node's configuration: one YAML file, the single source of truth.

node:    {node_id: lab-walk-1, kind: walk, actor_kind: pedestrian}
fabric:  {connect: [tcp/10.0.0.1:7447]}
xr:      the headset and controllers (carlaverse.hal.xr): sim | mouse | openxr
input:   optional keyboard or gamepad (carlaverse.hal.input) for desktop mode; its axes
         `move_x`, `move_y` and buttons `run`, `interact` add to the controllers'
gait:    walk/run speed, acceleration limits, what "forward" is (head or controller)
lanes:   {snap: false}   keep the walker on sidewalks, crossings and walking areas
body:    {source: none}  where avatar joint angles come from (nodes/walk/body.py)
loop:    {rate_hz: 90}   the control loop (its own process)
"""

from __future__ import annotations

from typing import Annotated

import msgspec
from carlaverse_nodes.walk.body import BodySettings
from carlaverse_nodes.walk.gait import GaitSettings
from carlaverse_nodes.walk.walkable import LaneSettings

from carlaverse.config import StrictStruct
from carlaverse.hal import InputConfig, XrConfig
from carlaverse.messages import Extent
from carlaverse.transport.settings import FabricSettings, NodeSettings

PEDESTRIAN = Extent(0.5, 0.6, 1.75)  # [m] length (depth), width (shoulders), height


class WalkLoopSettings(StrictStruct):
    rate_hz: Annotated[float, msgspec.Meta(ge=20, le=1000)] = 90.0  # a headset's frame rate
    realtime_priority: Annotated[int, msgspec.Meta(ge=0, le=99)] = 0  # 0: leave as is


class WalkNodeConfig(StrictStruct):
    node: NodeSettings = NodeSettings(kind="walk", actor_kind="pedestrian", extent=PEDESTRIAN,
                                      mass_kg=75.0, pose_rate_hz=50.0)  # fmt: skip
    fabric: FabricSettings = FabricSettings()
    xr: XrConfig = XrConfig(backend="sim", options={"posture": "standing"})
    input: InputConfig | None = None
    gait: GaitSettings = GaitSettings()
    lanes: LaneSettings = LaneSettings()
    body: BodySettings = BodySettings()
    loop: WalkLoopSettings = WalkLoopSettings()


def node_settings(config: WalkNodeConfig) -> NodeSettings:
    """Join settings: always a pedestrian of the walk kind."""
    return msgspec.structs.replace(config.node, kind="walk", actor_kind="pedestrian")
