"""One analysis of one recording: read, measure, write the files, draw the report."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from carlaverse.analysis import export, report
from carlaverse.analysis.lanes import LaneIndex
from carlaverse.analysis.surrogate import Thresholds, conflicts_by_concern, measure
from carlaverse.analysis.tracks import read_recording
from carlaverse.recording.sink import RecordingError


class AnalysisError(RuntimeError):
    """The recording cannot be analysed; the message says why."""


def analyze(
    recording: Path,
    out: Path,
    rate_hz: float,
    th: Thresholds,
    progress: Callable[[str], None] = lambda _: None,
) -> dict:
    """Write every output into `out`; the summary."""
    try:
        read = read_recording(recording, rate_hz, progress=lambda n: progress(f"{n} samples read"))
    except RecordingError as exc:
        raise AnalysisError(str(exc)) from exc
    tracks = read.tracks
    if not tracks.actors:
        raise AnalysisError(f"{recording}: no poses or NPC batches in this recording")
    span = f"{tracks.t[0] - read.start:.1f} to {tracks.t[-1] - read.start:.1f} s from start"
    progress(f"{len(tracks.actors)} road users from {span}; measuring")
    pairs, found = measure(tracks, th)
    conflicts = conflicts_by_concern(found)  # the tables list a participant's first
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AnalysisError(f"cannot create {out}: {exc.strerror}") from exc
    lanes, start = LaneIndex(read.road_map), read.start
    tables = {
        "actors": export.actors_table(tracks, lanes, start),
        "trajectories": export.trajectory_table(tracks, start),
        "events": export.events_table(read.events, start),
        "pairs": export.pairs_table(pairs, tracks, lanes, start),
        "conflicts": export.record_table(conflicts, start),
    }
    for name, table in tables.items():
        export.write_table(table, out, name)
    summary = export.summary(tracks, pairs, conflicts, th, start)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    report.draw(out / "report.png", tracks, read.road_map, pairs, conflicts, th, start)
    shown = report.Tables(*(tables[k].to_pylist() for k in ("pairs", "conflicts", "actors")))
    report.write_html(out / "report.html", "report.png", summary, shown, str(recording))
    return summary
