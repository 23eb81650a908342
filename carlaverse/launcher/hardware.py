"""Hardware checks the launcher runs before a study, on the same hal devices the nodes open.

Each check takes a device block as a node config writes it (`{backend: sim}`, `{backend: udp,
options: {host: …, port: …}}`, `{backend: pygame, options: {index: 0}}`), so what is tested is
what a node will use; the `sim` backends make every check run without hardware. The schedules
(test forces, neutral) are `carlaverse.hal.diagnostics`', shared with `carlaverse doctor`.
Errors are HalError/ConfigError with one line naming what is missing.

The page names the block, so a block that can reach beyond this machine (a UDP device at a
host and port) is sent to only when a config in the config dir holds that very block
(`check_reach`): the launcher's page cannot aim test pulses at an address of its choosing.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from carlaverse.hal import InputState, open_ffb, open_input, open_motion, open_trainer
from carlaverse.hal.diagnostics import ffb_test_sequence, paced
from carlaverse.hal.errors import HalError
from carlaverse.hal.motion_packet import NEUTRAL_FRAME

Block = Mapping[str, Any]
Report = Callable[[str], None]

# A scripted stick for the joystick panel: the steering sweeps and button `a` toggles each
# second, so the live view visibly moves without a device.
SIM_JOYSTICK: dict[str, Any] = {
    "backend": "sim",
    "options": {
        "axes": ["steer", "throttle", "brake"],
        "buttons": ["a", "b"],
        "loop": True,
        "profile": [
            {"t": 0.0, "axes": {"steer": -1.0, "throttle": 0.0, "brake": 1.0}},
            {
                "t": 1.0,
                "axes": {"steer": 1.0, "throttle": 1.0, "brake": 0.0},
                "buttons": {"a": True},
            },
            {"t": 2.0, "axes": {"steer": -1.0, "throttle": 0.0, "brake": 1.0}},
        ],
    },
}
# Backends that reach no address a block could name: simulations, and the Bluetooth scan
# (`trainer_scan` only listens for FTMS adverts). Any other one must be a config's own block.
LOCAL_BACKENDS = frozenset({"sim", "ftms_sim", "ftms"})
TRAINER_WAIT_S = 3.0  # [s] a simulated trainer notifies at 4 Hz; its first sample is soon
BLE_SCAN_S = 5.0  # [s] how long a Bluetooth scan listens for FTMS adverts


def check_reach(block: Block, known: Callable[[], list[dict[str, Any]]], config_dir: Path) -> None:
    """HalError unless `block` is a local simulation or a block a config in the dir holds.

    `known` lists the config dir's device blocks; it is read only for a non-local block.
    """
    if block.get("backend") in LOCAL_BACKENDS:
        return
    if any(dict(block) == found for found in known()):
        return
    raise HalError(
        f"device block with backend {block.get('backend')!r} is in no config in {config_dir}: "
        "the launcher tests a device only as a config there names it (copy its block here)"
    )


def ffb_pulses(
    block: Block, report: Report, strength: float = 0.3, step_s: float = 0.3, rate_hz: float = 50
) -> int:
    """Each test force for `step_s`, then all forces off; the number of commands sent."""
    sent = 0
    with open_ffb(block, source="launcher ffb test") as ffb:
        for label, command in ffb_test_sequence(strength):
            report(f"ffb: {label}")

            def send(_phase: float, c: Any = command) -> None:
                nonlocal sent
                ffb.send(c)
                sent += 1

            paced(step_s, rate_hz, send)
    report(f"ffb: sent {sent} commands, ending with all forces off")
    return sent


def motion_neutral(block: Block, report: Report, step_s: float = 1.0, rate_hz: float = 50) -> bool:
    """Hold the platform at neutral for `step_s`; whether it reports neutral after."""
    with open_motion(block, source="launcher motion test") as motion:
        paced(step_s, rate_hz, lambda _u: motion.send(NEUTRAL_FRAME))
        # A sim platform says what it holds; a UDP one cannot, so sending is all we know.
        current = getattr(motion, "current", NEUTRAL_FRAME)
    at_neutral = current == NEUTRAL_FRAME
    report(f"motion: held neutral for {step_s:g} s; platform at neutral: {at_neutral}")
    return at_neutral


class JoystickWatch:
    """An open input device, sampled by the page's timer; close it when the panel closes."""

    def __init__(self, block: Block = SIM_JOYSTICK) -> None:
        self.device = open_input(block, source="launcher joystick")

    def sample(self) -> InputState:
        return self.device.poll()

    def close(self) -> None:
        self.device.close()


def list_joysticks() -> list[str]:
    """Joysticks SDL sees ('index: name (…)'); HalError naming pygame when it is missing."""
    try:
        from carlaverse.hal.input.pygame_joystick import describe_joysticks
    except ImportError as exc:
        raise HalError(
            f"listing joysticks needs pygame: pip install 'carlaverse[input]' ({exc})"
        ) from exc
    return describe_joysticks()


def trainer_scan(block: Block, report: Report) -> list[str]:
    """Trainers found: Bluetooth FTMS adverts for `ftms`, else the device the block opens."""
    ble = block.get("backend") == "ftms"
    found = _ble_scan(BLE_SCAN_S) if ble else [_probe_trainer(block)]
    for line in found:
        report(f"trainer: {line}")
    if not found:
        report(f"trainer: no FTMS trainer advertised in {BLE_SCAN_S:g} s")
    return found


def _probe_trainer(block: Block) -> str:
    with open_trainer(block, source="launcher trainer scan") as trainer:
        deadline = time.monotonic() + TRAINER_WAIT_S
        state = trainer.read()
        while state.cadence_rpm <= 0 and time.monotonic() < deadline:
            time.sleep(0.05)
            state = trainer.read()
    if state.cadence_rpm <= 0:
        raise HalError(f"trainer {block.get('backend')!r}: no data within {TRAINER_WAIT_S:g} s")
    speed = "-" if state.speed_mps is None else f"{state.speed_mps:.1f} m/s"
    return (
        f"{block.get('backend')} answers; first sample {state.power_w:.0f} W, "
        f"{state.cadence_rpm:.0f} rpm, speed {speed}"
    )


def _ble_scan(timeout_s: float) -> list[str]:
    try:
        from bleak import BleakScanner
        from bleak.exc import BleakError
    except ImportError as exc:
        raise HalError(
            f"a Bluetooth scan needs bleak: pip install 'carlaverse[bike]' ({exc})"
        ) from exc
    from carlaverse.hal.trainer.ftms_codec import FTMS_SERVICE

    try:
        devices = asyncio.run(BleakScanner.discover(timeout_s, service_uuids=[FTMS_SERVICE]))
    except (BleakError, OSError) as exc:
        raise HalError(f"Bluetooth scan failed (is there an adapter and BlueZ?): {exc}") from exc
    return [f"{d.name or '(no name)'} at {d.address}" for d in devices]
