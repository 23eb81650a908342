"""A report a researcher reads first: the map, every trajectory, the conflicts, the numbers.

`report.png` draws the road network the authority served (lanes at their widths, areas),
NPC paths thin and grey, human paths in colour, and marks the worst TTC instant of each
critical pair and every crossing conflict below the thresholds. `report.html` shows that
picture and the summary, says what was left out and why (queues, implausible DRAC), and
lists the pairs with a participant first, the conflicts, and who each id is.
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display here or on a lab's analysis server
import matplotlib.pyplot as plt
from matplotlib.collections import LineCollection

from carlaverse import messages as m
from carlaverse.analysis.surrogate import Conflict, PairMeasures, Thresholds
from carlaverse.analysis.tracks import Tracks

AREA_COLOURS = {"vegetation": "#cfe8c4", "water": "#bcd7f0", "building": "#d9d4cc"}
MAX_ROWS = 25  # per table: the worst first


def draw(
    path: Path,
    tracks: Tracks,
    road_map: m.MapReply | None,
    pairs: list[PairMeasures],
    conflicts: list[Conflict],
    th: Thresholds,
    start: float = 0.0,
) -> None:
    """The picture; each critical mark labelled with its time in seconds after `start`."""
    fig, ax = plt.subplots(figsize=(10, 10), dpi=110)
    if road_map is not None:
        _draw_map(ax, road_map)
    _draw_tracks(ax, tracks)
    _mark_conflicts(ax, tracks, pairs, conflicts, th, start)
    ax.set_aspect("equal")
    ax.set_xlabel("x (east) [m]")
    ax.set_ylabel("y (north) [m]")
    ax.legend(loc="upper right", fontsize=8)
    span = f"{tracks.t[0] - start:.1f}–{tracks.t[-1] - start:.1f} s from start"  # never empty
    ax.set_title(f"{len(tracks.actors)} road users, {len(conflicts)} crossing conflicts, {span}")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _draw_map(ax: plt.Axes, road_map: m.MapReply) -> None:
    for area in road_map.areas:
        if area.kind in AREA_COLOURS and len(area.polygon) >= 3:
            ax.fill(*zip(*area.polygon, strict=True), color=AREA_COLOURS[area.kind], zorder=0)
    for lane in road_map.lanes:
        if len(lane.centerline) >= 2:
            colour = "#bbbbbb" if lane.kind == "road" else "#e2e2e2"
            ax.plot(*zip(*lane.centerline, strict=True), color=colour, zorder=1,
                    linewidth=max(0.5, lane.width * 1.5), solid_capstyle="butt")  # fmt: skip


def _draw_tracks(ax: plt.Axes, tracks: Tracks) -> None:
    npc = [_segments(tracks, i) for i, a in enumerate(tracks.actors) if not a.human]
    ax.add_collection(LineCollection([s for s in npc if len(s)], colors="#888888",
                                     linewidths=0.6, zorder=2, label="NPCs"))  # fmt: skip
    colours = plt.get_cmap("tab10")
    for n, (i, actor) in enumerate((i, a) for i, a in enumerate(tracks.actors) if a.human):
        ax.plot(tracks.x[i], tracks.y[i], color=colours(n % 10), linewidth=1.6, zorder=3,
                label=f"{actor.id} ({actor.kind})")  # fmt: skip
    ax.autoscale_view()


def _segments(tracks: Tracks, i: int) -> list[tuple[float, float]]:
    keep = tracks.present[i]
    return list(zip(tracks.x[i, keep], tracks.y[i, keep], strict=True))


def _mark_conflicts(ax, tracks: Tracks, pairs, conflicts, th: Thresholds, start: float) -> None:
    critical = [p for p in pairs if p.min_ttc_s < th.ttc_s and not math.isnan(p.t_min_ttc)]
    for p in critical:
        k = int(abs(tracks.t - p.t_min_ttc).argmin())
        i = tracks.index(p.a)
        ax.scatter(tracks.x[i, k], tracks.y[i, k], marker="o", s=60, facecolors="none",
                   edgecolors="#d62728", zorder=4)  # fmt: skip
        _label(ax, tracks.x[i, k], tracks.y[i, k], p.t_min_ttc - start)
    close = [c for c in conflicts if c.pet_s < th.ttc_s]
    if close:
        ax.scatter([c.x for c in close], [c.y for c in close], marker="x", s=70,
                   color="#d62728", zorder=5, label=f"PET < {th.ttc_s:g} s")  # fmt: skip
    for c in close:
        _label(ax, c.x, c.y, c.t_second_arrives - start)
    if critical:
        ax.scatter([], [], marker="o", facecolors="none", edgecolors="#d62728",
                   label=f"min TTC < {th.ttc_s:g} s")  # fmt: skip


def _label(ax: plt.Axes, x: float, y: float, at_s: float) -> None:
    """The moment beside its mark, as `render --at` takes it."""
    ax.annotate(f"{at_s:.1f} s", (x, y), xytext=(5, 5), textcoords="offset points",
                fontsize=7, color="#d62728", zorder=6)  # fmt: skip


def write_html(path: Path, image: str, summary: dict, tables: Tables, source: str) -> None:
    """The page: summary, how to read it, the picture, then pairs (humans first), conflicts
    and who the road users named in them are. Times in seconds from the recording's start."""
    pairs = [p for p in tables.pairs if p["human"] or math.isfinite(p["min_ttc_s"])][:MAX_ROWS]
    conflicts = tables.conflicts[:MAX_ROWS]
    named = {p[s] for p in pairs for s in ("a", "b")} | {c[s] for c in conflicts
                                                        for s in ("first", "second")}  # fmt: skip
    actors = [a for a in tables.actors if a["human"] or a["actor"] in named]
    body = [
        f"<h1>Session analysis</h1><p>{html.escape(source)}</p>",
        _table(["measure", "value"], [[k, _fmt(v)] for k, v in summary.items()]),
        _notes(summary, len(tables.pairs) - len(pairs)),
        f'<img src="{html.escape(image)}" alt="map, trajectories and conflicts" width="800">',
        "<h2>Pairs: with a participant first, then lowest TTC</h2>",
        _table(["a", "b", "min TTC [s]", "at [s]", "time below [s]", "min gap [m]",
                "max DRAC [m/s²]", "left out"], [_pair_row(p) for p in pairs]),
        "<h2>Crossing conflicts: with a participant first, then lowest PET</h2>",
        _table(["first", "second", "x [m]", "y [m]", "second arrives at [s]", "PET [s]",
                "angle [°]"],
               [[c["first"], c["second"], _fmt(c["x"]), _fmt(c["y"]),
                 _fmt(c["t_second_arrives_rel_s"]), _fmt(c["pet_s"]), _fmt(c["angle_deg"])]
                for c in conflicts]),
        "<h2>Road users named above</h2>",
        _table(["id", "who", "kind", "seen from [s]", "to [s]", "lanes driven"],
               [[a["actor"], "participant" if a["human"] else "NPC", a["kind"],
                 _fmt(a["first_seen_rel_s"]), _fmt(a["last_seen_rel_s"]), a["route"] or "—"]
                for a in actors]),
    ]  # fmt: skip
    style = "body{font-family:sans-serif;margin:2em}td,th{padding:2px 10px;text-align:left}"
    path.write_text(
        f"<!doctype html><html><head><meta charset='utf-8'><title>CARLAverse analysis</title>"
        f"<style>{style}</style></head><body>{''.join(body)}</body></html>",
        encoding="utf-8",
    )


