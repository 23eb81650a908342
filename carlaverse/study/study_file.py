"""A study file: who takes part (pseudonyms only), the conditions, and how trials are ordered.

Strict like every config (`carlaverse.config`): a typo is an error naming the file and the
field path. What YAML cannot say is checked after decoding (`check_study`), each problem
with the field it concerns, as `FILE: problem - at `$.conditions[1].latency.P09``.

    name: lane-keeping
    launch: local             # the runner starts each participant's node (sim devices)
    participants:
      - {id: P01, role: driver, site: lab-a, kind: drive}
      - {id: P02, role: cyclist, site: lab-b, kind: bike}
    conditions:
      - {id: direct}
      - id: lagged
        latency: {P02: {delay_ms: 150, jitter_ms: 20, loss: 0.01}}
    design: {order: latin, blocks: 2, practice: [direct], seed: 7}
    trial: {duration_s: 60, start_timeout_s: 120}

Participants are pseudonyms by construction: an id is up to four letters and one to six
digits (`P07`, `S2P13` is not: `SP13` is), so no name can pass as one; the mapping to people
is never part of a study (`carlaverse.study.people`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import msgspec

from carlaverse.config import ConfigError, StrictStruct, convert, parse_yaml, read_text
from carlaverse.patterns import anchored
from carlaverse.study.questionnaires import find_questionnaire

# Up to four letters, then one to six digits: a code, never a name (issue 44.7).
PSEUDONYM = anchored(r"[A-Za-z]{0,4}[0-9]{1,6}")
NAME = anchored(r"[a-z0-9][a-z0-9_-]{0,39}")  # study, role, site and condition ids

Pseudonym = Annotated[str, msgspec.Meta(pattern=PSEUDONYM)]
Name = Annotated[str, msgspec.Meta(pattern=NAME)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Positive = Annotated[float, msgspec.Meta(gt=0)]


class LinkCondition(StrictStruct):
    """A participant's link to the router for a trial, one way, each direction alike."""

    delay_ms: Annotated[float, msgspec.Meta(ge=0, le=5000)] = 0.0  # [ms] one-way delay
    jitter_ms: Annotated[float, msgspec.Meta(ge=0, le=5000)] = 0.0  # [ms] uniform ± the delay
    loss: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.0  # fraction of segments lost

    @property
    def impaired(self) -> bool:
        return self.delay_ms > 0 or self.jitter_ms > 0 or self.loss > 0


class Participant(StrictStruct):
    """One person's place in the study: their pseudonym, role, site and node."""

    id: Pseudonym
    role: Name  # driver, cyclist, pedestrian, ...
    site: Name = "local"
    kind: Literal["drive", "bike", "walk", "scripted", "observer"] = "drive"
    config: str | None = None  # node config (path relative to the study file, or shipped)
    link_port: Annotated[int, msgspec.Meta(ge=0, le=65535)] = 0  # 0: any free port
    # the node serves its web HMI here (0: any free port), where questionnaires are answered;
    # None: no HMI (a study asking questionnaires then cannot reach this participant locally)
    hmi_port: Annotated[int, msgspec.Meta(ge=0, le=65535)] | None = None


class Condition(StrictStruct):
    """What varies between trials: the world (scenario, seed, overrides) and each participant's
    link and node settings."""

    id: Name
    scenario: str = "none"  # shipped name or path relative to the study file; none: no world
    seed: int | None = None  # the scenario's own when unset
    # deep-merged into the scenario (weather, triggers, traffic ...), checked as a scenario
    scenario_override: dict[str, Any] = {}
    # the link of each participant in this condition; `latency` names one participant's own
    link: LinkCondition = LinkCondition()
    latency: dict[str, LinkCondition] = {}  # participant id -> their link in this condition
    node_config: dict[str, dict[str, Any]] = {}  # participant id -> fields merged into config


class Design(StrictStruct):
    """How trials are ordered and repeated."""

    # latin: balanced Latin square (Williams) rows; shuffle: a seeded shuffle per block;
    # fixed: the conditions as listed
    order: Literal["latin", "shuffle", "fixed"] = "latin"
    # participant: each participant walks their own row (conditions may then differ between
    # participants of one trial only in what is per participant: latency, node config);
    # session: everyone walks row `row` (the group's row of the square)
    counterbalance: Literal["participant", "session"] = "participant"
    row: Annotated[int, msgspec.Meta(ge=0)] = 0
    blocks: Annotated[int, msgspec.Meta(ge=1, le=100)] = 1  # passes through every condition
    repeats: Annotated[int, msgspec.Meta(ge=1, le=100)] = 1  # trials of a condition in a row
    practice: list[Name] = []  # condition ids run first, for everyone alike, not analysed
    seed: int = 0  # of the shuffle


class TrialSettings(StrictStruct):
    """How long a trial lasts and how long the runner waits for everyone."""

    duration_s: Annotated[float, msgspec.Meta(gt=0, le=86400)] = 60.0  # [s] from the start
    start_timeout_s: Annotated[float, msgspec.Meta(gt=0, le=3600)] = 120.0  # [s] for all roles
    view_probe_hz: Annotated[float, msgspec.Meta(ge=0, le=100)] = 10.0  # [Hz] 0: no probe
    # end earlier, when one of these scenario triggers fires, or at the first contact
    end_on_triggers: list[str] = []
    end_on_contact: bool = False


