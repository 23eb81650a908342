"""The hardware tab: FFB test pulses, a live joystick, a motion neutral test, a trainer scan.

Each card takes the device block a node config would hold (YAML, `{backend: sim}` by default,
so every check runs here without hardware) and runs the check in a worker thread; what it
reports is appended to the card's log. A device error is one red line, never a traceback.
A block that reaches a device beyond this machine's simulations must be one a config in the
config dir holds (`hardware.check_reach`): the page names no other address to send to.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import yaml
from nicegui import run, ui

from carlaverse.config import ConfigError
from carlaverse.hal import InputState
from carlaverse.hal.errors import HalError
from carlaverse.launcher import hardware
from carlaverse.launcher.files import ConfigDir

JOYSTICK_RATE_HZ = 20.0  # [Hz] how often the live joystick view samples its device
Check = Callable[[dict[str, Any], Callable[[str], None]], object]


def hardware_panel(files: ConfigDir) -> None:
    with ui.grid(columns=2).classes("w-full gap-4"):
        _check_card(files, "Force feedback", "{backend: sim}", "Send test pulses",
                    hardware.ffb_pulses, "ffb")  # fmt: skip
        _joystick_card()
        _check_card(files, "Motion platform", "{backend: sim}", "Neutral test",
                    hardware.motion_neutral, "motion")  # fmt: skip
        _check_card(files, "Smart trainer", "{backend: ftms_sim}", "Scan", hardware.trainer_scan,
                    "trainer")  # fmt: skip


def _check_card(
    files: ConfigDir, title: str, block: str, action: str, check: Check, testid: str
) -> None:
    with ui.card().classes("w-full"):
        ui.label(title).classes("text-lg font-medium")
        text = ui.input("device block (YAML)", value=block).classes("w-full")
        text.props(f"dense data-testid={testid}-block")
        log = (
            ui.log(max_lines=200).classes("w-full h-40 text-xs").props(f"data-testid={testid}-log")
        )
        button: ui.button = ui.button(
            action, on_click=lambda: _run_check(files, check, text.value, log, button)
        )
        button.props(f"data-testid={testid}-run")


async def _run_check(
    files: ConfigDir, check: Check, block_text: str, log: ui.log, button: ui.button
) -> None:
    button.disable()
    loop = asyncio.get_running_loop()  # the check reports from its worker thread

    def report(line: str) -> None:
        loop.call_soon_threadsafe(log.push, line)

    try:
        block = _block(block_text)
        await run.io_bound(_checked_reach, files, block)
        await run.io_bound(check, block, report)
    except (HalError, ConfigError, ValueError) as exc:
        log.push(f"error: {exc}")
    finally:
        button.enable()


def _checked_reach(files: ConfigDir, block: dict[str, Any]) -> None:
    hardware.check_reach(block, files.device_blocks, files.given)


def _block(text: str) -> dict[str, Any]:
    try:
        block = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"device block is not YAML: {exc}") from exc
    if not isinstance(block, dict) or "backend" not in block:
        raise ValueError("device block needs a mapping with `backend:`, e.g. {backend: sim}")
    return block


def _joystick_card() -> None:
    state: dict[str, Any] = {"watch": None}
    with ui.card().classes("w-full"):
        ui.label("Joystick").classes("text-lg font-medium")
        choice = ui.select(_joysticks(), value="sim (scripted)", label="device").classes("w-full")
        channels = ui.column().classes("w-full gap-1").props("data-testid=joystick-channels")
        status = ui.label("").classes("text-sm text-red-700")
        with ui.row():
            ui.button("Watch", on_click=lambda: start()).props("data-testid=joystick-watch")
            ui.button("Stop", on_click=lambda: stop())

    def start() -> None:
        stop()
        try:
            state["watch"] = hardware.JoystickWatch(_joystick_block(choice.value))
            status.text = ""
        except (HalError, ConfigError) as exc:
            status.text = f"error: {exc}"
        timer.activate()

    def stop() -> None:
        if state["watch"] is not None:
            state["watch"].close()
            state["watch"] = None
        timer.deactivate()

    view = InputView(channels)

    def sample() -> None:
        if state["watch"] is not None:
            view.show(state["watch"].sample())

    timer = ui.timer(1.0 / JOYSTICK_RATE_HZ, sample, active=False)
    ui.context.client.on_disconnect(stop)


def _joysticks() -> list[str]:
    try:
        found = hardware.list_joysticks()
    except HalError:
        found = []  # no pygame: the scripted stick is still offered
    return ["sim (scripted)", *found]


def _joystick_block(choice: str) -> dict[str, Any]:
    if choice.startswith("sim"):
        return hardware.SIM_JOYSTICK
    return {"backend": "pygame", "options": {"index": int(choice.split(":", 1)[0])}}


class InputView:
    """Bars for the axes and chips for the buttons, built on the first sample, then updated."""

    def __init__(self, parent: ui.column) -> None:
        self.parent = parent
        self.axes: dict[str, tuple[ui.linear_progress, ui.label]] = {}
        self.buttons: dict[str, ui.chip] = {}

    def show(self, sample: InputState) -> None:
        if set(sample.axes) != set(self.axes) or set(sample.buttons) != set(self.buttons):
            self._build(sample)
        for name, value in sample.axes.items():
            bar, label = self.axes[name]
            bar.value = (value + 1) / 2  # -1..1 across the bar, 0 in the middle
            label.text = f"{value:+.2f}"
        for name, pressed in sample.buttons.items():
            chip = self.buttons[name]
            chip.props(
                f"color={'green' if pressed else 'grey'} data-pressed={str(pressed).lower()}"
            )

    def _build(self, sample: InputState) -> None:
        self.parent.clear()
        self.axes, self.buttons = {}, {}
        with self.parent:
            for name in sample.axes:
                with ui.row().classes("w-full items-center no-wrap"):
                    ui.label(name).classes("w-24 font-mono text-sm")
                    bar = ui.linear_progress(value=0.5, show_value=False).classes("grow")
                    bar.props("instant-feedback")  # no easing: the bar is where the axis is
                    value = ui.label("").classes("w-16 font-mono text-sm")
                    self.axes[name] = (bar, value.props(f"data-axis={name}"))
            with ui.row():
                for name in sample.buttons:
                    self.buttons[name] = ui.chip(name).props(f"data-button={name}")
