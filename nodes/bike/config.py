"""The bike node's configuration: one YAML file, the single source of truth
(docs/architecture.md §10).

    node:         {node_id: lab-bike-1, kind: bike, actor_kind: bicycle}
    fabric:       {connect: [tcp/10.0.0.1:7447]}
    bicycle:      mass, wheelbase, head height …            carlaverse.physics.bicycle
    resistance:   {rolling_coefficient, drag_coefficient, frontal_area_m2, air_density_kgm3}
    table:        bike-trainer-table.yaml   the calibrated speed × force → % table (a file
                                            relative to this one, or shipped)
    road:         {grade_percent, roughness}   the grade comes from the scenario's `grades:`
                                            (the map carries no elevation); this
                                            grade_percent is the fallback where the
                                            scenario declares none
    speed_source: trainer | speed_sensor    which wheel speed drives the bike
    trainer_feel: {inertia, accel_tau_s}    the rider's missing mass added through the brake
    trainer, speed_sensor, input, ffb:      carlaverse.hal blocks
    fork, loop

Wind comes from the authority's weather, not from here.
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec
from carlaverse_nodes.bike.fork_feel import ForkFeelParams
from carlaverse_nodes.bike.trainer_command import TrainerFeelParams

from carlaverse.config import StrictStruct, resolve_path
from carlaverse.hal import FfbConfig, InputConfig, SpeedSensorConfig, TrainerConfig
from carlaverse.hal.trainer.resistance_table import ResistanceTable, load_table
from carlaverse.messages import Extent
from carlaverse.physics.bicycle import BicycleParams
from carlaverse.physics.resistance import ResistanceParams
from carlaverse.transport.settings import FabricSettings, NodeSettings

Positive = Annotated[float, msgspec.Meta(gt=0)]
DEFAULT_TABLE = "bike-trainer-table.yaml"


class BikeLoopSettings(StrictStruct):
    rate_hz: Annotated[float, msgspec.Meta(ge=50, le=2000)] = 200.0
    ffb_rate_hz: Positive = 200.0  # fork commands sent at most this often
    trainer_rate_hz: Annotated[float, msgspec.Meta(gt=0, le=20)] = 4.0  # BLE writes per second
    realtime_priority: Annotated[int, msgspec.Meta(ge=0, le=99)] = 40  # 0: leave as is


class RoadSettings(StrictStruct):
    grade_percent: Annotated[float, msgspec.Meta(ge=-40, le=40)] = 0.0  # [%] uphill positive
    roughness: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.2  # fork vibration texture


class BikeNodeConfig(StrictStruct):
    node: NodeSettings = NodeSettings(kind="bike", actor_kind="bicycle", pose_rate_hz=50.0)
    fabric: FabricSettings = FabricSettings()
    bicycle: BicycleParams = BicycleParams()
    resistance: ResistanceParams = ResistanceParams()
    table: str = DEFAULT_TABLE
    road: RoadSettings = RoadSettings()
    speed_source: Literal["trainer", "speed_sensor"] = "trainer"
    trainer: TrainerConfig = TrainerConfig(backend="ftms_sim")
    speed_sensor: SpeedSensorConfig = SpeedSensorConfig(backend="sim")
    input: InputConfig = InputConfig(backend="sim", options={"axes": ["steer"]})
    ffb: FfbConfig = FfbConfig(backend="sim")
    fork: ForkFeelParams = ForkFeelParams()
    loop: BikeLoopSettings = BikeLoopSettings()
    trainer_feel: TrainerFeelParams = TrainerFeelParams()


def resolve_table(config: BikeNodeConfig) -> ResistanceTable:
    """The calibrated table the config names (relative to the cwd, or shipped)."""
    return load_table(resolve_path(config.table))


def node_settings(config: BikeNodeConfig) -> NodeSettings:
    """Join settings with the bicycle's extent and mass."""
    b = config.bicycle
    return msgspec.structs.replace(
        config.node,
        kind="bike",
        actor_kind="bicycle",
        extent=Extent(b.length_m, b.width_m, b.height_m),
        mass_kg=b.mass_kg,
    )
