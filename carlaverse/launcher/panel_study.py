"""The study tab: start a study run, follow its trials, pause, resume, abort or redo them.

A thin view over `StudyRuns`: the table is rebuilt from the run's log by a timer, so a run
started from a terminal and opened here reads the same; the buttons write the same control
file `carlaverse study control` writes.
"""

from __future__ import annotations

from nicegui import run, ui

from carlaverse.launcher.processes import LaunchError
from carlaverse.launcher.study_runs import StudyRuns
from carlaverse.study.status import RunStatus, TrialRow

REFRESH_S = 1.0  # [s] the table follows the log this often
COLUMNS = [
    {"name": k, "label": label, "field": k, "align": "left"}
    for k, label in (("trial", "trial"), ("attempts", "attempts"), ("outcome", "outcome"),
                     ("conditions", "conditions"), ("time", "time (UTC)"),
                     ("view", "view error p95"), ("notes", "notes"))
]  # fmt: skip
COMMANDS = ("pause", "resume", "redo", "abort")


def study_panel(runs: StudyRuns) -> None:
    with ui.card().classes("w-full"):
        ui.label("Study").classes("text-lg font-medium")
        ui.label(
            "runs `carlaverse study run FILE --out FOLDER`: each trial a fresh recorded session; "
            "both names are inside the config dir"
        ).classes("text-xs text-gray-500")
        with ui.row().classes("items-end"):
            study_file = ui.input("study file").props("dense data-testid=study-file")
            folder = ui.input("run folder", value="study-runs/run-1")
            folder.props("dense data-testid=study-out")
            start = ui.button(
                "Start", on_click=lambda: _act(runs.start, study_file.value, folder.value)
            )
            start.props("data-testid=study-start")
            follow = ui.button("Open", on_click=lambda: _act(runs.open, folder.value))
            follow.props("outline data-testid=study-open")
        with ui.row().classes("items-end"):
            for name in COMMANDS:
                button = ui.button(name, on_click=lambda n=name: _act(runs.send, n))
                button.props(f"outline data-testid=study-{name}")
            note = ui.input("note").props("dense data-testid=study-note-text")
            ui.button("note", on_click=lambda: _act(runs.send, f"note {note.value}")).props(
                "outline data-testid=study-note"
            )
        state = ui.label("no run followed").props("data-testid=study-state")
        table = ui.table(columns=COLUMNS, rows=[], row_key="trial")
        table.classes("w-full").props("dense data-testid=study-trials")

    def refresh() -> None:
        status = runs.status()
        state.set_text(_state_line(status))
        table.rows = [] if status is None else _rows(status)
        table.update()

    ui.timer(REFRESH_S, refresh)


async def _act(action: object, *args: object) -> None:
    """Run it off the page's loop; a refusal is a one-line notice."""
    try:
        await run.io_bound(action, *args)  # type: ignore[arg-type]
    except LaunchError as exc:
        ui.notify(str(exc), type="negative", multi_line=True)


def _state_line(status: RunStatus | None) -> str:
    if status is None:
        return "no run followed (or no log yet)"
    return f"study {status.study}: {status.state}, {status.completed} trials completed"


def _rows(status: RunStatus) -> list[dict[str, object]]:
    return [_row(row) for row in status.trials]


def _row(row: TrialRow) -> dict[str, object]:
    return {
        "trial": row.trial,
        "attempts": row.attempts,
        "outcome": row.outcome,
        "conditions": ", ".join(f"{p}: {c}" for p, c in row.conditions.items()),
        "time": f"{row.started[11:19]}–{row.ended[11:19]}",
        "view": ", ".join(f"{pair} {m:.2f} m" for pair, m in row.view_p95_m.items()),
        "notes": "; ".join(row.notes),
    }
