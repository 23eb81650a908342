"""The session tab: start and stop the lab's processes, read their logs live, see who is in.

A thin view over `Lab`: every button calls one of its methods, every table is rebuilt from
its state by a timer, so two browsers on one launcher show the same thing.
"""

from __future__ import annotations

import math
from collections.abc import Awaitable, Callable
from typing import Any

from nicegui import run, ui

from carlaverse.config import shipped_dir
from carlaverse.keys import KeySpaceError
from carlaverse.launcher.hmi_pairing import EVERY_ADDRESS, LOOPBACK
from carlaverse.launcher.lab import Lab
from carlaverse.launcher.panel_pairing import pairing_panel
from carlaverse.launcher.presence import PresenceRow
from carlaverse.launcher.processes import LaunchError
from carlaverse.procs import Child

REFRESH_S = 0.5  # [s] tables and logs follow the lab this often
PROCESS_COLUMNS = [
    {"name": "name", "label": "process", "field": "name", "align": "left"},
    {"name": "role", "label": "role", "field": "role", "align": "left"},
    {"name": "state", "label": "state", "field": "state", "align": "left"},
    {"name": "pid", "label": "pid", "field": "pid"},
]
PRESENCE_COLUMNS = [
    {"name": k, "label": label, "field": k, "align": "left" if k in ("node_id", "kind", "site")
     else "right"}
    for k, label in (("node_id", "node"), ("kind", "kind"), ("site", "site"),
                     ("rate_hz", "rate Hz"), ("latency_p50_ms", "p50 ms"),
                     ("latency_p99_ms", "p99 ms"), ("loss", "loss"), ("last_seen_s", "last s"))
]  # fmt: skip


def session_panel(lab: Lab) -> None:
    with ui.row().classes("w-full no-wrap items-start gap-4"):
        with ui.column().classes("w-1/3 gap-3"):
            _start_cards(lab)
        with ui.column().classes("w-2/3 gap-3"):
            _processes_and_logs(lab)
            pairing_panel(lab)
            _presence(lab)


async def _act(action: Callable[..., object], *args: object) -> None:
    """Run a lab action off the page's event loop (stopping waits for children); a refusal
    becomes a one-line notice, not a traceback."""
    try:
        await run.io_bound(action, *args)
    except (LaunchError, KeySpaceError) as exc:
        ui.notify(str(exc), type="negative", multi_line=True)


def _start_cards(lab: Lab) -> None:
    _demo_card(lab)
    _router_card(lab)
    _node_card(lab)


def _card(title: str, note: str = "") -> ui.card:
    card = ui.card().classes("w-full")
    with card:
        ui.label(title).classes("text-lg font-medium")
        if note:
            ui.label(note).classes("text-xs text-gray-500")
    return card


def _demo_card(lab: Lab) -> None:
    with _card("Demo", "what `carlaverse demo` runs: router, authority, scripted nodes"):
        kinds = ui.input("node kinds", value="scripted,scripted,scripted")
        kinds.props("dense data-testid=demo-kinds")
        with ui.row().classes("no-wrap"):
            duration = ui.number("duration s", value=120, min=1).props("dense")
            scenario = ui.input("scenario", value="town").props("dense data-testid=demo-scenario")

        def start() -> Awaitable[None]:
            seconds = float(duration.value or 1)
            return _act(lab.start_demo, _kinds(kinds.value), seconds, scenario.value)

        ui.button("Start demo", icon="play_arrow", on_click=start).props("data-testid=start-demo")


def _router_card(lab: Lab) -> None:
    with _card("Router and authority", f"session {lab.session!r} on {lab.endpoint}"):
        ui.button("Start router", on_click=lambda: _act(lab.start_router))
        scenario = ui.input("scenario", value="town").props("dense")
        ui.button("Start authority", on_click=lambda: _act(lab.start_authority, scenario.value))


def _node_card(lab: Lab) -> None:
    with _card("Node", "joins the lab's session; no config: headless on sim devices"):
        kind = ui.select(lab.node_kinds, label="kind", value="scripted")
        kind.props("dense data-testid=node-kind")
        node_id = ui.input("id", value="node-1").props("dense data-testid=node-id")
        config = ui.input(
            "config file (optional)",
            placeholder="in the config dir, or a shipped name",
            autocomplete=_shipped(),
        )
        config.props("dense data-testid=node-config")
        hmi_port, hmi_bind = _hmi_fields()

        def start() -> Awaitable[None]:
            port = None if hmi_port.value is None else int(hmi_port.value)
            return _act(
                lab.start_node, kind.value, node_id.value, config.value, port, hmi_bind.value
            )

        ui.button("Start node", on_click=start).props("data-testid=start-node")


