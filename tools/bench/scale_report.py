"""The scale benchmark's report: its text, tables and verdicts, from the windows' figures.

`bench_scale.py` runs the windows; each is a dict of the children's reports (see
`Bench.window` there). Pure functions of those dicts and of the layout (`scale_layout`), so a
saved run can be reported again.
"""

from __future__ import annotations

from statistics import median
from typing import Any

from scale_layout import (
    BLOCK_M,
    DIGEST_SWEEP_MS,
    FLOOR_DRAIN_MS,
    GRID_JUNCTIONS,
    MATE_OFFSET_M,
    NEAR_RADIUS_M,
    SPREAD_M,
    TOWN_M,
    VEHICLES,
)

from carlaverse.authority.pose_digest import DIGEST_PERIOD_S

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
        "one-way p50 / p99 ms | of it, to the authority's put p50 / p99 ms | of it, the "
        "digest's hop p50 / p99 ms | delivery | authority CPU | authority tick p99 ms / "
        "overruns |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for ms in sorted(periods_ms):
        window, idle = run[f"digest@{ms:g}"], base[f"digest@{ms:g}"]
        p, a = window["probe-digest"], window["authority"]
        total_us, marginal_us = _per_pose_us(p, idle["probe-digest"])
        per_digest = a["relayed"] / a["digests"] if a["digests"] else float("nan")
        rows.append(
            f"| {ms:g} | {per_digest:.1f} | {total_us:.1f} / {marginal_us:.1f} | "
            f"{p['p50_ms']:.2f} / {p['p99_ms']:.2f} | {_split(p, 'to_relay')} | "
            f"{_split(p, 'hop')} | {_delivery(p):.3%} | "
            f"{window['cpu']['authority']:.0%} | {a['p99']:.2f} / {a['overruns']} |"
        )
    return "\n".join(rows)


def _split(probe: dict[str, Any], part: str) -> str:
    """p50 / p99 of one part of the digest's delay; a dash for a run saved before it was."""
    if f"{part}_p50_ms" not in probe:
        return "–"
    return f"{probe[f'{part}_p50_ms']:.2f} / {probe[f'{part}_p99_ms']:.2f}"


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


def _rounds(run: dict[str, Any], base: dict[str, Any], name: str, window: str) -> dict[str, Any]:
    """One hear-everything node over the run's rounds: per round (µs per pose above idle,
    all in, one-way p99, delivery, the floor beside it), and the medians."""
    rows = []
    for r in run.get("rounds") or [{window: run[window]}]:
        probe, idle = r[window][name], base[window]
        total_us, marginal_us = _per_pose_us(probe, idle[name])
        floor_us = _per_pose_us(r[window]["floor"], idle["floor"])[1]
        rows.append((marginal_us, total_us, probe["p99_ms"], _delivery(probe), floor_us))
    columns = list(zip(*rows, strict=True))
    return {
        "rows": rows,
        "us": median(columns[0]), "total_us": median(columns[1]), "p99_ms": median(columns[2]),
        "delivery": min(columns[3]), "floor_us": median(columns[4]),
    }  # fmt: skip


def rounds_part(run: dict[str, Any], base: dict[str, Any], n: int) -> str:
    every, digest = (
        _rounds(run, base, "probe-all", "hearing"),
        _rounds(run, base, "probe-digest", "digest"),
    )
    rows = [
        f"The two ways of hearing everything at N = {n}, their windows alternating on the same "
        "swarm, round by round (the verdicts below take the medians):",
        "",
        "| round | probe-all µs per pose above idle | one-way p99 ms | floor beside it µs | "
        "probe-digest µs per pose above idle | one-way p99 ms | floor beside it µs |",
        "|---|---|---|---|---|---|---|",
    ]
    for i, (a, d) in enumerate(zip(every["rows"], digest["rows"], strict=True), 1):
        rows.append(f"| {i} | {a[0]:.1f} | {a[2]:.2f} | {a[4]:.1f} | {d[0]:.1f} | {d[2]:.2f} | "
                    f"{d[4]:.1f} |")  # fmt: skip
    rows.append(
        f"| median | {every['us']:.1f} | {every['p99_ms']:.2f} | {every['floor_us']:.1f} | "
        f"{digest['us']:.1f} | {digest['p99_ms']:.2f} | {digest['floor_us']:.1f} |"
    )
    return "\n".join(rows)


