"""Surrogate safety measures for every pair of road users, humans and NPCs alike.

- TTC, time to collision: at each instant, how long until the two footprints touch if both
  keep their velocity and heading (exact for rectangles, `footprints.time_to_contact`).
  Reported: the minimum, and the time exposed below the threshold (the TET of Minderhoud and
  Bovy, 2001). TTCs beyond `ttc_horizon_s` are not an encounter.
- Gap: the smallest distance between the footprints (0 = they touched).
- DRAC, deceleration rate to avoid a crash: closing speed along the line of centres squared
  over twice the gap (Almqvist et al., 1991); for a follower that is dv^2 / 2s. A DRAC above
  `drac_limit_mps2` is more than any tyre gives: braking is limited by friction to mu g, 9.8
  m/s^2 for mu = 1 (dry asphalt, a good tyre). Such a value says no braking could have
  avoided the contact on those tracks, and where no contact followed it is an artefact (a
  footprint too long, a lateral neighbour in a junction, a sampling step); it is counted as
  `drac_implausible_s` and kept out of `max_drac_mps2`, the headline; `peak_drac_mps2` keeps it.
- Queued: while both are slower than `standstill_mps`, cars waiting nose to tail at a stop
  line creep a few centimetres towards each other; and two NPCs pulling up into a queue (the
  follower braking to rest behind the one ahead: both at rest within `ttc_horizon_s`, then
  at most `queue_gap_m` apart and heading the same way within `QUEUE_HEADING_DEG`, with no
  contact on the way) give a constant-velocity TTC near 1 s on every red light, though the
  traffic model's car-following stops them at its minimum gap by construction. Either would
  fill the TTC list with "encounters" nobody was in, so those instants are left out of TTC and
  time below (standing ones out of DRAC too) and counted as `queued_s`. A participant pulling
  up behind a queue keeps its TTC: how late a person brakes is what a study measures.
- PET, post-encroachment time, at every point where the two centre paths cross (at an angle
  of at least `min_crossing_deg`; paths that share a lane are following, not crossing): the
  time from the first actor's footprint leaving the point to the second's reaching it
  (Allen et al., 1978). 0 means both covered the point at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from carlaverse.analysis import footprints
from carlaverse.analysis.tracks import Tracks

QUEUE_HEADING_DEG = 30.0  # [deg] two at rest heading the same way within this: one queue


@dataclass(frozen=True, slots=True)
class Thresholds:
    ttc_s: float = 1.5  # [s] time below this is counted as exposed
    ttc_horizon_s: float = 10.0  # [s] a longer TTC is no encounter
    near_m: float = 30.0  # [m] pairs whose centres never come closer are not measured
    pet_max_s: float = 10.0  # [s] crossings further apart in time are no conflict
    min_crossing_deg: float = 15.0  # [deg] shallower crossings are following
    standstill_mps: float = 0.5  # [m/s] both slower than this: at rest, not an encounter
    # [m/s²] mu g for mu = 1 is 9.81: a larger DRAC is beyond any tyre's friction limit
    drac_limit_mps2: float = 10.0
    queue_gap_m: float = 5.0  # [m] at rest at most this far apart, nose to tail: a queue


@dataclass(frozen=True, slots=True)
class PairMeasures:
    a: str
    b: str
    min_ttc_s: float  # inf if never on a collision course within the horizon
    t_min_ttc: float  # [s] session time (nan without a TTC)
    ttc_below_s: float  # [s] time with TTC below the threshold
    min_gap_m: float
    t_min_gap: float
    max_drac_mps2: float  # 0 if never closing; the largest within `drac_limit_mps2`
    t_max_drac: float
    human: bool = False  # at least one of the two is a participant (a human's ego)
    queued_s: float = 0.0  # [s] at rest together, or NPCs pulling up into a queue: no TTC
    drac_implausible_s: float = 0.0  # [s] DRAC above `drac_limit_mps2`
    peak_drac_mps2: float = 0.0  # the largest DRAC, implausible or not


@dataclass(frozen=True, slots=True)
class Conflict:
    first: str  # reaches the crossing point first
    second: str
    x: float  # [m] the crossing point
    y: float
    t_first_leaves: float  # [s] session time the first's footprint clears the point
    t_second_arrives: float  # [s] session time the second's footprint reaches it
    pet_s: float
    angle_deg: float  # between the paths at the point
    human: bool = False  # at least one of the two is a participant


def measure(
    tracks: Tracks, th: Thresholds = Thresholds()
) -> tuple[list[PairMeasures], list[Conflict]]:
    """Measures for every pair that comes within `th.near_m`, and every crossing conflict."""
    pairs, conflicts = [], []
    for i, j in near_pairs(tracks, th.near_m):
        pairs.append(pair_measures(tracks, i, j, th))
        conflicts.extend(crossing_conflicts(tracks, i, j, th))
    return pairs, conflicts


def near_pairs(tracks: Tracks, near_m: float) -> list[tuple[int, int]]:
    out: list[tuple[int, int]] = []
    for i in range(len(tracks.actors) - 1):
        d = np.hypot(tracks.x[i + 1 :] - tracks.x[i], tracks.y[i + 1 :] - tracks.y[i])
        with np.errstate(invalid="ignore"):
            close = np.nanmin(np.where(np.isnan(d), np.inf, d), axis=1) <= near_m
        out.extend((i, i + 1 + int(k)) for k in np.flatnonzero(close))
    return out


def pair_measures(tracks: Tracks, i: int, j: int, th: Thresholds) -> PairMeasures:
    both = tracks.present[i] & tracks.present[j]
    t = tracks.t[both]
    a, b = tracks.actors[i], tracks.actors[j]
    ca, cb = _column(tracks, i, both), _column(tracks, j, both)
    offset, rel_v = cb["p"] - ca["p"], cb["v"] - ca["v"]
    ttc = footprints.time_to_contact(
        offset, rel_v, ca["yaw"], cb["yaw"], (a.length, a.width), (b.length, b.width)
    )
    ttc[ttc > th.ttc_horizon_s] = np.inf
    gap = footprints.gap(
        footprints.corners(ca["p"], ca["yaw"], a.length, a.width),
        footprints.corners(cb["p"], cb["yaw"], b.length, b.width),
    )
    still = _standstill(ca["v"], th.standstill_mps) & _standstill(cb["v"], th.standstill_mps)
    queued = still if a.human or b.human else still | _pulling_up(ca, cb, still, gap, t, th)
    ttc[queued] = np.inf
    peak = _drac(offset, rel_v, gap)
    peak[still] = 0.0
    implausible = peak > th.drac_limit_mps2
    drac = np.where(implausible, 0.0, peak)
    dt = float(np.median(np.diff(tracks.t))) if len(tracks.t) > 1 else 0.0
    k_ttc, k_gap, k_drac = np.argmin(ttc), np.argmin(gap), np.argmax(drac)
    return PairMeasures(
        a.id, b.id,
        float(ttc[k_ttc]), float(t[k_ttc]) if np.isfinite(ttc[k_ttc]) else math.nan,
        float(np.count_nonzero(ttc < th.ttc_s) * dt),
        float(gap[k_gap]), float(t[k_gap]),
        float(drac[k_drac]), float(t[k_drac]) if drac[k_drac] > 0 else math.nan,
        a.human or b.human, float(np.count_nonzero(queued) * dt),
        float(np.count_nonzero(implausible) * dt), float(peak.max(initial=0.0)),
    )  # fmt: skip


def by_concern(pairs: list[PairMeasures]) -> list[PairMeasures]:
    """Pairs with a human first, then by least TTC, then by least gap."""
    return sorted(pairs, key=lambda p: (not p.human, p.min_ttc_s, p.min_gap_m))


def conflicts_by_concern(conflicts: list[Conflict]) -> list[Conflict]:
    """Conflicts with a human first, then by least PET."""
    return sorted(conflicts, key=lambda c: (not c.human, c.pet_s))


def _standstill(v: np.ndarray, limit_mps: float) -> np.ndarray:
    return np.hypot(v[:, 0], v[:, 1]) < limit_mps


def _pulling_up(ca: dict, cb: dict, still: np.ndarray, gap: np.ndarray, t: np.ndarray,
                th: Thresholds) -> np.ndarray:  # fmt: skip
    """Instants from which the two come to stand in one queue: at rest, close, aligned."""
    in_queue = still & (gap <= th.queue_gap_m) & _aligned(ca["yaw"], cb["yaw"])
    return _settling(in_queue, gap, t, th.ttc_horizon_s)


def _aligned(yaw_a: np.ndarray, yaw_b: np.ndarray) -> np.ndarray:
    """Heading the same way within QUEUE_HEADING_DEG."""
    difference = np.angle(np.exp(1j * (yaw_a - yaw_b)))
    return np.abs(difference) <= math.radians(QUEUE_HEADING_DEG)


def _settling(in_queue: np.ndarray, gap: np.ndarray, t: np.ndarray, horizon_s: float) -> np.ndarray:
    """Instants from which the two stand in one queue (`in_queue`) within `horizon_s`
    without touching on the way: one pulling up behind the other."""
    idx = np.arange(len(in_queue))
    next_queue = _next_index(in_queue)
    next_contact = _next_index(gap <= 0.0)
    ahead = np.where(next_queue < len(t), t[np.minimum(next_queue, len(t) - 1)] - t, np.inf)
    return (ahead <= horizon_s) & (next_contact > next_queue) & (idx < next_queue)


def _next_index(mask: np.ndarray) -> np.ndarray:
    """For every instant, the index of the first True at or after it (len(mask) if none)."""
    n = len(mask)
    marks = np.where(mask, np.arange(n), n)
    return np.minimum.accumulate(marks[::-1])[::-1]


def _column(tracks: Tracks, i: int, mask: np.ndarray) -> dict[str, np.ndarray]:
    return {
        "p": np.stack([tracks.x[i, mask], tracks.y[i, mask]], -1),
        "v": np.stack([tracks.vx[i, mask], tracks.vy[i, mask]], -1),
        "yaw": tracks.yaw[i, mask],
    }


def _drac(offset: np.ndarray, rel_v: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """Closing speed along the line of centres squared over twice the gap; 0 when opening
    or touching (a contact is in the gap, not here)."""
    distance = np.maximum(np.hypot(offset[:, 0], offset[:, 1]), 1e-9)
    closing = -np.sum(offset * rel_v, axis=-1) / distance
    ok = (closing > 0) & (gap > 0)
    return np.where(ok, closing**2 / (2 * np.where(ok, gap, 1.0)), 0.0)


def crossing_conflicts(tracks: Tracks, i: int, j: int, th: Thresholds) -> list[Conflict]:
    """Every point where the centre paths of i and j cross within `pet_max_s` of each other."""
    pa, pb = _path(tracks, i), _path(tracks, j)
    dt = float(np.median(np.diff(tracks.t))) if len(tracks.t) > 1 else 0.0
    if dt <= 0:
        return []
    window = int(np.ceil(th.pet_max_s / dt))
    hits = [_crossings(pa, pb, shift, th.min_crossing_deg) for shift in range(-window, window + 1)]
    out = []
    for k, m, ua, ub, angle in (h for group in hits for h in group):
        conflict = _conflict(tracks, (i, pa, k, ua), (j, pb, m, ub), angle)
        if conflict is not None and conflict.pet_s <= th.pet_max_s:
            out.append(conflict)
    return out


def _path(tracks: Tracks, i: int) -> dict[str, np.ndarray]:
    points = np.stack([tracks.x[i], tracks.y[i]], -1)
    steps = np.diff(points, axis=0)
    lengths = np.nan_to_num(np.hypot(steps[:, 0], steps[:, 1]))
    return {"points": points, "steps": steps, "cum": np.concatenate([[0.0], np.cumsum(lengths)])}


def _crossings(pa: dict, pb: dict, shift: int, min_deg: float) -> list[tuple]:
    """Segment k of a against segment k + shift of b: (k, m, u_a, u_b, angle) where they cross."""
    n = len(pa["steps"])
    k = np.arange(max(0, -shift), min(n, n - shift))
    if len(k) == 0:
        return []
    m = k + shift
    r, s = pa["steps"][k], pb["steps"][m]
    q = pb["points"][m] - pa["points"][k]
    denom = _cross(r, s)
    with np.errstate(invalid="ignore", divide="ignore"):
        ua, ub = _cross(q, s) / denom, _cross(q, r) / denom
        sine = np.abs(denom) / (np.hypot(*r.T) * np.hypot(*s.T))
        hit = (
            (ua >= 0) & (ua < 1) & (ub >= 0) & (ub < 1) & (sine >= math.sin(math.radians(min_deg)))
        )
    idx = np.flatnonzero(hit)
    angles = np.degrees(
        np.arccos(
            np.clip(_dot(r[idx], s[idx]) / (np.hypot(*r[idx].T) * np.hypot(*s[idx].T)), -1, 1)
        )
    )
    return list(zip(k[idx], m[idx], ua[idx], ub[idx], angles, strict=True))


def _conflict(tracks: Tracks, a: tuple, b: tuple, angle: float) -> Conflict | None:
    """PET at the crossing of segment k of a with segment m of b (u: fractions along them)."""
    (i, pa, k, ua), (j, pb, m, ub) = a, b
    point = pa["points"][k] + ua * pa["steps"][k]
    passes = []
    for idx, path, seg, u in ((i, pa, k, ua), (j, pb, m, ub)):
        at = path["cum"][seg] + u * (path["cum"][seg + 1] - path["cum"][seg])
        half = 0.5 * tracks.actors[idx].length
        times = [_time_at(path["cum"], tracks.t, s) for s in (at - half, at, at + half)]
        passes.append((times[1], idx, times[0], times[2]))
    (_, first, _, first_leaves), (_, second, second_arrives, _) = sorted(passes)
    if math.isnan(first_leaves) or math.isnan(second_arrives):
        return None  # the recording ends while one of them is still on the point
    return Conflict(
        tracks.actors[first].id, tracks.actors[second].id, float(point[0]), float(point[1]),
        first_leaves, second_arrives, max(0.0, second_arrives - first_leaves), float(angle),
        tracks.actors[first].human or tracks.actors[second].human,
    )  # fmt: skip


def _time_at(cum: np.ndarray, t: np.ndarray, s: float) -> float:
    """First time the arc length along the path reaches `s` (nan if it never does)."""
    idx = int(np.searchsorted(cum, s, side="left"))
    if idx == 0 or idx >= len(cum):  # on the point before the recording began, or after it ended
        return math.nan
    span = cum[idx] - cum[idx - 1]
    frac = (s - cum[idx - 1]) / span if span > 0 else 0.0
    return float(t[idx - 1] + frac * (t[idx] - t[idx - 1]))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)
