"""Backends chosen by name from YAML, "did you mean", missing extras, and third-party backends
found through a real entry point (a dist-info on a tmp sys.path entry)."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import msgspec
import pytest

from carlaverse import hal
from carlaverse.config import ConfigError, StrictStruct, load_config
from carlaverse.hal import input as input_family
from carlaverse.hal.errors import BackendDependencyError, BackendNotFoundError, HalError
from carlaverse.hal.ffb_server import registry as ffb_server_registry
from carlaverse.hal.motion_server import registry as motion_server_registry
from carlaverse.hal.registry import BackendSpec, Registry


class Hardware(StrictStruct):
    """A node config's hardware blocks, as a drive or bike node would declare them."""

    input: hal.InputConfig
    ffb: hal.FfbConfig = msgspec.field(default_factory=hal.FfbConfig)
    motion: hal.MotionConfig = msgspec.field(default_factory=hal.MotionConfig)
    trainer: hal.TrainerConfig = msgspec.field(default_factory=hal.TrainerConfig)
    speed_sensor: hal.SpeedSensorConfig = msgspec.field(default_factory=hal.SpeedSensorConfig)
    xr: hal.XrConfig = msgspec.field(default_factory=hal.XrConfig)
    camera: hal.CameraConfig = msgspec.field(default_factory=hal.CameraConfig)


def write(path: Path, text: str) -> Path:
    path.write_text(textwrap.dedent(text))
    return path


def test_every_family_opens_its_backend_from_yaml(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path / "node.yaml", """
        input: {backend: sim, options: {axes: [steer], mode: random_walk}}
        ffb: {backend: udp, options: {host: 127.0.0.1, port: 45999}}
        motion: {backend: udp, options: {port: 45998, limits: {heave_m: 0.2}}}
        trainer: {backend: sim, options: {rider_power_w: 250}}
        speed_sensor: {backend: sim}
        xr: {backend: sim, options: {seed: 4}}
        camera: {backend: sim, options: {render: true, width: 64, height: 48}}
    """), Hardware)  # fmt: skip
    opened = [
        hal.open_input(cfg.input), hal.open_ffb(cfg.ffb), hal.open_motion(cfg.motion),
        hal.open_trainer(cfg.trainer), hal.open_speed_sensor(cfg.speed_sensor),
        hal.open_xr(cfg.xr), hal.open_camera(cfg.camera),
    ]  # fmt: skip
    names = [type(d).__name__ for d in opened]
    assert names == [
        "SimInput", "UdpFfb", "UdpMotion", "SimTrainer", "SimSpeedSensor", "SimHeadset",
        "SimCamera",
    ]  # fmt: skip
    assert opened[2].options.limits.heave_m == 0.2 and opened[3].options.rider_power_w == 250
    assert opened[6].read().image.shape == (48, 64, 3)
    for device in opened:
        device.close()


@pytest.mark.parametrize("family", ["ffb", "motion"])
def test_sim_backends_by_name(family: str) -> None:
    opener = getattr(hal, f"open_{family}")
    with opener({"backend": "sim"}) as device:
        assert type(device).__name__ == f"Sim{family.capitalize()}"


