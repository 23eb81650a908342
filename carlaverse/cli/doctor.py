"""`carlaverse doctor`: hardware diagnostics before a study.

    carlaverse doctor                                  # joysticks SDL detects
    carlaverse doctor --watch                          # their axes and buttons, live
    carlaverse doctor --ffb 127.0.0.1:45500            # test force sequence to an FFB server
    carlaverse doctor --motion 192.168.1.20:45501      # test sweep to a motion server

Forces and motion go through the same `udp` clients the nodes use, at a steady rate, so the
servers' watchdogs stay fed; the last step of each sequence is always "off"/neutral.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable

from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError
from carlaverse.hal import open_ffb, open_input, open_motion
from carlaverse.hal.diagnostics import SweepAmplitudes, ffb_test_sequence, motion_sweep, paced
from carlaverse.hal.errors import HalError
from carlaverse.hal.ffb.udp import UdpFfb
from carlaverse.hal.ffb_packet import FfbCommand
from carlaverse.hal.input import InputState
from carlaverse.hal.motion.udp import UdpMotion
from carlaverse.hal.motion_packet import MotionFrame
from carlaverse.patterns import whole_ascii

# HOST:PORT of a device server; no host means this one. Whole text, ASCII digits only.
_HOST_PORT = whole_ascii(r"(?P<host>[A-Za-z0-9_.-]*|\[[0-9A-Fa-f:.]+\]):(?P<port>[0-9]{1,5})")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--watch", action="store_true", help="show joystick channels live")
    parser.add_argument("--joystick", type=int, default=0, help="joystick index for --watch")
    parser.add_argument("--duration", type=float, metavar="S", help="--watch for S seconds")
    parser.add_argument("--ffb", metavar="HOST:PORT", help="send a test force sequence")
    parser.add_argument("--strength", type=float, default=0.3, help="FFB test strength 0..1")
    parser.add_argument("--motion", metavar="HOST:PORT", help="send a test motion sweep")
    parser.add_argument("--step-s", type=float, default=1.0, help="seconds per test step")
    parser.add_argument("--rate", type=float, default=100.0, help="send/poll rate [Hz]")


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # the CLI is headless; SDL must not ask
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        if args.ffb:
            run_ffb(args)
        if args.motion:
            run_motion(args)
        if not (args.ffb or args.motion):
            list_joysticks(args)
    except (ConfigError, HalError, ValueError) as exc:
        print(f"carlaverse doctor: {exc}", file=sys.stderr)
        return Exit.USAGE
    return Exit.OK


def host_port(text: str) -> dict[str, object]:
    match = _HOST_PORT.fullmatch(text)
    if match is None or int(match["port"]) > 65535:
        raise ValueError(f"{text!r} is not HOST:PORT (e.g. 127.0.0.1:45500)")
    return {"host": match["host"].strip("[]") or "127.0.0.1", "port": int(match["port"])}


def run_ffb(args: argparse.Namespace) -> None:
    with open_ffb({"backend": "udp", "options": host_port(args.ffb)}) as ffb:
        assert isinstance(ffb, UdpFfb)  # the backend named above, whose sender counts packets
        for label, command in ffb_test_sequence(args.strength):
            print(f"ffb: {label}", flush=True)

            def send_command(_phase: float, command: FfbCommand = command) -> None:
                ffb.send(command)

            paced(args.step_s, args.rate, send_command)
        print(f"ffb: sent {ffb.sender.sent} packets to {args.ffb}; did the wheel follow?")


def run_motion(args: argparse.Namespace) -> None:
    with open_motion({"backend": "udp", "options": host_port(args.motion)}) as motion:
        assert isinstance(motion, UdpMotion)  # the backend named above, whose sender counts frames
        for label, frame_at in motion_sweep(SweepAmplitudes()):
            print(f"motion: {label}", flush=True)

            def send_frame(
                phase: float, frame_at: Callable[[float], MotionFrame] = frame_at
            ) -> None:
                motion.send(frame_at(phase))

            paced(args.step_s, args.rate, send_frame)
        print(f"motion: sent {motion.sender.sent} frames to {args.motion}; did the rig move?")


def list_joysticks(args: argparse.Namespace) -> None:
    try:
        from carlaverse.hal.input.pygame_joystick import describe_joysticks
    except ImportError as exc:
        raise HalError(
            f"joystick listing needs pygame: pip install 'carlaverse[input]' ({exc})"
        ) from exc
    rows = describe_joysticks()
    print("joysticks:" if rows else "no joysticks detected (plugged in? permissions?)")
    for row in rows:
        print(f"  {row}")
    if args.watch and rows:
        watch(args)


def watch(args: argparse.Namespace) -> None:
    cfg = {"backend": "pygame", "options": {"index": args.joystick}}
    end = time.monotonic() + args.duration if args.duration is not None else float("inf")
    with open_input(cfg) as device:
        try:
            while time.monotonic() < end:
                print("\r" + render(device.poll()), end="", flush=True)
                time.sleep(1.0 / args.rate)
        except KeyboardInterrupt:
            pass
    print()


def render(state: InputState) -> str:
    axes = " ".join(f"{k}={v:+.3f}" for k, v in state.axes.items())
    pressed = ",".join(k for k, v in state.buttons.items() if v) or "-"
    hats = " ".join(f"{k}={v}" for k, v in state.hats.items())
    return f"{axes} | buttons {pressed} | {hats}"
