"""The launcher's web app (NiceGUI): one page with a tab per job, served on this machine.

NiceGUI is imported here and in the `panel_*` modules only, so the rest of the launcher (the
supervisor, the drafts, the checks) is plain Python its tests drive directly. Stopping the
server — Ctrl-C, SIGTERM, or closing the launcher otherwise — stops every process it started.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from nicegui import app, ui

from carlaverse.launcher.lab import Lab
from carlaverse.launcher.panel_config import ConfigEditor
from carlaverse.launcher.panel_hardware import hardware_panel
from carlaverse.launcher.panel_session import session_panel

TITLE = "CARLAverse launcher"


def build_page(lab: Lab, config_dir: Path) -> None:
    """The page every browser gets; each builds its own widgets over the one shared lab."""
    with ui.header().classes("items-center bg-slate-800"):
        ui.label(TITLE).classes("text-xl font-medium")
        ui.label(f"session {lab.session} · router {lab.endpoint}").classes("text-sm opacity-80")
    with ui.tabs().classes("w-full") as tabs:
        session_tab = ui.tab("Session", icon="hub")
        config_tab = ui.tab("Config", icon="account_tree")
        hardware_tab = ui.tab("Hardware", icon="sports_esports")
    with ui.tab_panels(tabs, value=session_tab).classes("w-full"):
        with ui.tab_panel(session_tab):
            session_panel(lab)
        with ui.tab_panel(config_tab):
            ConfigEditor(config_dir)
        with ui.tab_panel(hardware_tab):
            hardware_panel()


def serve(
    lab: Lab,
    config_dir: Path,
    host: str,
    port: int,
    open_browser: bool,
    on_ready: Callable[[], None] = lambda: None,
) -> None:
    """Serve until stopped (`on_ready` once the port listens); then stop all `lab` started."""
    ui.page("/", title=TITLE)(lambda: build_page(lab, config_dir))
    app.on_startup(on_ready)
    app.on_shutdown(lab.close)
    ui.run(
        host=host,
        port=port,
        title=TITLE,
        show=open_browser,
        reload=False,
        show_welcome_message=False,
        favicon="🚦",
    )