def test_keyboard_backend_by_name(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    pytest.importorskip("pygame")
    with hal.open_input({"backend": "keyboard"}) as device:
        assert type(device).__name__ == "KeyboardInput"


def test_pygame_backend_by_name(virtual_wheel) -> None:
    with hal.open_input({"backend": "pygame", "options": {"device": "virtual"}}) as device:
        assert type(device).__name__ == "PygameJoystick"


def test_server_backends_by_name(tmp_path: Path) -> None:
    assert ffb_server_registry().resolve("log").__name__ == "LogActuator"
    assert motion_server_registry().resolve("log").__name__ == "LogPlatform"
    assert motion_server_registry().resolve("csv").__name__ == "CsvPlatform"
    pytest.importorskip("evdev")
    assert ffb_server_registry().resolve("evdev").__name__ == "EvdevActuator"


def test_unknown_backend_suggests_the_closest_name() -> None:
    with pytest.raises(BackendNotFoundError) as info:
        hal.open_input({"backend": "pygam"})
    message = str(info.value)
    assert "Did you mean 'pygame'?" in message and "keyboard, pygame, sim" in message
    assert isinstance(info.value, LookupError) and info.value.suggestions == ["pygame"]
    with pytest.raises(BackendNotFoundError, match="Did you mean 'udp'"):
        hal.open_ffb({"backend": "upd"})


def test_unknown_backend_without_a_close_match_lists_the_known_ones() -> None:
    with pytest.raises(BackendNotFoundError) as info:
        hal.open_trainer({"backend": "wattbike-proprietary"})
    message = str(info.value)
    assert (
        "Did you mean" not in message and "Known trainer backends: ftms, ftms_sim, sim" in message
    )


def test_bad_options_name_the_backend_and_field(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        hal.open_ffb({"backend": "udp", "options": {"port": "many"}}, source="drive.yaml: ffb")
    assert "drive.yaml: ffb.options (backend 'udp')" in str(info.value)
    assert "$.port" in str(info.value)
    with pytest.raises(ConfigError, match="unknown field `histroy`"):
        hal.open_motion({"backend": "sim", "options": {"histroy": 3}})
    with pytest.raises(ConfigError, match="unknown field `bakend`"):
        hal.open_xr({"bakend": "sim"})


def make_distribution(root: Path, name: str, entry_points: str, modules: dict[str, str]) -> None:
    """A minimal installed distribution: modules plus NAME-0.1.dist-info with entry points."""
    for module, source in modules.items():
        (root / f"{module}.py").write_text(textwrap.dedent(source))
    info = root / f"{name}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent(entry_points))


@pytest.fixture
def third_party(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    make_distribution(
        tmp_path,
        "lab_devices",
        """
        [carlaverse.hal.input]
        wobble = lab_wobble:WobbleInput
        broken = lab_broken:BrokenInput
        notadevice = lab_wobble:NotADevice

        [carlaverse.hal.motion_server]
        labrig = lab_rig:LabRig
        """,
        {
            "lab_wobble": """
                from carlaverse.config import StrictStruct
                from carlaverse.hal.input import InputDevice

                class WobbleOptions(StrictStruct):
                    amplitude: float = 0.5

                class WobbleInput(InputDevice):
                    Options = WobbleOptions

                    def _poll(self, now):
                        return {"steer": self.options.amplitude}, {}, {}

                class NotADevice:
                    pass
            """,
            "lab_broken": "import lab_vendor_sdk_that_is_not_installed\n",
            "lab_rig": """
                from carlaverse.hal.motion_server import MotionPlatform

                class LabRig(MotionPlatform):
                    def _apply(self, frame, now):
                        self.last = frame
            """,
        },
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    for module in ("lab_wobble", "lab_broken", "lab_rig"):
        sys.modules.pop(module, None)


def test_a_third_party_backend_is_found_through_its_entry_point(third_party: Path) -> None:
    assert "wobble" in input_family.registry().names()
    with hal.open_input({"backend": "wobble", "options": {"amplitude": 0.25}}) as device:
        assert device.poll().axes == {"steer": 0.25}
    with pytest.raises(ConfigError, match="backend 'wobble'"):
        hal.open_input({"backend": "wobble", "options": {"amplitude": "x"}})
    with pytest.raises(BackendNotFoundError, match="Did you mean 'wobble'"):
        hal.open_input({"backend": "wobbel"})
    assert "labrig" in motion_server_registry().names()


def test_a_third_party_backend_missing_its_dependency_names_it(third_party: Path) -> None:
    with pytest.raises(BackendDependencyError) as info:
        hal.open_input({"backend": "broken"})
    message = str(info.value)
    assert "'broken'" in message and "lab_vendor_sdk_that_is_not_installed" in message
    assert "pip install lab_vendor_sdk_that_is_not_installed" in message
    assert "lab_devices" in message


def test_an_entry_point_to_a_non_device_is_refused(third_party: Path) -> None:
    with pytest.raises(HalError, match="not a InputDevice subclass"):
        hal.open_input({"backend": "notadevice"})


def test_a_builtin_backend_with_a_missing_extra_gives_the_install_command(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "cv_fancy_backend.py").write_text("import cv_fancy_sdk_missing\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    table = {"fancy": BackendSpec("cv_fancy_backend", "Fancy", "input")}
    registry = Registry("input", input_family.InputDevice, table)
    with pytest.raises(BackendDependencyError) as info:
        registry.resolve("fancy")
    assert "input backend 'fancy'" in str(info.value)
    assert "pip install 'carlaverse[input]'" in str(info.value)
    assert isinstance(info.value, ImportError) and info.value.name == "cv_fancy_sdk_missing"


def test_builtin_names_win_over_entry_points(tmp_path: Path, monkeypatch) -> None:
    make_distribution(
        tmp_path, "shadowing", "[carlaverse.hal.input]\nsim = lab_shadow:Nothing\n",
        {"lab_shadow": "Nothing = None\n"},
    )  # fmt: skip
    monkeypatch.syspath_prepend(str(tmp_path))
    assert input_family.registry().resolve("sim").__name__ == "SimInput"
