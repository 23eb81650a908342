"""The study export's tables of what happened in the trials: trials, trajectories, encounters
and triggers, one row per observation, keyed by participant, trial and condition.

The encounter measures are the analysis's own (`carlaverse.analysis`: the tracks of
`carlaverse analyze` and its TTC, gap, DRAC and PET per pair); this module only joins them
with the study's keys, so a study's figures and one recording's `carlaverse analyze` report
cannot disagree. Trajectories are summarised from the poses as recorded (`export_paths`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from carlaverse import messages as m
from carlaverse.analysis.surrogate import Conflict, PairMeasures
from carlaverse.analysis.tracks import Recording
from carlaverse.config import parse_yaml, read_text
from carlaverse.study.export_inputs import Attempt, Seat, StudyRun, as_json, utc
from carlaverse.study.export_paths import PATHS, path_figures

KEYS = {
    "participant": "pseudonym (never a name: the mapping to people is never exported)",
    "role": "the participant's role in the study (driver, cyclist, ...)",
    "site": "the participant's site (empty when exported without --study)",
    "trial": "trial id in running order (t01, t02, ...)",
    "attempt": "attempt number of the trial (a redone trial has several)",
    "block": "1-based block of the design; 0 for practice",
    "kind": "main | practice",
    "practice": "true for a practice trial (not analysed, by the study's design)",
    "condition": "the participant's condition in this trial",
}
TRIAL_KEYS = {k: v for k, v in KEYS.items() if k in ("trial", "attempt", "block", "kind",
              "practice")} | {"condition": "the trial's condition; `mixed` when its "
                              "participants' conditions differ"}  # fmt: skip

TRIALS = KEYS | {
    "outcome": "completed | aborted | redo | lost | killed | not_started | failed | running",
    "reason": "why the attempt ended so (the runner's words)",
    "started_utc": "when the attempt began (UTC timestamp)",
    "live_utc": "when every role was present and the trial's clock started",
    "ended_utc": "when the attempt ended",
    "live_s": "[s] from live to the end (NaN if it never went live)",
    "delay_ms": "[ms] the participant's one-way link delay in this condition",
    "jitter_ms": "[ms] the link's jitter (uniform, ± the delay)",
    "loss": "fraction of the link's segments lost",
    "view_error_p95_m": "[m] the participant's view of the others vs the truth, worst p95",
    "view_error_max_m": "[m] the same, worst maximum",
    "notes": "the operator's notes on the trial, ' | ' between them",
    "recording": "the attempt's recording, relative to the run's folder",
}
TRAJECTORIES = KEYS | PATHS
ENCOUNTERS = KEYS | {
    "a": "one road user of the pair (analysis id: a participant's pseudonym or an NPC id)",
    "b": "the other",
    "other": "the pair's road user that is not this row's participant",
    "other_kind": "car, van, bike, pedestrian, ... of `other`",
    "participant_involved": "a participant is in the pair (false: NPCs only; participant "
    "and condition columns then describe the trial)",
    "both_participants": "both are participants (the pair has one row for each)",
    "min_ttc_s": "[s] least time to collision (inf: never on a collision course within the "
    "horizon)",
    "min_ttc_at_rel_s": "[s] when, from the recording's start",
    "ttc_below_s": "[s] time with TTC below the threshold (TET)",
    "min_gap_m": "[m] least distance between the footprints (0: contact)",
    "contact": "the footprints touched",
    "max_drac_mps2": "[m/s²] largest plausible deceleration rate to avoid a crash",
    "peak_drac_mps2": "[m/s²] largest DRAC, implausible ones included",
    "drac_implausible": "DRAC exceeded the friction limit at some instant (an artefact "
    "unless contact followed); kept out of max_drac_mps2",
    "drac_implausible_s": "[s] time with an implausible DRAC",
    "standstill": "both were at rest together (or NPCs queued) at some instant; those "
    "instants are left out of TTC",
    "queued_s": "[s] time at standstill together / queued",
    "min_pet_s": "[s] least post-encroachment time at a crossing of their paths (NaN: none)",
    "crossings": "path crossings measured for PET",
}
TRIGGERS = TRIAL_KEYS | {
    "conditions": "participant -> condition, as JSON",
    "trigger_id": "the scenario trigger (as the trial's scenario lists it, or as fired)",
    "fired": "it fired at least once",
    "times_fired": "how often it fired",
    "first_fired_rel_s": "[s] first firing, from the recording's start (NaN: never)",
    "actions": "what its first firing did, '; ' between actions",
    "values": "its measurements at the first firing, as JSON",
}


@dataclass(frozen=True)
class Measured:
    """One completed attempt's recording, read and measured once for every table."""

    attempt: Attempt
    recording: Recording
    pairs: list[PairMeasures]
    conflicts: list[Conflict]
    poses: dict[str, np.ndarray]  # participant -> their poses (export_paths.read_poses)


