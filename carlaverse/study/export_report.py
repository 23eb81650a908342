"""The study export's report: one self-contained HTML file a researcher can send on.

Per-condition summaries (main trials only: practice is not analysed, by the study's design),
plots drawn by matplotlib and inlined as PNG (no external URL, no script), the trial list,
LSL coverage, and a line saying what was left out and why.
"""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Iterable
from pathlib import Path
from statistics import fmean, median
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only: no display on a lab's analysis server
import matplotlib.pyplot as plt

from carlaverse.analysis.surrogate import Thresholds
from carlaverse.study.export_inputs import StudyRun

Rows = list[dict[str, Any]]
SUMMARY_COLUMNS = ("condition", "participant-trials", "distance m (mean)", "min TTC s (median)",
                   "min TTC s (least)", "min PET s (least)", "SSQ total (mean)",
                   "TLX (mean)")  # fmt: skip


def write_report(
    path: Path, run: StudyRun, tables: dict[str, Rows], excluded: list[str], th: Thresholds
) -> Path:
    """Write `path`; return it."""
    main = {name: [r for r in rows if not r.get("practice")] for name, rows in tables.items()}
    conditions = sorted({r["condition"] for r in main["trials"]})
    ttc = _by_condition(_participant_ttc(main["encounters"]), conditions)
    ssq = _by_condition(_scores(main["questionnaires"], "ssq", ("total",)), conditions)
    trial_list = ("trial", "attempt", "kind", "block", "participant", "role", "condition",
                  "outcome", "reason", "live_s", "view_error_p95_m", "notes")  # fmt: skip
    streams = ("trial", "condition", "stream", "samples", "nominal_srate_hz", "coverage", "error")
    body = [
        f"<h1>Study {html.escape(run.study)}</h1>",
        f"<p>{len(run.attempts)} trial attempts, {len(run.completed())} completed; "
        "participants by pseudonym only.</p>",
        "<h2>By condition (main trials)</h2>",
        _summary(main, conditions),
        _figure("Least TTC per participant encounter [s]", ttc, th.ttc_s),
        _figure("SSQ total score", ssq, None),
        "<h2>Trials</h2>",
        _table(tables["trials"], trial_list),
        "<h2>LSL streams</h2>",
        _table(tables["lsl"], streams),
        "<h2>Notes between trials</h2>",
        _list(run.notes or ["none"]),
        "<h2>Left out</h2>",
        _excluded(tables, excluded),
    ]
    path.write_text(_page(f"Study {run.study}", "\n".join(body)))
    return path


def _participant_ttc(encounters: Rows) -> Iterable[tuple[str, float]]:
    for r in encounters:
        if r["participant_involved"] and math.isfinite(r["min_ttc_s"]):
            yield r["condition"], r["min_ttc_s"]


def _scores(rows: Rows, questionnaire: str, names: tuple[str, ...]) -> Iterable[tuple[str, float]]:
    for r in rows:
        if (r["questionnaire"] == questionnaire and r["measure_kind"] == "score"
                and r["measure"] in names):  # fmt: skip
            yield r["condition"], r["value"]


def _by_condition(pairs: Iterable[tuple[str, float]], conditions: list[str]) -> dict[str, list]:
    out: dict[str, list[float]] = {c: [] for c in conditions}
    for condition, value in pairs:
        out.setdefault(condition, []).append(value)
    return out


def _summary(main: dict[str, Rows], conditions: list[str]) -> str:
    ttc = _by_condition(_participant_ttc(main["encounters"]), conditions)
    pet = _by_condition(((r["condition"], r["min_pet_s"]) for r in main["encounters"]
                         if r["participant_involved"] and math.isfinite(r["min_pet_s"])),
                        conditions)  # fmt: skip
    dist = _by_condition(((r["condition"], r["distance_m"]) for r in main["trajectories"]),
                         conditions)  # fmt: skip
    ssq = _by_condition(_scores(main["questionnaires"], "ssq", ("total",)), conditions)
    tlx_names = ("weighted_tlx", "raw_tlx")
    tlx = _by_condition(_scores(main["questionnaires"], "nasa-tlx", tlx_names[:1]), conditions)
    for c, v in _scores(main["questionnaires"], "raw-tlx", tlx_names[1:]):
        tlx.setdefault(c, []).append(v)
    done = [r for r in main["trials"] if r["outcome"] == "completed"]
    rows = [{"condition": c, "participant-trials": sum(r["condition"] == c for r in done),
             "distance m (mean)": _f(dist[c], fmean), "min TTC s (median)": _f(ttc[c], median),
             "min TTC s (least)": _f(ttc[c], min), "min PET s (least)": _f(pet[c], min),
             "SSQ total (mean)": _f(ssq[c], fmean), "TLX (mean)": _f(tlx[c], fmean)}
            for c in conditions]  # fmt: skip
    return _table(rows, SUMMARY_COLUMNS)


def _f(values: list[float], how: Any) -> str:
    return f"{how(values):.2f}" if values else "–"


def _figure(title: str, by_condition: dict[str, list[float]], line: float | None) -> str:
    if not any(by_condition.values()):
        return f"<p>{html.escape(title)}: no values.</p>"
    names = list(by_condition)
    fig, ax = plt.subplots(figsize=(6, 3.2), dpi=100)
    for x, name in enumerate(names):
        values = by_condition[name]
        ax.scatter([x] * len(values), values, alpha=0.7)
        if values:
            ax.hlines(median(values), x - 0.25, x + 0.25, color="black")
    if line is not None:
        ax.axhline(line, color="red", linestyle="--", linewidth=1, label="threshold")
        ax.legend(loc="best")
    ax.margins(y=0.15)
    ax.set_xticks(range(len(names)), names)
    ax.set_title(title)
    ax.set_xlabel("condition (bar: median)")
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    data = base64.b64encode(buffer.getvalue()).decode()
    return f'<figure><img alt="{html.escape(title)}" src="data:image/png;base64,{data}"></figure>'


def _table(rows: Rows, columns: tuple[str, ...]) -> str:
    if not rows:
        return "<p>none</p>"
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(_cell(r.get(c)))}</td>" for c in columns) + "</tr>"
        for r in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "–" if math.isnan(value) else f"{value:.3g}"
    return "" if value is None else str(value)


def _excluded(tables: dict[str, Rows], excluded: list[str]) -> str:
    practice = sorted({r["trial"] for r in tables["trials"] if r.get("practice")})
    lines = [
        f"Practice trials ({', '.join(practice) or 'none'}) are in the tables but not in the "
        "per-condition summaries: the design runs them to learn, not to analyse.",
        "An infinite TTC (never on a collision course) and NPC-only pairs are not in the TTC "
        "summaries (a pair of two participants counts once for each, in their own "
        "condition); a DRAC beyond the friction limit is flagged and kept out of max DRAC.",
        *excluded,
    ]
    return _list(lines)


def _list(lines: list[str]) -> str:
    return "<ul>" + "".join(f"<li>{html.escape(line)}</li>" for line in lines) + "</ul>"


def _page(title: str, body: str) -> str:
    style = ("body{font-family:sans-serif;margin:2em;max-width:70em}"
             "table{border-collapse:collapse;margin:1em 0}"
             "td,th{border:1px solid #bbb;padding:2px 6px;font-size:90%}"
             "th{background:#eee}")  # fmt: skip
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>"
            f"{html.escape(title)}</title><style>{style}</style></head>\n<body>\n{body}\n"
            "</body></html>\n")  # fmt: skip
