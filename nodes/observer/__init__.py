"""A headless observer: joins, watches the world, has no actor of its own."""

from __future__ import annotations

from typing import Any

from carlaverse.config import StrictStruct
from carlaverse.transport.node_client import NodeClient, NodeSettings, PoseSource
from carlaverse.transport.session import FabricSettings


class ObserverConfig(StrictStruct):
    node: NodeSettings = NodeSettings(kind="observer", actor_kind="")
    fabric: FabricSettings = FabricSettings()


class ObserverNode:
    name = "observer"
    config_type = ObserverConfig

    def __init__(self, config: ObserverConfig) -> None:
        self.config = config
        self.max_actors = 0

    def pose_source(self) -> PoseSource | None:
        return None

    def step(self, client: NodeClient, now: float) -> None:
        self.max_actors = max(self.max_actors, len(client.world.egos))

    def close(self) -> None:
        pass

    def report(self) -> dict[str, Any]:
        return {"max_actors": self.max_actors}
