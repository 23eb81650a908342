"""The drive node's configuration: one YAML file, the single source of truth
(docs/architecture.md §10).

    node:     {node_id: tum-drive-1, kind: drive}        carlaverse.transport NodeSettings
    fabric:   {connect: [tcp/10.0.0.1:7447]}             FabricSettings
    vehicle:  vehicles/compact-car.yaml                  a file (relative to this one, or
                                                         shipped) or the parameters inline
    controls: {steer: {source: steer, curve: ...}, buttons: {...}}
    input:    {backend: keyboard | pygame | sim, options: {...}}     carlaverse.hal; or a
              list of them (wheel, pedals, button box): their channels are merged
    ffb:      {backend: udp | sim, options: {...}}
    motion:   {backend: udp | sim, options: {...}}
    gearbox:  vehicle | automatic | manual               override the vehicle's mode
    adas, steering_feel, motion_cueing, loop
    road:     {mu_scale, roughness_class: A..H | null, roughness_seed}   where the scenario's
              `surface:` gives no roughness class (bumps, kerbs, potholes come from it alone)

No hardware id lives in code: device names, axis indices and keys are all here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import msgspec
from carlaverse_nodes.drive.adas import AdasParams
from carlaverse_nodes.drive.controls import ControlsConfig

from carlaverse.config import ConfigError, StrictStruct, load_config, resolve_path
from carlaverse.hal import FfbConfig, InputConfig, MotionConfig
from carlaverse.hal.motion_packet import MotionLimits
from carlaverse.messages import Extent
from carlaverse.physics.motion_cueing import MotionCueingParams
from carlaverse.physics.params import VehicleParams, load_vehicle
from carlaverse.physics.roughness import RoughnessClass
from carlaverse.physics.steering_feel import SteeringFeelParams
from carlaverse.transport.settings import FabricSettings, NodeSettings

Positive = Annotated[float, msgspec.Meta(gt=0)]
DEFAULT_VEHICLE = "vehicles/compact-car.yaml"


class LoopSettings(StrictStruct):
    """The control + physics + haptics loop (docs/architecture.md §8)."""

    rate_hz: Annotated[float, msgspec.Meta(ge=50, le=5000)] = 1000.0
    physics_substeps: Annotated[int, msgspec.Meta(ge=1, le=20)] = 1
    ffb_rate_hz: Positive = 500.0  # FFB commands sent at most this often
    motion_rate_hz: Positive = 100.0  # FRAME_UPDATEs sent at most this often
    blink_period_s: Positive = 0.667  # indicator flasher period [s]
    # Ask the OS for real-time scheduling (SCHED_FIFO) for the loop process; needs root or
    # CAP_SYS_NICE, falls back to a raised nice priority, and says so when neither works.
    realtime_priority: Annotated[int, msgspec.Meta(ge=0, le=99)] = 40  # 0: leave as is


class RoadSettings(StrictStruct):
    """The surface under the car where the scenario's `surface:` says nothing."""

    mu_scale: Annotated[float, msgspec.Meta(gt=0, le=1.5)] = 1.0  # grip relative to dry
    # ISO 8608 class of the road's unevenness (physics/roughness.py), felt as heave, pitch and
    # steering-wheel shake; null: perfectly smooth. A: a new motorway, C: a worn town street.
    roughness_class: RoughnessClass | None = "A"
    roughness_seed: int = 0  # the profile's seed: the same seed, the same road


class DriveNodeConfig(StrictStruct):
    node: NodeSettings = NodeSettings(kind="drive", actor_kind="car")
    fabric: FabricSettings = FabricSettings()
    vehicle: str | VehicleParams = DEFAULT_VEHICLE
    gearbox: Literal["vehicle", "automatic", "manual"] = "vehicle"
    controls: ControlsConfig = ControlsConfig()
    input: InputConfig | list[InputConfig] = InputConfig(backend="sim")
    ffb: FfbConfig = FfbConfig(backend="sim")
    motion: MotionConfig = MotionConfig(backend="sim")
    adas: AdasParams = AdasParams()
    steering_feel: SteeringFeelParams = SteeringFeelParams()
    motion_cueing: MotionCueingParams = MotionCueingParams()
    loop: LoopSettings = LoopSettings()
    road: RoadSettings = RoadSettings()

    def __post_init__(self) -> None:
        check_motion_limits(self.motion_cueing, self.motion)


# The cueing's clamp of each axis and the device limit it must stay within.
CUEING_VS_DEVICE = (
    ("roll_limit_rad", "roll_rad"),
    ("pitch_limit_rad", "pitch_rad"),
    ("heave_limit_m", "heave_m"),
)


def check_motion_limits(cueing: MotionCueingParams, motion: MotionConfig) -> None:
    """Refuse cueing clamps wider than the motion device accepts: the device would reject every
    frame of a hard manoeuvre. Its limits are `options.limits` (defaults where absent)."""
    raw = motion.options.get("limits", {})
    try:
        limits = msgspec.convert(raw, MotionLimits, strict=False)
    except msgspec.ValidationError:
        return  # a bad `limits` block is named when the device opens it
    for cue_field, device_field in CUEING_VS_DEVICE:
        clamp, bound = getattr(cueing, cue_field), getattr(limits, device_field)
        if clamp > bound:
            raise ValueError(
                f"motion_cueing.{cue_field} {clamp:g} exceeds motion.options.limits."
                f"{device_field} {bound:g}: the device would reject those frames; set "
                f"motion_cueing.{cue_field} to at most {bound:g} or raise the device's limit"
            )


def load_drive_config(path: str | Path) -> tuple[DriveNodeConfig, VehicleParams]:
    """Load a drive config and the vehicle it names (path relative to the config file)."""
    resolved = resolve_path(path)
    config = load_config(resolved, DriveNodeConfig)
    return config, resolve_vehicle(config, resolved.parent)


def resolve_vehicle(config: DriveNodeConfig, relative_to: Path | None = None) -> VehicleParams:
    """The vehicle the config names, with the `gearbox:` override applied."""
    if isinstance(config.vehicle, VehicleParams):
        vehicle = config.vehicle
    else:
        try:
            vehicle = load_vehicle(config.vehicle, relative_to)
        except ConfigError as exc:
            raise ConfigError(exc.source, f"{exc.detail} (named by `vehicle:`)") from exc
    if config.gearbox == "vehicle" or config.gearbox == vehicle.transmission.mode:
        return vehicle
    transmission = msgspec.structs.replace(vehicle.transmission, mode=config.gearbox)
    return msgspec.structs.replace(vehicle, transmission=transmission)


def input_configs(config: DriveNodeConfig) -> list[InputConfig]:
    """Every input device of the node, in merge order (a later device's channel wins)."""
    return list(config.input) if isinstance(config.input, list) else [config.input]


def node_settings(config: DriveNodeConfig, vehicle: VehicleParams) -> NodeSettings:
    """The node's join settings with its extent and mass taken from the vehicle."""
    body = vehicle.body
    return msgspec.structs.replace(
        config.node,
        kind="drive",
        extent=Extent(body.length_m, body.width_m, body.height_m),
        mass_kg=body.mass_kg,
    )