def _hmi_fields() -> tuple[ui.number, ui.select]:
    """The node's web HMI (drive, bike): a port, empty for none, and the address it serves on."""
    with ui.row().classes("no-wrap items-end"):
        port = ui.number("HMI port", placeholder="none", min=1, max=65535, precision=0)
        port.props("dense clearable data-testid=node-hmi-port")
        bind = ui.select(
            {LOOPBACK: "this machine only", EVERY_ADDRESS: "this machine's network address"},
            label="HMI served to",
            value=LOOPBACK,
        ).props("dense data-testid=node-hmi-bind")
    warning = ui.label(
        "Anyone on the network can reach this HMI: it asks for a pairing token, shown as a QR "
        "code under Processes for a cabin tablet to scan. Plain HTTP: use a network you trust."
    ).classes("text-xs text-orange-700")
    warning.bind_visibility_from(bind, "value", backward=lambda v: v != LOOPBACK)
    return port, bind


def _shipped() -> list[str]:
    """Names of the shipped node configs, offered as the config field is typed."""
    return sorted(p.stem for p in shipped_dir().glob("*.yaml"))


def _kinds(text: str) -> list[str]:
    return [k.strip() for k in text.split(",") if k.strip()]


def _processes_and_logs(lab: Lab) -> None:
    selected: dict[str, Any] = {"name": "", "next": 0}
    with ui.card().classes("w-full"):
        with ui.row().classes("w-full items-center"):
            ui.label("Processes").classes("text-lg font-medium")
            ui.space()
            stop_all = ui.button(
                "Stop everything",
                color="negative",
                icon="stop",
                on_click=lambda: _act(lab.stop_all),
            )
            stop_all.props("data-testid=stop-all")
        table = ui.table(rows=[], columns=PROCESS_COLUMNS, row_key="name")
        table.classes("w-full cursor-pointer").props("dense flat data-testid=processes")
        table.props('no-data-label="nothing started yet"')
        with ui.row().classes("items-center"):
            log_title = ui.label("log: click a process").classes("font-mono text-sm")
            stop_one = ui.button("", on_click=lambda: _act(lab.stop, selected["name"]))
            stop_one.props("dense flat color=negative data-testid=stop-selected")
            stop_one.set_visibility(False)
        log = ui.log(max_lines=1000).classes("w-full h-64 text-xs").props("data-testid=log")

    def choose(name: str) -> None:
        selected["name"], selected["next"] = name, 0
        log.clear()
        log_title.text = f"log: {name}"
        stop_one.text = f"stop {name}"
        stop_one.set_visibility(True)

    table.on("rowClick", lambda e: choose(e.args[1]["name"]))

    def refresh() -> None:
        rows = [_process_row(c) for c in lab.supervisor.snapshot()]
        if rows != table.rows:
            table.rows = rows
            table.update()
        if selected["name"]:
            selected["next"], lines = lab.supervisor.lines(selected["name"], selected["next"])
            for line in lines:
                log.push(line)

    ui.timer(REFRESH_S, refresh)


def _process_row(child: Child) -> dict[str, object]:
    state = "running" if child.running else f"exited {child.exit_code}"
    return {"name": child.name, "role": child.role, "state": state, "pid": child.proc.pid}


def _presence(lab: Lab) -> None:
    with ui.card().classes("w-full"):
        ui.label("Who is in the session").classes("text-lg font-medium")
        ui.label("as `carlaverse stats` measures it: pose rate, one-way latency, loss").classes(
            "text-xs text-gray-500"
        )
        authority = ui.label(lab.authority_line()).props("data-testid=authority-status")
        table = ui.table(rows=[], columns=PRESENCE_COLUMNS, row_key="node_id")
        table.classes("w-full").props("dense flat data-testid=presence")
        table.props('no-data-label="nobody is in the session"')

    def refresh() -> None:
        authority.text = lab.authority_line()
        rows = [_presence_row(r) for r in lab.presence()]
        if rows != table.rows:
            table.rows = rows
            table.update()

    ui.timer(REFRESH_S, refresh)


def _presence_row(row: PresenceRow) -> dict[str, object]:
    def number(value: float, fmt: str) -> str:
        return "-" if math.isnan(value) else format(value, fmt)

    return {
        "node_id": row.node_id,
        "kind": row.kind,
        "site": row.site or "-",
        "rate_hz": number(row.rate_hz, ".1f"),
        "latency_p50_ms": number(row.latency_p50_ms, ".2f"),
        "latency_p99_ms": number(row.latency_p99_ms, ".2f"),
        "loss": number(row.loss, ".1%"),
        "last_seen_s": number(row.last_seen_s, ".1f"),
    }
