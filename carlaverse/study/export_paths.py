"""Each participant's path in a trial, summarised from their recorded poses as sent.

The analysis resamples every road user onto one grid (`analysis.tracks`), which is what pair
measures need; a path's length and duration want every pose instead: on a 10 Hz grid a
trajectory loses up to 0.1 s at each end (measured on a real two-participant run: 0.9 m of a
28 m path, 3 %). So the trajectory figures come from the poses themselves, the encounter
figures from the grid.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from carlaverse import keys as keyspace
from carlaverse import messages as m
from carlaverse.recording.reading import iter_samples

PATHS = {
    "samples": "poses recorded",
    "duration_s": "[s] from the first recorded pose to the last",
    "distance_m": "[m] path length: the sum of the straight steps between consecutive poses",
    "mean_speed_mps": "[m/s] distance_m / duration_s",
    "max_speed_mps": "[m/s] largest recorded horizontal speed",
    "max_accel_mps2": "[m/s²] largest horizontal acceleration the node sent with its poses; "
    "where it sent none (all zero), the largest |Δv|/Δt between consecutive poses",
    "p95_accel_mps2": "[m/s²] its 95th percentile over the poses (a device that reports "
    "speed in steps, as a trainer's speed sensor does, gives single spikes the maximum keeps)",
    "accel_source": "sent | differentiated: where max_accel_mps2 comes from",
    "first_seen_rel_s": "[s] first pose, from the recording's start",
    "last_seen_rel_s": "[s] last pose, from the recording's start",
}
_COLUMNS = ("t", "x", "y", "vx", "vy", "ax", "ay")


def read_poses(path: Path, node_ids: set[str]) -> dict[str, np.ndarray]:
    """node id -> (N, 7) rows of t, x, y, vx, vy, ax, ay in time order, one per instant."""
    rows: dict[str, list[tuple[float, ...]]] = {}
    for sample in iter_samples(path):
        if sample.kind != "put" or "/ego/" not in sample.key:
            continue
        try:
            key = keyspace.parse(sample.key)
            if key.channel != "pose" or key.node_id not in node_ids:
                continue
            p = m.POSE.decode(sample.payload)
        except (keyspace.KeySpaceError, m.MessageError):
            continue  # a foreign or damaged sample says nothing about a path
        rows.setdefault(key.node_id, []).append((p.t, p.x, p.y, p.vx, p.vy, p.ax, p.ay))
    return {node: _ordered(np.array(r, dtype=np.float64)) for node, r in rows.items()}


def _ordered(rows: np.ndarray) -> np.ndarray:
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    keep = np.concatenate([[True], np.diff(rows[:, 0]) > 0])  # one pose per instant
    return rows[keep]


def path_figures(rows: np.ndarray, start: float) -> dict[str, Any]:
    """The PATHS columns of one participant's poses; `start`: the recording's [s]."""
    t = rows[:, 0]
    duration = float(t[-1] - t[0])
    distance = float(np.hypot(np.diff(rows[:, 1]), np.diff(rows[:, 2])).sum())
    accel, source = np.hypot(rows[:, 5], rows[:, 6]), "sent"
    if not accel.any():
        dv = np.hypot(np.diff(rows[:, 3]), np.diff(rows[:, 4]))
        accel, source = (dv / np.diff(t) if len(t) > 1 else np.zeros(1)), "differentiated"
    return {
        "samples": len(rows), "duration_s": duration, "distance_m": distance,
        "mean_speed_mps": distance / duration if duration > 0 else math.nan,
        "max_speed_mps": float(np.hypot(rows[:, 3], rows[:, 4]).max()),
        "max_accel_mps2": float(accel.max()),
        "p95_accel_mps2": float(np.percentile(accel, 95)), "accel_source": source,
        "first_seen_rel_s": float(t[0] - start), "last_seen_rel_s": float(t[-1] - start),
    }  # fmt: skip