class Questionnaires(StrictStruct):
    """What every participant answers on their node's HMI after each completed trial, before
    their node leaves: built-in names (ssq, nasa-tlx, raw-tlx) or YAML files beside the study."""

    after_trial: list[str] = []
    timeout_s: Annotated[float, msgspec.Meta(gt=0, le=86400)] = 600.0  # [s] per questionnaire


class LslSettings(StrictStruct):
    """LSL streams recorded into every trial's recording, and the study's own marker outlets."""

    streams: list[str] = []  # LSL stream names, found once before the first trial
    scope: Literal["machine", "lab"] = "machine"  # this host only, or the lab's network
    session_id: str = "default"  # liblsl's SessionID: only equal ids see each other
    known_peers: list[str] = []  # hosts asked directly where the lab's multicast is blocked
    wait_s: Annotated[float, msgspec.Meta(gt=0, le=600)] = 10.0  # [s] to find the streams
    markers: bool = True  # trial_start/trial_end markers and the session clock as LSL outlets


class Study(StrictStruct):
    """A whole study file."""

    name: Name
    participants: list[Participant]
    conditions: list[Condition]
    design: Design = Design()
    trial: TrialSettings = TrialSettings()
    # local: the runner starts each participant's agent (and so their node) on this machine;
    # external: each participant's machine runs `carlaverse study agent` itself
    launch: Literal["local", "external"] = "local"
    connect: list[str] = []  # an existing router; empty: the runner starts one on loopback
    questionnaires: Questionnaires = Questionnaires()
    lsl: LslSettings | None = None  # None: no LSL at all (pylsl is not loaded)


def load_study(path: str | Path) -> Study:
    """Read and check a study file; ConfigError names the file and the field."""
    source = Path(path)
    if not source.is_file():
        raise ConfigError(str(source), "no such study file")
    data = parse_yaml(read_text(source), str(source))
    study = convert(data, Study, str(source))
    problem = check_study(study)
    if problem:
        raise ConfigError(str(source), problem)
    for i, name in enumerate(study.questionnaires.after_trial):
        try:
            find_questionnaire(name, source.parent)
        except ConfigError as exc:
            raise ConfigError(
                str(source), f"{exc} - at `$.questionnaires.after_trial[{i}]`"
            ) from None
    return study


def check_study(study: Study) -> str:
    """What YAML types cannot say, as one line naming the field ("" when all is well)."""
    ids = [p.id for p in study.participants]
    names = [c.id for c in study.conditions]
    for problem in (
        _nonempty(ids, "participants"),
        _nonempty(names, "conditions"),
        _unique(ids, "participants", "id"),
        _unique(names, "conditions", "id"),
        _unique([p.id.lower() for p in study.participants], "participants", "id (ignoring case)"),
        *(_known(c, set(ids), i) for i, c in enumerate(study.conditions)),
        *(_links(c, i) for i, c in enumerate(study.conditions)),
        *(
            _condition(name, names, f"$.design.practice[{i}]")
            for i, name in enumerate(study.design.practice)
        ),
        _ports(study.participants),
        _hmi(study),
    ):
        if problem:
            return problem
    return ""


def _nonempty(items: list[str], field: str) -> str:
    return "" if items else f"at least one is needed - at `$.{field}`"


def _unique(items: list[str], field: str, what: str) -> str:
    seen: set[str] = set()
    for i, item in enumerate(items):
        if item in seen:
            return f"{what} {item!r} appears twice - at `$.{field}[{i}]`"
        seen.add(item)
    return ""


def _links(condition: Condition, index: int) -> str:
    """A jitter larger than its delay would deliver bytes before they were sent."""
    named = [("link", condition.link)] + [
        (f"latency[{pid}]", c) for pid, c in condition.latency.items()
    ]
    for field, link in named:
        if link.jitter_ms > link.delay_ms:
            return (
                f"jitter_ms {link.jitter_ms:g} exceeds delay_ms {link.delay_ms:g}: a byte cannot "
                f"arrive before it is sent - at `$.conditions[{index}].{field}.jitter_ms`"
            )
    return ""


def _known(condition: Condition, ids: set[str], index: int) -> str:
    for field in ("latency", "node_config"):
        for pid in getattr(condition, field):
            if pid not in ids:
                return (
                    f"no participant {pid!r} (participants: {', '.join(sorted(ids))}) "
                    f"- at `$.conditions[{index}].{field}.{pid}`"
                )
    return ""


def _condition(name: str, names: list[str], where: str) -> str:
    return "" if name in names else f"no condition {name!r} ({', '.join(names)}) - at `{where}`"


def _ports(participants: list[Participant]) -> str:
    ports = [p.link_port for p in participants if p.link_port]
    return _unique([str(port) for port in ports], "participants", "link_port")


def _hmi(study: Study) -> str:
    """Questionnaires are answered on the node's HMI: a local study must give each one."""
    if not study.questionnaires.after_trial or study.launch != "local":
        return ""
    for i, p in enumerate(study.participants):
        if p.hmi_port is None:
            return (f"{p.id} answers questionnaires on their node's HMI: give hmi_port "
                    f"(0: any free port) - at `$.participants[{i}].hmi_port`")  # fmt: skip
    return ""