def trial_rows(run: StudyRun) -> list[dict[str, Any]]:
    return [_trial_row(a, seat) for a in run.attempts for seat in run.seats(a)]


def _trial_row(a: Attempt, seat: Seat) -> dict[str, Any]:
    link = a.links.get(seat.participant, {})
    seen = list(a.view_error.get(seat.participant, {}).values())
    live = a.ended_unix - a.live_unix
    return seat.keys(a) | {
        "outcome": a.outcome, "reason": a.reason, "started_utc": utc(a.started_unix),
        "live_utc": utc(a.live_unix), "ended_utc": utc(a.ended_unix), "live_s": live,
        "delay_ms": link.get("delay_ms", 0.0), "jitter_ms": link.get("jitter_ms", 0.0),
        "loss": link.get("loss", 0.0),
        "view_error_p95_m": max((e.get("p95_m", math.nan) for e in seen), default=math.nan),
        "view_error_max_m": max((e.get("max_m", math.nan) for e in seen), default=math.nan),
        "notes": " | ".join(a.notes), "recording": a.recording,
    }  # fmt: skip


def trajectory_rows(run: StudyRun, measured: Measured) -> list[dict[str, Any]]:
    start, poses = measured.recording.start, measured.poses
    return [seat.keys(measured.attempt) | path_figures(poses[seat.participant], start)
            for seat in run.seats(measured.attempt) if seat.participant in poses]  # fmt: skip


def encounter_rows(run: StudyRun, measured: Measured) -> list[dict[str, Any]]:
    a, start = measured.attempt, measured.recording.start
    kinds = {actor.id: actor.kind for actor in measured.recording.tracks.actors}
    seats = {seat.participant: seat for seat in run.seats(a)}
    rows = []
    for p in measured.pairs:
        figures = _pair(p, measured.conflicts, start)
        inside = [pid for pid in (p.a, p.b) if pid in seats]
        for pid in inside:
            other = p.b if pid == p.a else p.a
            rows.append(seats[pid].keys(a) | {"a": p.a, "b": p.b, "other": other,
                        "other_kind": kinds.get(other, ""), "participant_involved": True,
                        "both_participants": len(inside) == 2} | figures)  # fmt: skip
        if not inside:  # NPCs alone: keyed by the trial
            npcs = {"a": p.a, "b": p.b, "other": "", "other_kind": "",
                    "participant_involved": False, "both_participants": False}  # fmt: skip
            rows.append(Seat("", "", "", a.condition).keys(a) | npcs | figures)
    return rows


def _pair(p: PairMeasures, conflicts: list[Conflict], start: float) -> dict[str, Any]:
    mine = [c for c in conflicts if {c.first, c.second} == {p.a, p.b}]
    return {
        "min_ttc_s": p.min_ttc_s, "min_ttc_at_rel_s": p.t_min_ttc - start,
        "ttc_below_s": p.ttc_below_s, "min_gap_m": p.min_gap_m, "contact": p.min_gap_m == 0.0,
        "max_drac_mps2": p.max_drac_mps2, "peak_drac_mps2": p.peak_drac_mps2,
        "drac_implausible": p.drac_implausible_s > 0, "drac_implausible_s": p.drac_implausible_s,
        "standstill": p.queued_s > 0, "queued_s": p.queued_s,
        "min_pet_s": min((c.pet_s for c in mine), default=math.nan), "crossings": len(mine),
    }  # fmt: skip


def trigger_rows(run: StudyRun, measured: Measured) -> list[dict[str, Any]]:
    a, start = measured.attempt, measured.recording.start
    fired: dict[str, list[m.TriggerFired]] = {}
    for event in measured.recording.events:
        if isinstance(event, m.TriggerFired):
            fired.setdefault(event.trigger_id, []).append(event)
    listed = scenario_triggers(run.scenario_file(a))
    rows = []
    for trigger_id in [*listed, *(t for t in fired if t not in listed)]:
        times = sorted(fired.get(trigger_id, []), key=lambda e: e.t)
        first = times[0] if times else None
        rows.append(Seat("", "", "", a.condition).keys(a) | {
            "condition": a.condition, "conditions": as_json(a.conditions),
            "trigger_id": trigger_id, "fired": bool(times), "times_fired": len(times),
            "first_fired_rel_s": first.t - start if first else math.nan,
            "actions": "; ".join(first.actions) if first else "",
            "values": as_json(first.values) if first else "{}",
        })  # fmt: skip
    return [{k: row[k] for k in TRIGGERS} for row in rows]


def scenario_triggers(path: Path) -> list[str]:
    """The trigger ids a trial's scenario file lists ([] without the file or triggers)."""
    if not path.is_file():
        return []
    data = parse_yaml(read_text(path), str(path))
    triggers = data.get("triggers", []) if isinstance(data, dict) else []
    return [str(t["id"]) for t in triggers if isinstance(t, dict) and "id" in t]


def chain(*groups: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    return [row for group in groups for row in group]
