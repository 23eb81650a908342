"""The receive benchmark's report: its layers, tables and verdict, from the windows' figures.

`bench_receive.py` runs the windows; each is a dict of a subscriber's report (see
`receive_children.Receiver.since`); these are pure functions of those dicts.
"""

from __future__ import annotations

import argparse
import statistics
from dataclasses import dataclass, field
from typing import Any

from receive_children import DIGEST, EXPRESS, IDLE, SLICES

LAYERS = ("zenoh", "handoff", "inbound", "node")  # each adds to the one before
# The same layers while the publisher puts `express`: one frame per pose, as a node meets
# egos that are machines of their own with direct links (peer mode); one process's egos, and
# a router's fan-out, otherwise share frames.
EXPRESS_LAYERS = ("zenoh" + EXPRESS, "node" + EXPRESS)
# The layers again with the poses many to a sample, as the authority's digest relays them
# (`world/@egos`) for a node that hears the whole session.
DIGEST_LAYERS = ("zenoh" + DIGEST, "handoff" + DIGEST, "node" + DIGEST)
TARGET_US = 10.0  # [µs] the target: receive cost per pose
WHAT = {
    IDLE: "a session subscribed to the poses, the publisher paused",
    "zenoh": "ring channel never drained: Zenoh's own work, no Python",
    "handoff": "Python callback taking the payload's bytes",
    "inbound": "the project's pose handler into a world view",
    "node": "as inbound, plus `WorldView.update` at 100 Hz",
    "zenoh" + EXPRESS: "as `zenoh`, every pose put express (a frame of its own)",
    "node" + EXPRESS: "as `node`, every pose put express (a frame of its own)",
    "zenoh" + DIGEST: "as `zenoh`, the poses relayed as the authority's digest",
    "handoff" + DIGEST: "as `handoff`, a digest's bytes per sample",
    "node" + DIGEST: "as `node`, the digests an update drains checked and applied as one batch",
}
ALL_LAYERS = (*LAYERS, *EXPRESS_LAYERS, *DIGEST_LAYERS)


def poses(window: dict[str, Any]) -> float:
    """Poses the window's layer was handed: counted, or (the ring) those sent meanwhile."""
    if window["layer"] == IDLE:
        return 0.0
    received = window["received"]
    return window["sent"] if received is None else received


@dataclass
class Figures:
    """One layer in one mode, one value per round."""

    rate: list[float] = field(default_factory=list)  # [poses/s]
    us: list[float] = field(default_factory=list)  # [µs/pose] above idle
    step: list[float] = field(default_factory=list)  # [µs/pose] over the layer before
    share: list[float] = field(default_factory=list)  # of a core, the whole process
    update_us: list[float] = field(default_factory=list)  # [µs/pose] the update thread's
    p50_ms: list[float] = field(default_factory=list)  # one-way, publisher to world view
    p99_ms: list[float] = field(default_factory=list)


def summarise(windows: list[dict[str, Any]], modes: list[str]) -> dict[str, dict[str, Figures]]:
    """Per mode and layer, the figures of every round; the idle window of the same round and
    mode is subtracted, and each step is taken within one round (both saw the same drift)."""
    by = {(w["round"], w["mode"], w["layer"]): w for w in windows}
    rounds = sorted({w["round"] for w in windows})
    out: dict[str, dict[str, Figures]] = {}
    for mode in modes:
        out[mode] = {layer: Figures() for layer in (IDLE, *ALL_LAYERS)}
        for r in rounds:
            idle = by[(r, mode, IDLE)]
            out[mode][IDLE].share.append(idle["cpu_s"] / idle["seconds"])
            us: dict[str, float] = {}
            for layer in ALL_LAYERS:
                us[layer] = _add(out[mode][layer], by[(r, mode, layer)], idle)
                if (under := _under(layer)) is not None:
                    out[mode][layer].step.append(us[layer] - us[under])
    return out


def _under(layer: str) -> str | None:
    """What a layer's step is taken over: the layer before it (of the digest's, for a digest
    layer), or itself put batched (an express layer)."""
    if layer.endswith(EXPRESS):
        return layer.removesuffix(EXPRESS)
    chain = DIGEST_LAYERS if layer.endswith(DIGEST) else LAYERS
    at = chain.index(layer)
    return chain[at - 1] if at else None


def _add(figures: Figures, w: dict[str, Any], idle: dict[str, Any]) -> float:
    n = poses(w)
    above_s = w["cpu_s"] - idle["cpu_s"] / idle["seconds"] * w["seconds"]
    us = above_s / n * 1e6 if n else float("nan")
    figures.rate.append(n / w["seconds"])
    figures.us.append(us)
    figures.share.append(w["cpu_s"] / w["seconds"])
    if w["layer"].startswith("node"):
        figures.update_us.append(w["update_cpu_s"] / n * 1e6 if n else float("nan"))
    if "latency_ms" in w:
        figures.p50_ms.append(w["latency_ms"][0])
        figures.p99_ms.append(w["latency_ms"][1])
    return us


def _spread(values: list[float], digits: int = 1, scale: float = 1.0, unit: str = "") -> str:
    """The median, and the range over rounds when there is more than one."""
    if not values:
        return "—"
    v = [x * scale for x in values]
    text = f"{statistics.median(v):.{digits}f}{unit}"
    return text if len(v) == 1 else f"{text} ({min(v):.{digits}f}–{max(v):.{digits}f})"


