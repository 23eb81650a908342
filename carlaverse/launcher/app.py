"""The launcher's web app (NiceGUI): one page with a tab per job, served on this machine.

NiceGUI is imported here and in the `panel_*` modules only, so the rest of the launcher (the
supervisor, the drafts, the checks) is plain Python its tests drive directly. Stopping the
server — Ctrl-C, SIGTERM, or closing the launcher otherwise — stops every process it started.

Every request passes the door first (`launcher.door`: token, Host, Origin, no framing), so a
request without the launch token never reaches NiceGUI and no page is built for it; the page's
files are the config dir's (`launcher.files`).
"""

from __future__ import annotations

import socket
import threading
import time
import webbrowser
from collections.abc import Callable
from pathlib import Path

from nicegui import app, ui

from carlaverse.launcher.door import Door, HostPolicy, cookie_name
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.lab import Lab
from carlaverse.launcher.panel_config import ConfigEditor
from carlaverse.launcher.panel_hardware import hardware_panel
from carlaverse.launcher.panel_session import session_panel
from carlaverse.launcher.panel_study import study_panel
from carlaverse.launcher.study_runs import StudyRuns

TITLE = "CARLAverse launcher"


BROWSER_WAIT_S = 30.0  # [s] the page is opened once the port listens, or not at all


def build_page(lab: Lab, files: ConfigDir, studies: StudyRuns) -> None:
    """The page every browser gets; each builds its own widgets over the one shared lab."""
    with ui.header().classes("items-center bg-slate-800"):
        ui.label(TITLE).classes("text-xl font-medium")
        ui.label(f"session {lab.session} · router {lab.endpoint}").classes("text-sm opacity-80")
    with ui.tabs().classes("w-full") as tabs:
        session_tab = ui.tab("Session", icon="hub")
        config_tab = ui.tab("Config", icon="account_tree")
        hardware_tab = ui.tab("Hardware", icon="sports_esports")
        study_tab = ui.tab("Study", icon="science")
    with ui.tab_panels(tabs, value=session_tab).classes("w-full"):
        with ui.tab_panel(session_tab):
            session_panel(lab)
        with ui.tab_panel(config_tab):
            ConfigEditor(files)
        with ui.tab_panel(hardware_tab):
            hardware_panel(files)
        with ui.tab_panel(study_tab):
            study_panel(studies)


def serve(
    lab: Lab,
    token: str,
    host: str,
    port: int,
    allow_hosts: list[str],
    open_page: Path | None = None,
    on_ready: Callable[[], None] = lambda: None,
    on_stop: Callable[[], None] = lambda: None,
) -> None:
    """Serve until stopped (`on_ready` once started); then stop all `lab` started, and call
    `on_stop` (a SIGTERM ends the process right after this shutdown).

    Only requests with `token` from an allowed Host get in; `open_page` (a local file that
    forwards to the token URL) is opened in a browser once the port listens.
    """
    studies = StudyRuns(lab.files, lab.supervisor)  # one study run per lab, every page sees it
    ui.page("/", title=TITLE)(lambda: build_page(lab, lab.files, studies))
    app.add_middleware(
        Door, token=token, hosts=HostPolicy(host, allow_hosts), cookie=cookie_name(port)
    )
    app.on_startup(on_ready)
    if open_page is not None:
        app.on_startup(lambda: _open_when_listening(host, port, open_page))
    app.on_shutdown(lab.close)
    app.on_shutdown(on_stop)
    ui.run(
        host=host,
        port=port,
        title=TITLE,
        show=False,  # NiceGUI would open the URL without the token
        reload=False,
        show_welcome_message=False,
        favicon="🚦",
        access_log=False,  # request lines would carry `?token=`
    )


def _open_when_listening(host: str, port: int, page: Path) -> None:
    def wait_and_open() -> None:
        address = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
        deadline = time.monotonic() + BROWSER_WAIT_S
        while time.monotonic() < deadline:
            try:
                socket.create_connection((address, port), timeout=1.0).close()
            except OSError:
                time.sleep(0.1)
                continue
            webbrowser.open(page.as_uri())
            return

    threading.Thread(target=wait_and_open, name="open-browser", daemon=True).start()
