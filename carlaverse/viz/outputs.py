"""Where a view goes: a native viewer, a web viewer, a running viewer, or an .rrd file.

The Rerun SDK's own `serve_grpc`/`serve_web_viewer`/`spawn` bind every interface and have no
host option. To keep a lab's session off the network by default, `--serve` and `--spawn`
start the `rerun` executable shipped in the `rerun-sdk` wheel as a child with
`--bind 127.0.0.1` and stream to it over gRPC on loopback. `--serve-host` widens that on
purpose (e.g. `0.0.0.0` to let another machine watch).
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import signal
import subprocess
import threading
import uuid
from dataclasses import dataclass
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

log = logging.getLogger(__name__)

APPLICATION_ID = "carlaverse"
_GRPC_LINE = re.compile(r"Listening for gRPC connections on ([0-9.:\[\]a-fA-F]+):(\d+)")
_WEB_LINE = re.compile(r"Hosting a web-viewer at http://([0-9.:\[\]a-fA-F]+):(\d+)")
# rerun's last word when a port is taken: "Error: Failed to create server: Address already in
# use (os error 98): (127.0.0.1:9090): ..."
_IN_USE = re.compile(r"Address already in use.*?\((?P<host>[0-9.:\[\]a-fA-F]+):(?P<port>\d+)\)")
_ANSI = re.compile(r"\x1b\[[0-9;]*m")


def default_blueprint() -> rrb.Blueprint:
    """The world large on the left; health, events and weather in a column on the right."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name="world"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="stats/latency_ms", name="one-way latency [ms]"),
                rrb.TimeSeriesView(origin="stats/rate_hz", name="pose rate [Hz]"),
                rrb.TextLogView(origin="events", name="events"),
                rrb.TextDocumentView(origin="weather/summary", name="weather"),
            ),
            column_shares=[3, 1],
        ),
        collapse_panels=True,
    )


class ViewerError(RuntimeError):
    """A viewer process that could not be started or reached."""


class PortInUse(ViewerError):
    """The viewer's port is taken by another process: the user chooses another."""


@dataclass(frozen=True, slots=True)
class Outputs:
    save: Path | None = None
    connect: str | None = None  # rerun+http://host:port/proxy of a running viewer
    serve: bool = False
    spawn: bool = False
    serve_host: str = "127.0.0.1"
    web_port: int = 0  # 0: any free port
    grpc_port: int = 0

    def any(self) -> bool:
        return bool(self.save or self.connect or self.serve or self.spawn)


def rerun_executable() -> str:
    """The `rerun` binary of the installed rerun-sdk (not the Python wrapper)."""
    try:
        import rerun_cli

        bundled = Path(rerun_cli.__file__).parent / "rerun"
        if bundled.is_file():
            return str(bundled)
    except ImportError:
        pass
    found = shutil.which("rerun")
    if found is None:
        raise ViewerError("no rerun executable: pip install 'rerun-sdk>=0.41' (carlaverse[view])")
    return found