def table(figures: dict[str, Figures]) -> str:
    head = [
        "| layer | what it does | poses/s | µs per pose above idle | over the layer before "
        "(express: over the same layer put as nodes do; digest: over the digest layer before) "
        "| share of a core | of which the update thread, µs per pose |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    rows = []
    for layer, f in figures.items():
        cells = [f"`{layer}`", WHAT[layer], _spread(f.rate, 0), _spread(f.us),
                 _spread(f.step, unit=" µs"), _spread(f.share, 1, 100, " %"),
                 _spread(f.update_us)]  # fmt: skip
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(head + rows)


def delays(summary: dict[str, dict[str, Figures]]) -> str:
    """What each mode costs in delay: one-way, from the publisher's put to the pose handler."""
    lines = [
        "One-way delay of the `node` layer's poses (send time to the handler's arrival stamp, "
        "one host's clock), p50 / p99:"
    ]
    for mode, f in summary.items():
        for layer in ("node", "node" + EXPRESS, "node" + DIGEST):
            node = f[layer]
            lines.append(f"{mode} mode, `{layer}`: {_spread(node.p50_ms, 2)} / "
                         f"{_spread(node.p99_ms, 2)} ms.")  # fmt: skip
    return " ".join(lines)


def verdict(summary: dict[str, dict[str, Figures]]) -> str:
    """Where Zenoh's floor and the hand-off floor stand against the target, from the figures."""
    lines = [f"The target is a receive cost of at most {TARGET_US:g} µs per pose."]
    for mode, f in summary.items():
        floor, handed, node = (statistics.median(f[k].us) for k in ("zenoh", "handoff", "node"))
        room = (
            f"leaving {TARGET_US - floor:.1f} µs for everything Python does"
            if floor < TARGET_US
            else "leaving nothing for Python: this path cannot meet the target on this machine"
        )
        lines.append(
            f"In {mode} mode Zenoh's own floor (`zenoh`) is {floor:.1f} µs per pose, "
            f"{floor / TARGET_US:.0%} of the target, {room}; being handed the sample in Python "
            f"(`handoff`) takes it to {handed:.1f} µs, {_against(handed)}, before any of the "
            f"project's code runs; a node with its world view (`node`) pays {node:.1f} µs, "
            f"{node / TARGET_US:.1f}× the target."
        )
        alone, node_alone = (statistics.median(f[k + EXPRESS].us) for k in ("zenoh", "node"))
        lines.append(
            f"With a frame per pose (`+express`) Zenoh's floor is {alone:.1f} µs and the node "
            f"pays {node_alone:.1f} µs."
        )
        floor, handed, node = (statistics.median(f[k + DIGEST].us)
                               for k in ("zenoh", "handoff", "node"))  # fmt: skip
        lines.append(
            f"Through the authority's digest (`+digest`) Zenoh's floor is {floor:.1f} µs per "
            f"pose, being handed the digests in Python {handed:.1f} µs, and the node pays "
            f"{node:.1f} µs per pose, {_against(node)}."
        )
    return " ".join(lines)


def _against(us: float) -> str:
    if us <= TARGET_US:
        return f"within the target by {TARGET_US - us:.1f} µs"
    return f"{us - TARGET_US:.1f} µs over the target"


def _rounds(n: int) -> str:
    if n == 1:
        return "One round: one value per figure."
    return f"{n} rounds, every window once in each; figures are medians (range over rounds)."


def paths(windows: list[dict[str, Any]]) -> str:
    """Which way the poses came in each mode, from the links the subscribers held."""
    said = []
    for mode in dict.fromkeys(w["mode"] for w in windows):
        peers = [w["peers"] for w in windows if w["mode"] == mode and w["layer"] != IDLE]
        if min(peers) > 0:
            said.append(
                f"in {mode} mode every subscriber held a direct link to the publisher "
                "(learnt through the router), so the poses could skip the router"
            )
        elif max(peers) == 0:
            said.append(f"in {mode} mode no subscriber held a link but the router's")
        else:
            said.append(
                f"in {mode} mode some subscribers held a direct link to the publisher "
                "and some did not"
            )
    return "Links: " + "; ".join(said) + "."


def section(
    summary: dict[str, dict[str, Figures]], windows: list[dict[str, Any]], args: argparse.Namespace
) -> str:
    intro = (
        f"{args.egos} egos at {args.rate:g} Hz each ({args.egos * args.rate:.0f} poses/s) from "
        "one publisher process, a peer of one router, all on this machine over loopback TCP. "
        "Each layer is a subscriber process of its own, alone on the stream while it is "
        "measured (its whole process: getrusage over all threads, Zenoh's own included), "
        f"{args.warmup:g} s after it subscribed, for {args.seconds:g} s. The `zenoh` layer "
        "cannot count what reaches it, nor can `handoff+digest` (it would have to decode the "
        "digests): their poses are those the publisher sent in the window (the `handoff` and "
        "`node+digest` rows show how many arrive). Digests hold "
        f"{args.egos / SLICES:.1f} poses each (one every {1e3 / args.rate / SLICES:g} ms; the "
        "relay ships with 2 ms; the "
        "one-way delay of `node+digest` leaves out the relay's wait, which the scale "
        "benchmark measures). The idle window's CPU, scaled to each "
        "window's length, is subtracted; the `node` layer's update thread idling at 100 Hz "
        "is not in it. The `inbound` and `node` layers count each pose and note its delay in "
        f"one wrapper call more per pose than a node makes. {_rounds(args.rounds)}"
    )
    parts = [intro, "", paths(windows)]
    for mode, figures in summary.items():
        parts += ["", f"A node in **{mode}** mode:", "", table(figures)]
    return "\n".join([*parts, "", delays(summary), "", verdict(summary)])