@dataclass(frozen=True)
class Tables:
    """The rows the page shows, as the tables on disk hold them (`export`)."""

    pairs: list[dict]  # in `surrogate.by_concern` order
    conflicts: list[dict]  # in `surrogate.conflicts_by_concern` order
    actors: list[dict]


def _notes(summary: dict, hidden: int) -> str:
    """How to read the numbers: the origin of times and what was left out, and why."""
    notes = [
        f"Times are seconds from the recording's start (session time "
        f"{summary['recording_start']:.3f} s); <code>carlaverse render FILE --at S</code> "
        "shows that moment.",
        f"Queued: instants with both road users slower than {summary['standstill_mps']:g} m/s "
        "(cars waiting nose to tail at a stop line), and NPCs pulling up into a queue (soon "
        "at rest nose to tail, untouched: the traffic model's car-following) are "
        f"left out of TTC and time below, standing ones out of DRAC too (pairs with such "
        f"instants: "
        f"{summary['pairs_queued']}). A participant pulling up behind a queue keeps its TTC.",
        f"DRAC above {summary['drac_limit_mps2']:g} m/s² is more than a tyre's friction "
        "allows (μg = 9.8 m/s² for μ = 1): no braking avoids contact, and without a contact "
        "the number is an artefact of footprints or sampling. It is left out of max DRAC and "
        f"flagged (pairs with such instants: {summary['pairs_drac_implausible']}).",
    ]
    if hidden:
        notes.append(f"NPC-only pairs never on a collision course are not listed here: "
                     f"{hidden} (pairs.csv has every pair).")  # fmt: skip
    return "<ul>" + "".join(f"<li>{n}</li>" for n in notes) + "</ul>"


def _pair_row(p: dict) -> list[str]:
    left_out = []
    if p["queued_s"] > 0:
        left_out.append(f"queued {_fmt(p['queued_s'])} s")
    if p["drac_implausible_s"] > 0:
        left_out.append(f"DRAC implausible {_fmt(p['drac_implausible_s'])} s "
                        f"(peak {_fmt(p['peak_drac_mps2'])})")  # fmt: skip
    return [_who(p, "a"), _who(p, "b"), _fmt(p["min_ttc_s"]), _fmt(p["t_min_ttc_rel_s"]),
            _fmt(p["ttc_below_s"]), _fmt(p["min_gap_m"]), _fmt(p["max_drac_mps2"]),
            "; ".join(left_out) or "—"]  # fmt: skip


def _who(p: dict, side: str) -> str:
    lane = p[f"{side}_lane"]
    return f"{p[side]} ({p[f'{side}_kind']}{', lane ' + lane if lane else ''})"


def _table(header: list[str], rows: list[list]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    cells = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<table><tr>{head}</tr>{cells}</table>"


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return (
            "—"
            if not math.isfinite(value)
            else f"{value:.3g}"
            if abs(value) < 100
            else f"{value:.1f}"
        )
    if isinstance(value, list):
        return ", ".join(map(str, value))
    return "—" if value is None else str(value)
