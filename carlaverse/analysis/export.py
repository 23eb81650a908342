"""The analysis as files: road users, trajectories, events, pair measures, conflicts.

Tables are columnar (pyarrow), written once each; CSV beside every Parquet file so a
spreadsheet opens them without a library. Every session time [s] `t…` has a `t…_rel_s` beside
it: seconds from the recording's start, what a plot axis wants and what `carlaverse render
--at` takes to show that moment.

An NPC id is the traffic engine's name for it; `actors` says what each one is (kind, size,
when it was there) and which lanes it drove along (`analysis.lanes`), and the pairs table
names both road users' kinds and lanes at the pair's worst moment.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from carlaverse import messages as m
from carlaverse.analysis.lanes import LaneIndex
from carlaverse.analysis.surrogate import Conflict, PairMeasures, Thresholds, by_concern
from carlaverse.analysis.tracks import Tracks

ROUTE_STEP_S = 1.0  # [s] between the points whose lanes make up a route
ROUTE_SEPARATOR = " > "


def trajectory_table(tracks: Tracks, start: float | None = None) -> pa.Table:
    """One row per actor and grid instant it is present; `t_rel_s` counts from `start` [s,
    session time] (default: the first grid instant)."""
    present = tracks.present
    rows, cols = np.nonzero(present)
    speed = np.hypot(tracks.vx, tracks.vy)
    actor = [tracks.actors[i] for i in range(len(tracks.actors))]
    t0 = start if start is not None else tracks.t[0] if len(tracks.t) else 0.0
    return pa.table(
        {
            "t": tracks.t[cols],
            "t_rel_s": tracks.t[cols] - t0,
            "actor": [actor[i].id for i in rows],
            "kind": [actor[i].kind for i in rows],
            "human": [actor[i].human for i in rows],
            "x_m": tracks.x[present],
            "y_m": tracks.y[present],
            "yaw_rad": tracks.yaw[present],
            "vx_mps": tracks.vx[present],
            "vy_mps": tracks.vy[present],
            "speed_mps": speed[present],
            "length_m": [actor[i].length for i in rows],
            "width_m": [actor[i].width for i in rows],
        }
    )


def record_table(records: Iterable[Any], start: float | None = None) -> pa.Table:
    """A table from dataclass rows (pair measures, conflicts); inf stays inf in Parquet. With
    `start`, each session time `t…` gets `t…_rel_s` beside it."""
    rows = [_with_relative(dataclasses.asdict(r), start) for r in records]
    return pa.Table.from_pylist(rows) if rows else pa.table({})


def _with_relative(row: dict[str, Any], start: float | None) -> dict[str, Any]:
    if start is None:
        return row
    out: dict[str, Any] = {}
    for name, value in row.items():
        out[name] = value
        if name == "t" or name.startswith("t_"):
            out[f"{name}_rel_s"] = value - start  # nan stays nan: no such moment
    return out


def pairs_table(
    pairs: list[PairMeasures], tracks: Tracks, lanes: LaneIndex, start: float
) -> pa.Table:
    """The pair measures, humans first (`surrogate.by_concern`), each road user's kind and
    lane at the pair's worst moment (its least TTC, else its least gap) beside them."""
    rows = []
    for p in by_concern(pairs):
        moment = p.t_min_ttc if math.isfinite(p.t_min_ttc) else p.t_min_gap
        who = {f"{side}_{what}": value for side, actor_id in (("a", p.a), ("b", p.b))
               for what, value in _describe(tracks, lanes, actor_id, moment).items()}  # fmt: skip
        rows.append({**_with_relative(dataclasses.asdict(p), start), **who})
    return pa.Table.from_pylist(rows) if rows else pa.table({})


def _describe(tracks: Tracks, lanes: LaneIndex, actor_id: str, t: float) -> dict[str, Any]:
    i = tracks.index(actor_id)
    k = int(np.abs(tracks.t - t).argmin())
    return {"kind": tracks.actors[i].kind, "lane": lanes.lane_at(tracks.x[i, k], tracks.y[i, k])}


