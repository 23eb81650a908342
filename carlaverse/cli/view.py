"""`carlaverse view`: the live world (or a recording) in Rerun."""

from __future__ import annotations

import argparse
import importlib
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import zenoh

from carlaverse.cli.common import (
    add_fabric_args,
    attend,
    fabric_from_args,
    fail,
    reached_nothing,
    stop_on_signals,
    tell,
)
from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError
from carlaverse.keys import Keys, KeySpaceError, check_token
from carlaverse.transport.session import FabricError, FabricUnreachable, build_config

if TYPE_CHECKING:
    from carlaverse.viz.outputs import ViewOutput

VIEWER_SCHEMES = ("rerun://", "rerun+http://", "rerun+https://")
SERVE_HELP = (
    "host a web viewer and print its URL. It binds 127.0.0.1 only (a child `rerun "
    "--bind 127.0.0.1`); --serve-host 0.0.0.0 EXPOSES the viewer, and with it the session's "
    "positions, to every machine that can reach this one"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recording",
        nargs="?",
        type=Path,
        metavar="FILE.mcap",
        help="render a recording instead of a live session",
    )
    parser.add_argument("--session", help="live session to observe (e.g. demo)")
    out = parser.add_argument_group("output (at least one)")
    out.add_argument("--spawn", action="store_true", help="open a native Rerun viewer window")
    out.add_argument("--serve", action="store_true", help=SERVE_HELP)
    out.add_argument(
        "--serve-host",
        default="127.0.0.1",
        metavar="IP",
        help="address --serve/--spawn bind to (default 127.0.0.1; see --serve)",
    )
    out.add_argument("--web-port", type=int, default=0, help="web viewer port (default: any)")
    out.add_argument("--save", type=Path, metavar="FILE.rrd", help="write a Rerun file")
    parser.add_argument(
        "--rate",
        type=float,
        default=20.0,
        metavar="HZ",
        help="render rate; frames are dropped, never the fabric (default 20)",
    )
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    parser.add_argument("--no-trails", action="store_true", help="do not draw trajectories")
    parser.add_argument(
        "--raw",
        action="store_true",
        help="also draw every pose and NPC sample as received (world/raw/...), for diagnosis",
    )
    parser.add_argument(
        "--id",
        dest="node_id",
        default="viewer",
        help="identity in a --roster session (default viewer)",
    )
    add_fabric_args(parser, session=False)
    parser.epilog = (
        "--connect also takes the rerun+http://... URL of a running viewer to stream into; "
        "every other --connect is a Zenoh endpoint of the session."
    )


def _split_connect(values: list[str]) -> tuple[list[str], str | None]:
    """--connect takes Zenoh endpoints and at most one Rerun viewer URL (rerun://...)."""
    viewers = [v for v in values if v.startswith(VIEWER_SCHEMES)]
    return [v for v in values if v not in viewers], (viewers[-1] if viewers else None)


def run(args: argparse.Namespace) -> int:
    args.connect, viewer_url = _split_connect(args.connect)
    if not (args.save or viewer_url or args.serve or args.spawn):
        return _fail(
            "choose an output: --spawn, --serve, --connect rerun+http://... or --save FILE.rrd"
        )
    if args.recording is None and not args.session:
        return _fail("give --session NAME to watch a live session, or a FILE.mcap to render")
    if args.rate <= 0:
        return _fail(f"--rate must be > 0, got {args.rate}")
    if args.recording is not None:
        if not args.recording.is_file():
            return _fail(f"{args.recording}: no such recording")
        return _show(args, viewer_url, stop_on_signals(), None)
    try:  # a bad endpoint, session name or roster entry is a usage error: before any output
        check_token(args.session, "session name")
        fabric = fabric_from_args(args)
        build_config(fabric)
    except (KeySpaceError, FabricError, ConfigError) as exc:
        return _fail(str(exc))
    stop = stop_on_signals()
    deadline = None if args.duration is None else time.monotonic() + args.duration
    try:  # first, so what it waits for is said before Rerun's seconds-long import
        session, notice = attend("view", fabric, Keys(args.session), stop, deadline)
    except FabricUnreachable as exc:
        return _fail(str(exc), stop.exit_code() if stop.is_set() else Exit.FABRIC)
    except FabricError as exc:
        return _fail(str(exc), Exit.FABRIC)
    try:
        if not _load_viewer(stop):
            return stop.exit_code()  # stopped while Rerun was still loading
        code = _show(args, viewer_url, stop, Live(session, Keys(args.session), deadline))
        unreached = reached_nothing(notice, fabric)
    finally:  # a missing rerun-sdk or mcap is said by carlaverse.cli.main, naming its extra
        notice.close()
        session.close()
    if unreached and code == Exit.OK:  # an empty view would read as an empty session
        return _fail(
            f"{unreached}: nothing shown", stop.exit_code() if stop.is_set() else Exit.FABRIC
        )
    return code