def floors_part(run: dict[str, Any], base: dict[str, Any], n: int, drain_ms: float) -> str:
    """The floor taken two ways in one window: a Python callback per sample, and a Zenoh
    ring drained in batches (no callback): whether the floor is the callback's or the
    sample's, and what a node fed from such a ring would pay."""
    window, idle = run["floors"], base["floors"]
    callback = _per_pose_us(window["floor"], idle["floor"])
    ring = _per_pose_us(window["floor-ring"], idle["floor-ring"])
    digest = _rounds(run, base, "probe-digest", "digest")["us"]
    relay = run["digest"]["authority"]
    per_digest = relay["relayed"] / relay["digests"] if relay["digests"] else float("nan")
    if min(callback[1], ring[1]) > TARGET_RX_US:
        reading = (
            f"Neither is below the {TARGET_RX_US:g} µs a pose may cost: being handed a sample "
            "costs that much however it is taken, so only fewer samples per pose (the digest) "
            "get below it."
        )
    else:
        reading = (
            f"Being handed a sample costs less than the {TARGET_RX_US:g} µs a pose may cost "
            f"when it is taken from {'the ring' if ring[1] <= callback[1] else 'a callback'}, "
            "but what a node does with each pose comes on top: probe-digest, handed "
            f"{per_digest:.0f} poses a sample, paid {digest:.1f} µs per pose, nearly all of it "
            "that work, so a node taking every pose from a ring would pay about "
            f"{min(callback[1], ring[1]) + digest:.0f} µs: the digest stays the way under it."
        )
    return (
        f"Where the floor comes from, at N = {n}: two bare zenoh-python subscribers to every "
        "pose, side by side in one window and both only taking each payload's bytes, one "
        "with a Python callback per sample (the floor above), one whose samples wait in a "
        f"Zenoh ring that a thread drains every {drain_ms:g} ms (as the authority's intake "
        f"takes them; no Python callback): {callback[1]:.1f} µs and {ring[1]:.1f} µs per pose "
        f"above idle ({callback[0]:.1f} and {ring[0]:.1f} all in; "
        f"{window['floor']['poses'] / window['floor']['seconds']:,.0f} and "
        f"{window['floor-ring']['poses'] / window['floor-ring']['seconds']:,.0f} poses/s). "
        + reading
    )


def verdicts(runs: dict[int, dict[str, Any]], base: dict[str, Any]) -> str:
    n = max(runs)
    w, h = runs[n]["session"], runs[n]["hearing"]
    a, near = w["authority"], w["probe-near"]
    every = _rounds(runs[n], base, "probe-all", "hearing")
    digest = _rounds(runs[n], base, "probe-digest", "digest")
    judged = len(every["rows"])
    over = f"medians of {judged} rounds" if judged > 1 else "one window"

    def hearing_check(who: str, r: dict[str, Any]) -> tuple[str, bool, str]:
        return (
            f"{who} at N = {n} receives ≥ {TARGET_DELIVERY:.1%} with one-way p99 ≤ "
            f"{TARGET_ONE_WAY_P99_MS:g} ms",
            r["delivery"] >= TARGET_DELIVERY and r["p99_ms"] <= TARGET_ONE_WAY_P99_MS,
            f"{r['delivery']:.3%} in the worst window, p99 {r['p99_ms']:.2f} ms ({over})",
        )

    checks = [
        (f"authority tick p99 ≤ {TARGET_TICK_P99_MS:g} ms with no overruns at N = {n}",
         a["p99"] <= TARGET_TICK_P99_MS and a["overruns"] == 0,
         f"p99 {a['p99']:.2f} ms, {a['overruns']} overruns; beside probe-all "
         f"{h['authority']['p99']:.2f} ms, {h['authority']['overruns']} overruns"),
        _node_check("a participant with the default interest radius (probe-near)", near, n),
        hearing_check("a node hearing every pose of the session (probe-all)", every),
        hearing_check("the same node on the pose digest (probe-digest)", digest),
        (f"receive cost ≤ {TARGET_RX_US:g} µs per pose (above idle), a sample per pose",
         every["us"] <= TARGET_RX_US, f"probe-all {every['us']:.1f} µs ({every['total_us']:.1f} "
         f"µs all in; {over}); a bare zenoh-python subscriber to the same poses in the same "
         f"windows, its callback only taking the bytes: {every['floor_us']:.1f} µs"),
        (f"receive cost ≤ {TARGET_RX_US:g} µs per pose (above idle), on the pose digest",
         digest["us"] <= TARGET_RX_US, f"probe-digest {digest['us']:.1f} µs "
         f"({digest['total_us']:.1f} µs all in; {over}; the bare subscriber beside it "
         f"{digest['floor_us']:.1f} µs), one-way p99 {digest['p99_ms']:.2f} ms against "
         f"probe-all's {every['p99_ms']:.2f} ms"),
    ]  # fmt: skip
    return "\n".join(f"- {what}: {'met' if ok else 'MISSED'} ({got})." for what, ok, got in checks)


