"""One analysis of one recording: read, measure, write the files, draw the report."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from carlaverse.analysis import export, report
from carlaverse.analysis.surrogate import Thresholds, measure
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
    progress(f"{len(tracks.actors)} road users over {tracks.t[-1] - tracks.t[0]:.1f} s; measuring")
    pairs, conflicts = measure(tracks, th)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AnalysisError(f"cannot create {out}: {exc.strerror}") from exc
    export.write_table(export.trajectory_table(tracks), out, "trajectories")
    export.write_table(export.events_table(read.events), out, "events")
    export.write_table(export.record_table(pairs), out, "pairs")
    export.write_table(export.record_table(conflicts), out, "conflicts")
    summary = export.summary(tracks, pairs, conflicts, th.ttc_s)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    report.draw(out / "report.png", tracks, read.road_map, pairs, conflicts, th)
    report.write_html(out / "report.html", "report.png", summary, pairs, conflicts, str(recording))
    return summary
