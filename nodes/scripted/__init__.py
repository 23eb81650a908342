"""A scripted participant: an honest simulated node driving a known path at a set speed.

Its pose is an exact function of session time (`trajectories.py` beside this file), so whoever
knows its config knows where it truly is — the reference for interpolation-error measurements.
"""

from __future__ import annotations

from typing import Any

from carlaverse_nodes.scripted.trajectories import CirclePath, PathSpec

from carlaverse.config import StrictStruct
from carlaverse.transport.node_client import NodeClient, NodeSettings, PoseSource
from carlaverse.transport.session import FabricSettings


class ScriptedConfig(StrictStruct):
    node: NodeSettings = NodeSettings(kind="scripted")
    fabric: FabricSettings = FabricSettings()
    path: PathSpec = CirclePath()


class ScriptedNode:
    name = "scripted"
    config_type = ScriptedConfig

    def __init__(self, config: ScriptedConfig) -> None:
        self.config = config
        self.path = config.path

    def pose_source(self) -> PoseSource | None:
        path = self.path
        return lambda t: path.pose_at(t)

    def step(self, client: NodeClient, now: float) -> None:
        pass

    def close(self) -> None:
        pass

    def report(self) -> dict[str, Any]:
        return {"path": type(self.path).__name__}