def section(
    runs: dict[int, dict[str, Any]],
    base: dict[str, Any],
    profile: str,
    express: dict[int, dict[str, Any]] | None = None,
) -> str:
    sync = max(r["hearing"]["probe-all"]["sync_ms"] for r in runs.values())
    ba, bh = base["session"]["authority"], base["hearing"]["authority"]
    parts = [
        f"One router, one authority running a generated {GRID_JUNCTIONS} × {GRID_JUNCTIONS} "
        f"grid town ({BLOCK_M:g} m blocks, {TOWN_M / 1000:g} km across) with {VEHICLES} NPC "
        f"vehicles requested ({ba['npcs']} present), real nodes standing at its centre and "
        f"`carlaverse swarm --egos N` driving blocks of the same street grid over "
        f"{SPREAD_M / 1000:g} km × {SPREAD_M / 1000:g} km at 50 Hz per ego: every ego joins and "
        "is in the collision matrix; those on the town's streets are carried in SUMO, the "
        "others SUMO cannot place (retried each second). SUMO runs in a process of its own "
        "beside the authority (`traffic.sumo_process`, the default), its CPU in a column of "
        "its own. Swarm egos render no audio, so "
        "the authority builds no audio scenes for them (it builds a listener's only while "
        "something subscribes to its audio key; 256 listeners' scenes are costed under "
        "Authority audio emitters). All on this machine over "
        f"loopback TCP, {runs[max(runs)]['session']['probe-near']['seconds']:.0f} s windows. "
        "Three windows per N, one after the other on the same swarm: the **session** window has "
        f"one real node as a participant has it, `probe-near` with the default "
        f"{NEAR_RADIUS_M:g} m interest radius (it subscribes to the map tiles around it), with "
        f"a second participant, `probe-mate`, standing {MATE_OFFSET_M:g} m from it; the "
        "**hear-everything** window adds `probe-all`, a node with no interest radius that is "
        "handed every pose of the session, and a bare zenoh-python subscriber to the poses "
        "(the floor under any Python node's receive cost when it takes a sample per pose); "
        "a third, the **digest** window, has the floor again beside `probe-digest`, the same "
        "node taking the poses through the authority's pose digest (`pose_digest: true`: "
        f"every pose relayed on `world/@egos`, gathered for {DIGEST_PERIOD_S * 1e3:g} ms a "
        "message; the window runs once per relay period, "
        f"{', '.join(f'{ms:g}' for ms in DIGEST_SWEEP_MS)} ms, and the tables give the "
        f"shipped {DIGEST_PERIOD_S * 1e3:g} ms but the one that compares them). On two cores "
        "the two processes of either window take a core's worth of CPU at N = 256, which is "
        "why the authority's tick is "
        f"shown beside them too. Without a swarm the authority ticked at p50 {ba['p50']:.2f} / "
        f"p99 {ba['p99']:.2f} ms with {ba['overruns']} overruns (p99 {bh['p99']:.2f} ms, "
        f"{bh['overruns']} overruns beside probe-all). Read every figure against the load "
        "average above: a swarm that cannot send its 50 Hz (the percentage in the second "
        "column) and ticks far over 20 ms measure the machine's contention more than the "
        "fabric.",
        "",
        "One-way latency is a probe's session time on arrival minus the pose's session time "
        f"(both clocks synchronised to the authority; sync bound ≤ {sync:.2f} ms); the swarm "
        "stamps each pose as it puts it, as a node does (one stamp for a slot's 26 egos "
        "would count the wait behind the slot's earlier puts in every receiver's delay); "
        "delivery is poses received over sequence numbers spanned per sender.",
        "",
        scale_table(runs, base),
        "",
        stalls(runs),
        "",
        "Receiving everything (the hear-everything windows): CPU per pose is the probe's "
        "process CPU over poses received (all in: its own pose, clock sync and the NPC "
        "batches too) and the same above its CPU in the window without swarm.",
        "",
        receive_table(runs, base),
        "",
        "Interest management: `probe-near` hears only the tiles around it; `probe-all` "
        "and `probe-digest` hear everything.",
        "",
        interest_table(runs),
        "",
        f"The digest's period trades CPU against delay: the digest window at N = {max(runs)} "
        "run once per period, one after the other on the same swarm (the shipped "
        f"`--digest-ms` is {DIGEST_PERIOD_S * 1e3:g}). Each pose's delay is split at the "
        "timestamp the authority put its digest with: the pose's way to the authority and "
        "its wait there for the relay, then the digest's hop to the node (session time is "
        "the authority's clock, so the two parts add up to the one-way figure).",
        "",
        digest_table(runs[max(runs)], base, DIGEST_SWEEP_MS),
        "",
        rounds_part(runs[max(runs)], base, max(runs)),
        "",
        floors_part(runs[max(runs)], base, max(runs), FLOOR_DRAIN_MS),
        "",
        verdicts(runs, base),
    ]
    if express:
        parts += ["", express_part(express, base)]
    if profile:
        parts += ["", profile]
    return "\n".join(parts)


def express_part(express: dict[int, dict[str, Any]], base: dict[str, Any]) -> str:
    """The same windows while every pose travels in a frame of its own."""
    return "\n".join([
        "A swarm is one process, so its egos' poses share frames on every link, which N "
        "machines with links of their own would not: receiving them is cheaper here than in "
        "such a session. The same windows once more with `carlaverse swarm --express` (every "
        "pose in a frame of its own), after the runs above, on the same router and authority:",
        "",
        scale_table(express, base),
        "",
        receive_table(express, base),
        "",
        verdicts(express, base),
    ])  # fmt: skip