def actors_table(tracks: Tracks, lanes: LaneIndex, start: float) -> pa.Table:
    """Who each id is: human or NPC, kind, size, first and last seen (seconds from the start)
    and the lanes it drove along, in order."""
    dt = float(np.median(np.diff(tracks.t))) if len(tracks.t) > 1 else ROUTE_STEP_S
    step = max(1, round(ROUTE_STEP_S / dt))
    out: dict[str, list[Any]] = {k: [] for k in ACTOR_COLUMNS}
    for i, actor in enumerate(tracks.actors):
        seen = np.flatnonzero(tracks.present[i])
        route = lanes.route(tracks.x[i, seen[::step]], tracks.y[i, seen[::step]])
        values = (actor.id, actor.human, actor.kind, actor.length, actor.width,
                  tracks.t[seen[0]] - start, tracks.t[seen[-1]] - start,
                  route[0] if route else "", route[-1] if route else "",
                  ROUTE_SEPARATOR.join(route))  # fmt: skip
        for column, value in zip(ACTOR_COLUMNS, values, strict=True):
            out[column].append(value)
    return pa.table(out)


ACTOR_COLUMNS = ("actor", "human", "kind", "length_m", "width_m", "first_seen_rel_s",
                 "last_seen_rel_s", "first_lane", "last_lane", "route")  # fmt: skip


def events_table(events: Iterable[m.WorldEvent], start: float | None = None) -> pa.Table:
    """The `world/events` messages: time, type and the rest of each one's fields as JSON;
    with `start`, `t_rel_s` seconds from the recording's start."""
    out: dict[str, list[Any]] = {"t": [], "type": [], "actor": [], "fields": []}
    if start is not None:
        out["t_rel_s"] = []
    for event in events:
        out["t"].append(event.t)
        if start is not None:
            out["t_rel_s"].append(event.t - start)
        out["type"].append(type(event).__struct_config__.tag)
        out["actor"].append(getattr(event, "node_id", "") or getattr(event, "a", ""))
        out["fields"].append(json.dumps(msgspec.to_builtins(event), separators=(",", ":")))
    return pa.table(out)


def write_table(table: pa.Table, directory: Path, name: str) -> list[Path]:
    """`name`.parquet and `name`.csv in `directory`; the paths written."""
    parquet, csv = directory / f"{name}.parquet", directory / f"{name}.csv"
    pq.write_table(table, parquet)
    pa_csv.write_csv(table, csv)
    return [parquet, csv]


def summary(
    tracks: Tracks,
    pairs: list[PairMeasures],
    conflicts: list[Conflict],
    th: Thresholds,
    start: float = 0.0,
) -> dict:
    """What the report's first table says, as JSON-safe numbers (inf and nan as null); the
    `…_at_s` times are seconds from the recording's start (`start`, session time)."""
    humans = [a.id for a in tracks.actors if a.human]
    critical = [p for p in pairs if p.min_ttc_s < th.ttc_s]
    drac = max(pairs, key=lambda p: p.max_drac_mps2, default=None)
    return {
        "duration_s": float(tracks.t[-1] - tracks.t[0]) if len(tracks.t) > 1 else 0.0,
        "recording_start": start,
        "humans": humans,
        "npcs": len(tracks.actors) - len(humans),
        "pairs_measured": len(pairs),
        "pairs_ttc_below_threshold": len(critical),
        "human_pairs_ttc_below_threshold": sum(1 for p in critical if p.human),
        "contacts": sum(1 for p in pairs if p.min_gap_m == 0.0),
        "crossing_conflicts": len(conflicts),
        **_least_ttc("human_", [p for p in pairs if p.human], start),
        **_least_ttc("", pairs, start),
        "min_pet_s": _finite(min((c.pet_s for c in conflicts), default=math.inf)),
        "max_drac_mps2": drac.max_drac_mps2 if drac else 0.0,
        "max_drac_at_s": _finite(drac.t_max_drac - start if drac else math.nan),
        "drac_limit_mps2": th.drac_limit_mps2,
        "pairs_drac_implausible": sum(1 for p in pairs if p.drac_implausible_s > 0),
        "standstill_mps": th.standstill_mps,
        "pairs_queued": sum(1 for p in pairs if p.queued_s > 0),
    }


def _least_ttc(prefix: str, pairs: list[PairMeasures], start: float) -> dict:
    """The least TTC of `pairs`, when (seconds from the start) and between whom."""
    worst = min(pairs, key=lambda p: p.min_ttc_s, default=None)
    if worst is None or not math.isfinite(worst.min_ttc_s):
        return {f"{prefix}min_ttc_s": None, f"{prefix}min_ttc_at_s": None,
                f"{prefix}min_ttc_pair": None}  # fmt: skip
    return {
        f"{prefix}min_ttc_s": worst.min_ttc_s,
        f"{prefix}min_ttc_at_s": worst.t_min_ttc - start,
        f"{prefix}min_ttc_pair": [worst.a, worst.b],
    }


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None
