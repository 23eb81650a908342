"""What `carlaverse demo` reports: one row per node, from the JSON summary each node printed.

A row tells a node that failed (its exit code and its last error line) from one that ran, and
among the actors a node saw leave, those that left on purpose (`left`) from those it lost
(lease, silence, removed by the authority).
"""

from __future__ import annotations

import math
from typing import Any

from carlaverse.cli.common import to_json

# Despawn reasons (messages.Despawned.reason) that mean "left on purpose"; every other one
# (liveliness, timeout, authority) is a loss.
NORMAL_LEAVES = frozenset({"left"})


def node_row(node_id: str, actors: list[str], entry: dict[str, Any]) -> dict[str, Any]:
    """The table row of one node from its exit code, JSON summary and last error line."""
    summary = entry.get("summary") or {}
    seen = set(summary.get("actors_seen", []))
    despawns = summary.get("despawns", [])
    peers = summary.get("peers", {}).values()
    return {
        "exit_code": entry.get("exit_code"),
        "error": entry.get("error", "") if entry.get("exit_code") != 0 else "",
        "joined": summary.get("joined", False),
        "actors_seen": sorted(seen),
        "missing": sorted({a for a in actors if a != node_id} - seen),
        "latency_p50_ms": _worst(peers, "latency_p50_ms"),
        "latency_p99_ms": _worst(peers, "latency_p99_ms"),
        "despawns": despawns,
        "left": sorted(n for n, reason in despawns if reason in NORMAL_LEAVES),
        "lost": sorted(f"{n} ({reason})" for n, reason in despawns if reason not in NORMAL_LEAVES),
        "dropped": dict(summary.get("dropped", {})),
        "rejected": dict(summary.get("rejected", {})),
        "handler_errors": dict(summary.get("handler_errors", {})),
        "npcs_now": summary.get("npcs_now", 0),
        "poses_sent": summary.get("poses_sent", 0),
        "waiting_for": summary.get("waiting_for", ""),
    }


def summarise(
    ids: list[str],
    nodes: dict[str, Any],
    authority: dict[str, Any] | None,
    watched: dict[str, Any],
    tools: dict[str, int],
    tool_errors: dict[str, str],
    interrupted: str = "",
) -> dict[str, Any]:
    """The demo's result: ok only if every node and tool exited 0 and nobody interrupted it."""
    actors = [i for i in ids if not i.startswith("observer")]
    table = {node_id: node_row(node_id, actors, nodes.get(node_id, {})) for node_id in ids}
    all_seen = all(not row["missing"] and row["exit_code"] == 0 for row in table.values())
    ok = (
        not interrupted
        and all(row["exit_code"] == 0 for row in table.values())
        and all(code == 0 for code in tools.values())
    )
    return {
        "ok": ok,
        "interrupted": interrupted,
        "all_seen": all_seen,
        "nodes": table,
        "authority": authority,
        "observer": watched,
        "tools": tools,  # name -> exit code
        "tool_errors": {name: tool_errors.get(name, "") for name, c in tools.items() if c != 0},
    }


def _worst(peers: Any, field_name: str) -> float | None:
    values = [p.get(field_name) for p in peers if isinstance(p.get(field_name), float | int)]
    values = [v for v in values if not math.isnan(v)]
    return max(values) if values else None


def format_summary(summary: dict[str, Any], as_json: bool) -> str:
    if as_json:
        return to_json(summary)
    lines = [
        f"{'node':<14} {'status':<7} {'joined':<7} {'saw':<4} {'NPCs':>5} {'p50 ms':>8} "
        f"{'p99 ms':>8} {'left':>5} {'lost':>5} {'dropped':>8} {'rejected':>8}  missing"
    ]
    for node_id, row in summary["nodes"].items():
        lines.append(_table_line(node_id, row))
    lines += LEGEND
    lines += _problems(summary)
    tick = (summary.get("authority") or {}).get("tick") or {}
    if tick:
        lines.append(
            f"authority: {tick.get('ticks')} ticks, p50 {tick.get('tick_p50_ms')} ms, "
            f"p99 {tick.get('tick_p99_ms')} ms"
        )
    lines.append(_seen_sentence(summary))
    if summary.get("interrupted"):
        lines.append(f"interrupted ({summary['interrupted']}): the run was cut short")
    return "\n".join(lines)


# Under the table, so that a reader meets the columns' meaning where they read them.
LEGEND = [
    "  saw: other actors the node saw; NPCs: NPCs in its world at exit; p50/p99: worst peer's "
    "one-way pose latency",
    "  left: actors it saw leave on purpose (they stopped); lost: actors it lost to a lease, "
    "silence or the authority",
    "  dropped/rejected: its undecodable/refused input messages; missing: actors it never saw",
]


def _seen_sentence(summary: dict[str, Any]) -> str:
    """The closing verdict; with one actor there is no other to see, so it says that instead."""
    actors = [n for n in summary["nodes"] if not n.startswith("observer")]
    if not actors:
        return "no actor node ran: nothing to see"
    if len(actors) == 1:
        return f"only one node ran ({actors[0]}): there was no other node for it to see"
    if summary["all_seen"]:
        return "every node saw every other node"
    return "NOT every node saw every other node"


def _table_line(node_id: str, row: dict[str, Any]) -> str:
    p50, p99 = row["latency_p50_ms"], row["latency_p99_ms"]
    status = "ok" if row["exit_code"] == 0 else f"exit {row['exit_code']}"
    return (
        f"{node_id:<14} {status:<7} {row['joined']!s:<7} {len(row['actors_seen']):<4} "
        f"{row['npcs_now']:>5} {_ms(p50):>8} {_ms(p99):>8} {len(row['left']):>5} "
        f"{len(row['lost']):>5} {sum(row['dropped'].values()):>8} "
        f"{sum(row['rejected'].values()):>8}  "
        f"{' '.join(row['missing']) or '-'}"
    )


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def _problems(summary: dict[str, Any]) -> list[str]:
    """One line per failed node or tool (with its last error line) and per lost actor."""
    lines = []
    for name, row in summary["nodes"].items():
        if row["exit_code"] != 0:
            lines.append(f"{name} failed (exit {row['exit_code']}): {row['error'] or '?'}")
        if row["lost"]:
            lines.append(f"{name} lost {', '.join(row['lost'])}")
        for what in ("dropped", "rejected", "handler_errors"):
            if row[what]:
                counts = ", ".join(f"{k} {v}" for k, v in sorted(row[what].items()))
                lines.append(f"{name} {what.replace('_', ' ')}: {counts}")
    for name, code in summary["tools"].items():
        if code != 0:
            lines.append(f"{name} failed (exit {code}): {summary['tool_errors'][name] or '?'}")
    return lines
