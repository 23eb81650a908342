"""The analysis as files: trajectories (Parquet and CSV), events, pair measures, conflicts.

Tables are columnar (pyarrow), written once each; CSV beside every Parquet file so a
spreadsheet opens them without a library. Times are session times [s] plus `t_rel_s`, the
seconds since the first trajectory sample, which is what a plot axis wants.
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
from carlaverse.analysis.surrogate import Conflict, PairMeasures
from carlaverse.analysis.tracks import Tracks


def trajectory_table(tracks: Tracks) -> pa.Table:
    """One row per actor and grid instant it is present."""
    present = tracks.present
    rows, cols = np.nonzero(present)
    speed = np.hypot(tracks.vx, tracks.vy)
    actor = [tracks.actors[i] for i in range(len(tracks.actors))]
    t0 = tracks.t[0] if len(tracks.t) else 0.0
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


def record_table(records: Iterable[Any]) -> pa.Table:
    """A table from dataclass rows (pair measures, conflicts); inf stays inf in Parquet."""
    rows = [dataclasses.asdict(r) for r in records]
    return pa.Table.from_pylist(rows) if rows else pa.table({})


def events_table(events: Iterable[m.WorldEvent]) -> pa.Table:
    """The `world/events` messages: time, type and the rest of each one's fields as JSON."""
    out: dict[str, list[Any]] = {"t": [], "type": [], "actor": [], "fields": []}
    for event in events:
        out["t"].append(event.t)
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
    tracks: Tracks, pairs: list[PairMeasures], conflicts: list[Conflict], ttc_s: float
) -> dict:
    """What the report's first table says, as JSON-safe numbers (inf and nan as null)."""
    humans = [a.id for a in tracks.actors if a.human]
    critical = [p for p in pairs if p.min_ttc_s < ttc_s]
    return {
        "duration_s": float(tracks.t[-1] - tracks.t[0]) if len(tracks.t) > 1 else 0.0,
        "humans": humans,
        "npcs": len(tracks.actors) - len(humans),
        "pairs_measured": len(pairs),
        "pairs_ttc_below_threshold": len(critical),
        "contacts": sum(1 for p in pairs if p.min_gap_m == 0.0),
        "crossing_conflicts": len(conflicts),
        "min_ttc_s": _finite(min((p.min_ttc_s for p in pairs), default=math.inf)),
        "min_pet_s": _finite(min((c.pet_s for c in conflicts), default=math.inf)),
    }


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None