VIEWER_MODULES = ("carlaverse.recording.sink", "carlaverse.viz.outputs", "carlaverse.viz.live")


def _load_viewer(stop: threading.Event) -> bool:
    """Import Rerun and the view (seconds on a loaded machine) in a worker thread, so a
    signal meanwhile ends the process at once; False if `stop` came first. Raises the
    worker's ModuleNotFoundError (no rerun-sdk) here."""
    loaded = threading.Event()
    missing: list[ModuleNotFoundError] = []

    def load() -> None:
        try:
            for name in VIEWER_MODULES:
                importlib.import_module(name)
        except ModuleNotFoundError as exc:
            missing.append(exc)
        finally:
            loaded.set()

    threading.Thread(target=load, name="load-viewer", daemon=True).start()
    while not loaded.wait(0.05):
        if stop.is_set():
            return False
    if missing:
        raise missing[0]
    return True


@dataclass(frozen=True)
class Live:
    """An open session to watch, until the monotonic `deadline` (--duration) if any."""

    session: zenoh.Session
    keys: Keys
    deadline: float | None


def _show(
    args: argparse.Namespace, viewer_url: str | None, stop: threading.Event, live: Live | None
) -> int:
    from carlaverse.recording.sink import RecordingError  # imports mcap: after the session
    from carlaverse.viz.outputs import Outputs, PortInUse, ViewerError, ViewOutput

    outputs = Outputs(
        save=args.save, connect=viewer_url, serve=args.serve, spawn=args.spawn,
        serve_host=args.serve_host, web_port=args.web_port,
    )  # fmt: skip
    try:
        view = ViewOutput(outputs)
    except PortInUse as exc:  # as for any flag the user can change
        return _fail(f"--web-port: {exc}; choose another, or 0 for any free one")
    except ViewerError as exc:
        return _fail(str(exc), Exit.FAILED)
    try:
        if view.web_url:
            tell(f"web viewer: {view.web_url}")
        if live is None:
            return _render_file(args, view, stop)
        return _watch(args, live, view, stop)
    except (RecordingError, FabricError, KeySpaceError) as exc:
        return _fail(str(exc), Exit.FAILED)
    finally:
        view.close()


def _render_file(args: argparse.Namespace, view: ViewOutput, stop: threading.Event) -> int:
    from carlaverse.viz.outputs import wait_forever_or
    from carlaverse.viz.playback import FromStart, render_recording, view_origin
    from carlaverse.viz.scene import SceneLogger

    rec = FromStart(view.rec, view_origin(args.recording))  # seconds from start beside sim_time
    scene = SceneLogger(cast("Any", rec), trails=not args.no_trails, raw=args.raw)
    stats = render_recording(args.recording, scene, rate_hz=args.rate)
    tell(f"rendered {stats.samples} samples in {stats.frames} frames, 0.0–{stats.span_s:.1f} s "
         "from the recording's start (Rerun timelines: from_start, and sim_time on the "
         "session clock)")  # fmt: skip
    if view.viewers:  # a served/spawned viewer would vanish with us: keep it until Ctrl-C
        view.rec.flush(timeout_sec=10.0)
        tell("serving the recording; Ctrl-C to stop")
        wait_forever_or(stop, view.viewers)
    return Exit.OK


def _watch(args: argparse.Namespace, live: Live, view: ViewOutput, stop: threading.Event) -> int:
    from carlaverse.viz.live import LiveView, ViewSettings
    from carlaverse.viz.scene import SceneLogger

    settings = ViewSettings(rate_hz=args.rate, trails=not args.no_trails)
    scene = SceneLogger(view.rec, trails=settings.trails, raw=args.raw)
    watcher = LiveView(live.session, live.keys, scene, settings)
    try:
        left = None if live.deadline is None else max(0.0, live.deadline - time.monotonic())
        stats = watcher.start().run(stop, left)
    finally:
        watcher.close()
    tell(
        f"viewed {stats.samples} samples in {stats.frames} frames ({stats.skipped_frames} skipped)"
    )
    return Exit.OK


def _fail(message: str, code: int = Exit.USAGE) -> int:
    return fail("view", message, code)
