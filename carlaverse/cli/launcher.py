"""`carlaverse launcher`: a local web app to run a lab's session from a browser."""

from __future__ import annotations

import argparse
import ipaddress
import os
import socket
import sys
from pathlib import Path

from carlaverse.cli.common import fail
from carlaverse.config import ConfigError
from carlaverse.keys import KeySpaceError, check_token
from carlaverse.procs import free_port

DEFAULT_PORT = 8470


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Serve the launcher, a web app for this machine: start and stop a router, an "
        "authority and nodes and read their logs live; see who is in the session, from which "
        "site, with latency and loss (as `carlaverse stats`); edit node configs in a tree "
        "generated from their schemas, checked by the nodes' own strict decoder and saved only "
        "when valid; test hardware (FFB pulses, joystick axes and buttons, motion neutral, "
        "trainer scan; simulated devices when none is plugged in); start the demo in one click. "
        "Stopping the launcher (Ctrl-C, SIGTERM) stops every process it started. "
        "Each launch makes a new token: the printed URL carries it once (?token=...) and the "
        "browser then keeps it in a cookie; scripts read it from "
        "$XDG_RUNTIME_DIR/carlaverse/launcher-PORT.token (mode 0600, removed at exit) and send "
        "'Authorization: Bearer TOKEN'. Requests without it, from a Host not allowed or from "
        "another site's page are refused. Files are opened and saved only inside --config-dir."
    )
    parser.add_argument(
        "--port", type=int, default=DEFAULT_PORT, help=f"HTTP port (default {DEFAULT_PORT})"
    )
    parser.add_argument(
        "--bind",
        default="127.0.0.1",
        metavar="ADDR",
        help="address to serve on (default 127.0.0.1: this machine only; the page starts "
        "processes, so expose it on purpose or tunnel with ssh -L)",
    )
    parser.add_argument(
        "--allow-host",
        action="append",
        default=[],
        metavar="NAME",
        help="a name the browser may use to reach the launcher, besides 127.0.0.1, localhost, "
        "[::1] and the --bind address (repeatable); requests naming any other Host are refused, "
        "which stops DNS rebinding",
    )
    parser.add_argument("--no-browser", action="store_true", help="do not open a browser")
    parser.add_argument("--session", default="lab", help="session the lab runs (default lab)")
    parser.add_argument(
        "--router",
        metavar="EP",
        help="endpoint the lab's router listens on and every child connects to "
        "(default tcp/127.0.0.1:<a free port>)",
    )
    parser.add_argument(
        "--config-dir",
        type=Path,
        default=Path.cwd(),
        metavar="DIR",
        help="the folder the page may open and save configs in and start nodes with (besides "
        "the shipped configs); nothing outside it is read or written (default: the working "
        "directory)",
    )


def run(args: argparse.Namespace) -> int:
    try:
        check_token(args.session, "session name")  # before the web stack's seconds of import
        from carlaverse.launcher import token_file
        from carlaverse.launcher.app import serve
        from carlaverse.launcher.files import ConfigDir
        from carlaverse.launcher.lab import Lab
        from carlaverse.web_policy import new_token

        files = ConfigDir(args.config_dir)
    except (KeySpaceError, ConfigError) as exc:
        return fail("launcher", str(exc))
    except ModuleNotFoundError as exc:
        return fail("launcher", f"needs {exc.name}: pip install 'carlaverse[launcher]'")
    if not _loopback(args.bind):
        print(f"carlaverse launcher: serving on {args.bind}, reachable from the network; its "
              "token travels in clear HTTP there: prefer ssh -L", file=sys.stderr)  # fmt: skip
    if not _port_free(args.bind, args.port):  # before the token file of a launcher there
        return fail("launcher", f"port {args.port} on {args.bind} is in use; choose --port")
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # joysticks without a display
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    token = new_token()
    url = f"http://{_url_host(args.bind)}:{args.port}/?token={token}"
    try:
        written = [token_file.write_token(args.port, token)]
        if not args.no_browser:
            written.append(token_file.write_opener(args.port, url))
    except OSError as exc:
        return fail("launcher", f"cannot write the token file: {exc}")
    lab = Lab(args.session, args.router or f"tcp/127.0.0.1:{free_port()}", files)

    def remove_token_files() -> None:
        for path in written:
            token_file.remove(path)

    try:
        serve(lab, token, args.bind, args.port, args.allow_host,
              open_page=None if args.no_browser else written[1],
              on_ready=lambda: print(f"launcher at {url}", flush=True),
              on_stop=remove_token_files)  # fmt: skip
    finally:
        lab.close()  # also when the server failed to start: nothing is left behind
        remove_token_files()
    return 0


def _port_free(address: str, port: int) -> bool:
    family = socket.AF_INET6 if ":" in address else socket.AF_INET
    with socket.socket(family) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn binds
        try:
            probe.bind((address, port))
        except OSError:
            return False
    return True


def _url_host(address: str) -> str:
    return f"[{address}]" if ":" in address else address


def _loopback(address: str) -> bool:
    try:
        return ipaddress.ip_address(address).is_loopback
    except ValueError:
        return address == "localhost"