class ViewerProcess:
    """A `rerun` child (web server and/or native viewer) bound to one host; stop() ends it."""

    def __init__(self, args: list[str], wants_web: bool, timeout_s: float = 20.0) -> None:
        env = dict(os.environ, RUST_LOG=os.environ.get("RUST_LOG", "info"))
        self._proc = subprocess.Popen(
            [rerun_executable(), *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=env,
            start_new_session=True,  # Ctrl-C reaches us; we stop the child ourselves
        )
        self.lines: list[str] = []
        self._ready = threading.Event()
        self._wants_web = wants_web
        self.grpc: tuple[str, int] | None = None
        self.web: tuple[str, int] | None = None
        threading.Thread(target=self._read, daemon=True, name="rerun-output").start()
        if not self._ready.wait(timeout_s):
            tail = "".join(self.lines[-20:])
            self.stop()
            raise ViewerError(f"rerun viewer did not start within {timeout_s:g} s:\n{tail}")
        if not self._serving():  # it exited first: say its own last word, in one line
            self.stop()
            raise _start_error(self.lines)

    def _read(self) -> None:
        assert self._proc.stdout is not None
        for raw in self._proc.stdout:
            line = _ANSI.sub("", raw)
            self.lines.append(line)
            if (g := _GRPC_LINE.search(line)) is not None:
                self.grpc = (g.group(1), int(g.group(2)))
            if (w := _WEB_LINE.search(line)) is not None:
                self.web = (w.group(1), int(w.group(2)))
            if self._serving():
                self._ready.set()
        self._ready.set()  # exited: let the waiter see it

    def _serving(self) -> bool:
        return self.grpc is not None and (self.web is not None or not self._wants_web)

    @property
    def grpc_url(self) -> str:
        if self.grpc is None:
            raise ViewerError("rerun exited before serving gRPC:\n" + "".join(self.lines[-20:]))
        host = "127.0.0.1" if self.grpc[0] in ("0.0.0.0", "::", "[::]") else self.grpc[0]
        return f"rerun+http://{host}:{self.grpc[1]}/proxy"

    @property
    def web_url(self) -> str:
        """The page to open: the web viewer, pointed at this process's gRPC proxy."""
        if self.web is None:
            raise ViewerError("rerun is not hosting a web viewer")
        host = "127.0.0.1" if self.web[0] in ("0.0.0.0", "::", "[::]") else self.web[0]
        return f"http://{host}:{self.web[1]}/?url={self.grpc_url}"

    def alive(self) -> bool:
        return self._proc.poll() is None

    def stop(self, timeout_s: float = 5.0) -> None:
        if self._proc.poll() is None:
            self._proc.send_signal(signal.SIGTERM)
            try:
                self._proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()


def _start_error(lines: list[str]) -> ViewerError:
    """Why a rerun child exited before serving, from its output, as one line."""
    text = "".join(lines)
    taken = _IN_USE.search(text)
    if taken is not None:
        return PortInUse(f"port {taken['port']} on {taken['host']} is in use by another program")
    said = [line.strip() for line in lines if line.strip()]
    errors = [line for line in said if line.startswith("Error:") or " ERROR " in line]
    last = (errors or said or ["(it printed nothing)"])[-1]
    return ViewerError(f"rerun viewer exited before serving: {last}")


def serve_web(host: str = "127.0.0.1", web_port: int = 0, grpc_port: int = 0) -> ViewerProcess:
    """A web viewer and its gRPC proxy, bound to `host` only."""
    args = ["--serve-web", "--bind", host, "--port", str(grpc_port)]
    args += ["--web-viewer-port", str(web_port), "--server-memory-limit", "512MiB"]
    return ViewerProcess(args, wants_web=True)


def spawn_native(host: str = "127.0.0.1", grpc_port: int = 0) -> ViewerProcess:
    """A native viewer window (needs a display), listening on `host` only."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ViewerError(
            "--spawn needs a display (DISPLAY/WAYLAND_DISPLAY); use --serve or --save"
        )
    return ViewerProcess(["--bind", host, "--port", str(grpc_port)], wants_web=False)


class ViewOutput:
    """An explicit recording stream wired to the chosen outputs; close() flushes and stops."""

    def __init__(self, outputs: Outputs, recording_id: str | None = None) -> None:
        if not outputs.any():
            raise ViewerError(
                "choose an output: --spawn, --serve, --connect rerun+http://... or --save FILE.rrd"
            )
        self.rec = rr.RecordingStream(
            APPLICATION_ID, recording_id=recording_id or str(uuid.uuid4())
        )
        self.viewers: list[ViewerProcess] = []
        sinks: list[rr.LogSinkLike] = []
        try:
            if outputs.serve:
                self.viewers.append(
                    serve_web(outputs.serve_host, outputs.web_port, outputs.grpc_port)
                )
            if outputs.spawn:
                self.viewers.append(spawn_native(outputs.serve_host))
        except ViewerError:
            self.close()
            raise
        sinks += [rr.GrpcSink(v.grpc_url) for v in self.viewers]
        if outputs.connect:
            sinks.append(rr.GrpcSink(outputs.connect))
        if outputs.save:
            sinks.append(rr.FileSink(str(outputs.save)))
        self.rec.set_sinks(*sinks, default_blueprint=default_blueprint())

    @property
    def web_url(self) -> str | None:
        web = [v for v in self.viewers if v.web is not None]
        return web[0].web_url if web else None

    def close(self, keep_viewers: bool = False) -> None:
        """Flush everything logged; stop served/spawned viewers unless asked to keep them."""
        try:
            self.rec.flush(timeout_sec=10.0)
            self.rec.disconnect()
        finally:
            if not keep_viewers:
                for viewer in self.viewers:
                    viewer.stop()


def wait_forever_or(stop: threading.Event, viewers: list[ViewerProcess]) -> None:
    """After a recording is rendered into a served viewer: keep serving until Ctrl-C."""
    while not stop.is_set() and all(v.alive() for v in viewers):
        stop.wait(0.5)
