"""The scale benchmark's report: its tables and verdicts, from the windows' figures.

`bench_scale.py` runs the windows; each is a dict of the children's reports (see
`Bench.window` there). Pure functions of those dicts, so a saved run can be reported again.
"""

from __future__ import annotations

from typing import Any

TARGET_TICK_P99_MS = 20.0
TARGET_DELIVERY = 0.999
TARGET_ONE_WAY_P99_MS = 5.0
TARGET_RX_US = 10.0  # [µs] per pose received


def _per_pose_us(probe: dict[str, Any], base: dict[str, Any]) -> tuple[float, float]:
    """(all CPU, CPU above the no-swarm window) per pose received [µs]."""
    if not probe["poses"]:
        return float("nan"), float("nan")
    rate = probe["cpu_s"] / probe["seconds"]
    base_rate = base["cpu_s"] / base["seconds"]
    per_s = probe["poses"] / probe["seconds"]
    return rate / per_s * 1e6, (rate - base_rate) / per_s * 1e6


def _delivery(probe: dict[str, Any]) -> float:
    return probe["poses"] / probe["spanned"] if probe["spanned"] else float("nan")


def scale_table(runs: dict[int, dict[str, Any]], base: dict[str, Any]) -> str:
    rows = [
        "| egos | poses/s sent (of 50 Hz × N) | authority tick p50 / p99 / max ms | overruns | "
        "probe-near one-way p50 / p99 ms | delivery | router CPU | authority CPU | "
        "its SUMO process CPU | swarm CPU | tick p99 ms / overruns beside probe-all |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n, r in runs.items():
        w, h = r["session"], r["hearing"]
        a, near, cpu = w["authority"], w["probe-near"], w["cpu"]
        sumo = f"{cpu['sumo']:.0%}" if "sumo" in cpu else "–"  # SUMO inside the authority
        rows.append(
            f"| {n} | {r['swarm']['poses_per_s']:,.0f} ({r['swarm']['offered_fraction']:.0%}) | "
            f"{a['p50']:.2f} / {a['p99']:.2f} / {a['max']:.1f} | {a['overruns']} | "
            f"{near['p50_ms']:.2f} / {near['p99_ms']:.2f} | {_delivery(near):.3%} | "
            f"{cpu['router']:.0%} | {cpu['authority']:.0%} | "
            f"{sumo} | {cpu['swarm']:.0%} | "
            f"{h['authority']['p99']:.2f} / {h['authority']['overruns']} |"
        )
    return "\n".join(rows)


def stalls(runs: dict[int, dict[str, Any]]) -> str:
    """What could stall the authority's tick in the session windows, besides the machine."""
    parts = []
    for n, r in runs.items():
        a = r["session"]["authority"]
        if "gc_n" not in a:  # a run saved before these were reported
            return ""
        parts.append(
            f"N = {n}: {a['gc_n']} collections (longest {a['gc_max_ms']:.1f} ms), "
            f"{a['late']} steps that waited for SUMO"
        )
    return (
        "Stalls in the session windows: Python's cyclic collector in the authority and ticks "
        "that had to wait for SUMO's process (a tick leaves a step still running to a later "
        "tick, so none should): " + "; ".join(parts) + "."
    )


# (node, window it runs in, how it takes the poses)
RECEIVERS = (("probe-all", "hearing", "a sample per pose"),
             ("probe-digest", "digest", "the pose digest"))  # fmt: skip


def receive_table(runs: dict[int, dict[str, Any]], base: dict[str, Any]) -> str:
    rows = [
        "| egos | node | how it takes the poses | poses/s | one-way p50 / p99 ms | delivery | "
        "µs per pose (all / above idle) | bare zenoh-python µs per pose above idle, same "
        "window | authority CPU | authority tick p99 ms / overruns |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n, r in runs.items():
        for name, window, how in RECEIVERS:
            h, idle = r[window], base[window]
            p = h[name]
            total_us, marginal_us = _per_pose_us(p, idle[name])
            floor_us = _per_pose_us(h["floor"], idle["floor"])[1]
            a = h["authority"]
            rows.append(
                f"| {n} | {name} | {how} | {p['poses'] / p['seconds']:,.0f} | "
                f"{p['p50_ms']:.2f} / {p['p99_ms']:.2f} | {_delivery(p):.3%} | "
                f"{total_us:.1f} / {marginal_us:.1f} | {floor_us:.1f} | "
                f"{h['cpu']['authority']:.0%} | {a['p99']:.2f} / {a['overruns']} |"
            )
    return "\n".join(rows)


def digest_table(run: dict[str, Any], base: dict[str, Any], periods_ms: tuple[float, ...]) -> str:
    """probe-digest at each relay period: poses per digest, CPU per pose, delay."""
    rows = [
        "| relay period ms | poses per digest | probe-digest µs per pose (all / above idle) | "
        "one-way p50 / p99 ms | delivery | authority CPU | authority tick p99 ms / overruns |",
        "|---|---|---|---|---|---|---|",
    ]
    for ms in sorted(periods_ms):
        window, idle = run[f"digest@{ms:g}"], base[f"digest@{ms:g}"]
        p, a = window["probe-digest"], window["authority"]
        total_us, marginal_us = _per_pose_us(p, idle["probe-digest"])
        per_digest = a["relayed"] / a["digests"] if a["digests"] else float("nan")
        rows.append(
            f"| {ms:g} | {per_digest:.1f} | {total_us:.1f} / {marginal_us:.1f} | "
            f"{p['p50_ms']:.2f} / {p['p99_ms']:.2f} | {_delivery(p):.3%} | "
            f"{window['cpu']['authority']:.0%} | {a['p99']:.2f} / {a['overruns']} |"
        )
    return "\n".join(rows)


def interest_table(runs: dict[int, dict[str, Any]]) -> str:
    rows = [
        "| egos on the map | probe-near: egos heard | poses/s received | tiles subscribed | "
        "probe-all: egos heard | poses/s received |",
        "|---|---|---|---|---|---|",
    ]
    for n, r in runs.items():
        near, every = r["session"]["probe-near"], r["hearing"]["probe-all"]
        rows.append(
            f"| {n} | {near['senders']} | {near['poses'] / near['seconds']:,.0f} | "
            f"{near['tiles']} | {every['senders']} | {every['poses'] / every['seconds']:,.0f} |"
        )
    return "\n".join(rows)


def _node_check(who: str, probe: dict[str, Any], n: int) -> tuple[str, bool, str]:
    delivery = _delivery(probe)
    return (
        f"{who} at N = {n} receives ≥ {TARGET_DELIVERY:.1%} with one-way p99 ≤ "
        f"{TARGET_ONE_WAY_P99_MS:g} ms",
        delivery >= TARGET_DELIVERY and probe["p99_ms"] <= TARGET_ONE_WAY_P99_MS,
        f"{delivery:.3%}, p99 {probe['p99_ms']:.2f} ms",
    )


def verdicts(runs: dict[int, dict[str, Any]], base: dict[str, Any]) -> str:
    n = max(runs)
    w, h = runs[n]["session"], runs[n]["hearing"]
    d = runs[n]["digest"]
    a, near, every, digest = w["authority"], w["probe-near"], h["probe-all"], d["probe-digest"]
    total_us, marginal_us = _per_pose_us(every, base["hearing"]["probe-all"])
    digest_total_us, digest_us = _per_pose_us(digest, base["digest"]["probe-digest"])
    digest_floor_us = _per_pose_us(d["floor"], base["digest"]["floor"])[1]
    floor_us = _per_pose_us(h["floor"], base["hearing"]["floor"])[1]
    checks = [
        (f"authority tick p99 ≤ {TARGET_TICK_P99_MS:g} ms with no overruns at N = {n}",
         a["p99"] <= TARGET_TICK_P99_MS and a["overruns"] == 0,
         f"p99 {a['p99']:.2f} ms, {a['overruns']} overruns; beside probe-all "
         f"{h['authority']['p99']:.2f} ms, {h['authority']['overruns']} overruns"),
        *(_node_check(name, probe, n) for name, probe in (
            ("a participant with the default interest radius (probe-near)", near),
            ("a node hearing every pose of the session (probe-all)", every),
            ("the same node on the pose digest (probe-digest)", digest))),
        (f"receive cost ≤ {TARGET_RX_US:g} µs per pose (above idle), a sample per pose",
         marginal_us <= TARGET_RX_US, f"probe-all {marginal_us:.1f} µs ({total_us:.1f} µs all "
         f"in); a bare zenoh-python subscriber to the same poses in the same window, its "
         f"callback only taking the bytes: {floor_us:.1f} µs"),
        (f"receive cost ≤ {TARGET_RX_US:g} µs per pose (above idle), on the pose digest",
         digest_us <= TARGET_RX_US, f"probe-digest {digest_us:.1f} µs ({digest_total_us:.1f} "
         f"µs all in; the bare subscriber beside it {digest_floor_us:.1f} µs), one-way p99 "
         f"{digest['p99_ms']:.2f} ms against probe-all's {every['p99_ms']:.2f} ms"),
    ]  # fmt: skip
    return "\n".join(f"- {what}: {'met' if ok else 'MISSED'} ({got})." for what, ok, got in checks)
