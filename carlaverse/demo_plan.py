"""What a local demo session runs: the authority's and each node's `carlaverse` arguments.

`carlaverse demo` and the launcher's demo start the same processes from this plan; each runs
them its own way (the demo as one command that prints a summary, the launcher as children it
lists and stops one by one).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import yaml

from carlaverse.config import ConfigError, load_config
from carlaverse.node_runtime import UnknownNodeKind, load_node_kind

DEFAULT_NODES = "scripted,scripted,scripted"
HEADLESS_KINDS = ("scripted", "observer")  # kinds that need no devices, sim or real


@dataclass(frozen=True)
class DemoChoices:
    """What the user chose for a demo session (`carlaverse demo`'s options)."""

    session: str = "demo"
    scenario: str = "town"  # a scenario file or shipped name; "none": membership only
    duration_s: float = 30.0  # [s] how long each node runs
    node_configs: tuple[str, ...] = ()  # KIND=FILE: the config of every node of KIND


def authority_argv(session: str, scenario: str, endpoint: str) -> list[str]:
    """The demo authority's `carlaverse` arguments (the launcher's authority runs the same)."""
    return ["authority", "--session", session, "--connect", endpoint,
            "--scenario", scenario, "--json"]  # fmt: skip


def node_plan(
    kinds: list[str], endpoint: str, choices: DemoChoices, directory: Path
) -> list[tuple[str, list[str]]]:
    """(node id, `carlaverse` arguments) of each demo node; scripted paths go to `directory`."""
    scripted = [i for i, k in enumerate(kinds) if k == "scripted"]
    plan = []
    for i, kind in enumerate(kinds):
        node_id = f"{kind}-{i + 1}"
        config = (
            _scripted_config(scripted.index(i), len(scripted), directory)
            if kind == "scripted"
            else None
        )
        plan.append((node_id, _node_argv(kind, node_id, config, endpoint, choices)))
    return plan


def check_nodes(kinds: list[str], node_configs: list[str] | tuple[str, ...]) -> str:
    """Why the requested nodes cannot start ("" if they can): unknown kind, bad config."""
    if not kinds:
        return "--nodes names no node kind"
    try:
        for kind in kinds:
            load_node_kind(kind)
        for item in node_configs:
            kind, sep, path = item.partition("=")
            if not sep or not kind or not path:
                return f"--node-config takes KIND=FILE, got {item!r}"
            if kind not in kinds:
                return f"--node-config {item!r}: no {kind!r} node in --nodes {','.join(kinds)}"
            load_config(path, load_node_kind(kind).config_type)
    except (UnknownNodeKind, ConfigError) as exc:
        return str(exc)
    return ""


def _scripted_config(index: int, count: int, directory: Path) -> Path:
    # Concentric circles, evenly phased, so the demo's actors never sit on top of each other.
    path = {
        "type": "circle",
        "center": [0.0, 0.0],
        "radius": 25.0 + 6.0 * index,  # [m]
        "speed_mps": 14.0 if index % 2 == 0 else -12.0,
        "phase_deg": 360.0 * index / max(1, count),
    }
    target = directory / f"scripted-{index + 1}.yaml"
    target.write_text(yaml.safe_dump({"path": path}))
    return target


def _node_argv(
    kind: str, node_id: str, config: Path | None, endpoint: str, choices: DemoChoices
) -> list[str]:
    argv = ["join", kind, "--id", node_id, "--session", choices.session, "--connect", endpoint,
            "--duration", str(choices.duration_s), "--json"]  # fmt: skip
    configs = dict(item.split("=", 1) for item in choices.node_configs)
    if kind in configs:  # the user's config wins over the demo's generated one
        argv += ["--config", configs[kind]]
    elif config is not None:
        argv += ["--config", str(config)]
    elif kind not in HEADLESS_KINDS:
        argv += ["--backend", "sim"]  # no hardware here: the kind's honest simulated devices
    return argv
