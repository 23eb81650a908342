"""Which OpenSCENARIO 1.x elements the importer (`openscenario.py`) reads, and how.

Every element named in the OpenSCENARIO 1.0–1.3 XML schemas (as `scenariogeneration` ships
them) gets one of four statuses:

- supported: read, and what it says is done;
- partly: read, with the part that is not done named (an attribute not read, a value refused);
- refused: the import stops with a one-line error naming it (the message is given);
- not read: outside the storyboard, where the scenario YAML owns the thing (actors, map,
  catalogues) — the importer never looks there.

The importer's own knowledge is in `EXPLICIT` (written by hand, held to its behaviour by
tests/traffic/test_openscenario_coverage_*.py); every other element's status follows from where
the schema lets it appear: a condition or action the importer does not know is refused (the
importer's message names it), anything that can only appear inside a refused element is
refused with it, and anything only outside the storyboard is not read. Each child of a
supported or partly supported element must be in `EXPLICIT`, so no part goes unexamined.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections import defaultdict, deque
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

SUPPORTED, PARTLY, REFUSED, NOT_READ = "supported", "partly", "refused", "not read"
XSD = "{http://www.w3.org/2001/XMLSchema}"
# `... is not supported; supported: <the importer's SUPPORTED keys>` follows each of these
EVENT_REFUSAL = "event 'NAME': {chain}… is not supported…"
INIT_REFUSAL = "Init action <…> is not supported: the scenario YAML places actors"
WRAPPED = "the elements inside it are read (it is a container)"

# element -> (status, what is read, or the refusal's message)
EXPLICIT: dict[str, tuple[str, str]] = {
    # the file
    "OpenSCENARIO": (PARTLY, "a scenario definition; a file without `Storyboard` is refused: "
                     "`<OpenSCENARIO> holds no <Storyboard>: a catalog or a parameter "
                     "distribution is not a scenario`"),
    "OpenScenario": (PARTLY, "as OpenSCENARIO (the root element's other spelling)"),
    "Catalog": (REFUSED, "a catalog file has no storyboard: `<OpenSCENARIO> holds no "
                "<Storyboard>: a catalog or a parameter distribution is not a scenario`"),
    "ParameterValueDistribution": (REFUSED, "a parameter variation file has no storyboard: "
                                   "`<OpenSCENARIO> holds no <Storyboard>: a catalog or a "
                                   "parameter distribution is not a scenario`"),
    "FileHeader": (NOT_READ, "file information"),
    "ParameterDeclarations": (NOT_READ, "declarations are not read; a `$name` reference or "
                              "`${expression}` in the storyboard is refused: `<…>: parameter "
                              "references and expressions are not supported: write the value`"),
    "VariableDeclarations": (NOT_READ, "variables are not used"),
    "MonitorDeclarations": (NOT_READ, "monitors are not used"),
    "CatalogLocations": (NOT_READ, "catalogues are not read"),
    "RoadNetwork": (NOT_READ, "the scenario YAML names the map (a SUMO network)"),
    "Entities": (NOT_READ, "the scenario YAML places actors; an entity's name is the "
                 "participant's or NPC's id"),
    "CatalogReference": (REFUSED, "in the storyboard: `<CatalogReference catalogName='…'> is "
                         "not supported: write the element out in the storyboard`; not read "
                         "in Entities"),
    # the storyboard
    "Storyboard": (SUPPORTED, "every Event of every Story becomes one trigger"),
    "Init": (PARTLY, f"must be empty: an action in it is refused: `{INIT_REFUSAL}`"),
    "Actions": (REFUSED, f"(Init's) `{INIT_REFUSAL}`"),
    "Story": (SUPPORTED, "its Acts"),
    "Act": (PARTLY, "its ManeuverGroups; its StartTrigger may hold SimulationTimeConditions "
            "only, OR-ed and AND-ed into each event's condition, anything else is refused: "
            "`Act 'NAME': only a SimulationTimeCondition may start an Act`"),
    "StopTrigger": (PARTLY, "must be empty: one with conditions is refused: `a StopTrigger "
                    "with conditions is not supported: a session ends by its --duration or "
                    "Ctrl-C`"),
    "ManeuverGroup": (PARTLY, "its Maneuvers; maximumExecutionCount is not read"),
    "Actors": (NOT_READ, "the actors are those each condition names"),
    "Maneuver": (SUPPORTED, "its Events"),
    "Event": (PARTLY, "one trigger named after it; maximumExecutionCount > 1 repeats it; "
              "priority is not read; an Event without a StartTrigger is refused: `event 'NAME': an "
              "event without a StartTrigger is not supported…`, as are two of one name: "
              "`events named '…' (as a trigger id) more than once: name each event apart`"),
    "Action": (SUPPORTED, WRAPPED),
    "StartTrigger": (SUPPORTED, "the trigger's condition"),
    "ConditionGroup": (SUPPORTED, "condition groups OR-ed, conditions within a group AND-ed"),
    "Condition": (PARTLY, "delay 0 and conditionEdge rising or none only (triggers fire on "
                  "rising); others refused: `event 'NAME': condition '…' with a delay is not "
                  "supported…`, `event 'NAME': conditionEdge '…' (triggers fire on rising) "
                  "is not supported…`"),
    "ByEntityCondition": (SUPPORTED, WRAPPED),
    "ByValueCondition": (SUPPORTED, WRAPPED),
    "EntityCondition": (SUPPORTED, WRAPPED),
    "TriggeringEntities": (SUPPORTED, "triggeringEntitiesRule any (OR) or all (AND)"),
    "EntityRef": (SUPPORTED, "an actor by name: a participant's or NPC's id"),
    # conditions
    "SimulationTimeCondition": (SUPPORTED, "`t` (scenario seconds) compared with value"),
    "StoryboardElementStateCondition": (PARTLY, "`fired_<ref> > 0` for an event; the state is "
                                        "not read; another element type, or an event the file "
                                        "lacks, is refused: `event 'NAME': "
                                        "StoryboardElementStateCondition on a … (events only) is "
                                        "not supported…`, `StoryboardElementStateCondition refers "
                                        "to '…', no event of this storyboard`"),
    "SpeedCondition": (PARTLY, "a `speed` measure compared with value; direction is not read"),
    "DistanceCondition": (PARTLY, "a `distance` measure from the entity's centre to a "
                          "WorldPosition: freespace false and a euclidean relativeDistanceType "
                          "only, others refused (`event 'NAME': DistanceCondition with freespace "
                          "true (centres only) is not supported…`, `event 'NAME': "
                          "DistanceCondition relativeDistanceType '…' is not supported…`); "
                          "coordinateSystem and routingAlgorithm are not read"),
    "ReachPositionCondition": (PARTLY, "`distance < tolerance` to a WorldPosition"),
    "TimeToCollisionCondition": (PARTLY, "a `ttc` measure between footprints, to an entity "
                                 "only, freespace true only (`event 'NAME': "
                                 "TimeToCollisionCondition with freespace false (footprints "
                                 "only) is not supported…`); coordinateSystem, "
                                 "relativeDistanceType and alongRoute are not read"),
    "TimeToCollisionConditionTarget": (PARTLY, "an EntityRef; a Position is refused: `event "
                                       "'NAME': TimeToCollisionCondition to a position is not "
                                       "supported…`"),
    "Position": (PARTLY, "a WorldPosition only; any other is refused: `event 'NAME': <…> "
                 "with a position other than WorldPosition is not supported…`"),
    "WorldPosition": (PARTLY, "x and y (the map is flat); z, h, p, r are not read"),
    # actions
    "GlobalAction": (SUPPORTED, WRAPPED),
    "UserDefinedAction": (SUPPORTED, WRAPPED),
    "InfrastructureAction": (SUPPORTED, WRAPPED),
    "TrafficSignalAction": (SUPPORTED, WRAPPED),
    "TrafficSignalStateAction": (PARTLY, "a `light` action: name is the SUMO signal's id, "
                                 "state its link characters (e.g. GGrr), not OpenSCENARIO's "
                                 "semicolon-separated lamp states"),
    "CustomCommandAction": (PARTLY, "type carlaverse.message (text: a message to everyone) or "
                            "carlaverse.release (text: an NPC id); other types refused: "
                            "`event 'NAME': CustomCommandAction type '…' is not supported…`"),
    "PrivateAction": (REFUSED, "`event 'NAME': <PrivateAction><…>… is not supported…` (the "
                      "scenario YAML and the traffic engine move actors)"),
    "EnvironmentAction": (PARTLY, "a `weather` action from its Environment; a catalogue "
                          "reference instead is refused"),
    "Environment": (PARTLY, "Weather and RoadCondition; TimeOfDay is not read"),
    "TimeOfDay": (NOT_READ, "the session keeps its own sun (Sun sets it)"),
    "Weather": (PARTLY, "Sun, Fog, Precipitation and cloud cover (cloudState, "
                "fractionalCloudCover: oktas / 8); temperature, atmosphericPressure not "
                "read; Wind and DomeImage refused: `event 'NAME': <Weather><Wind> is not "
                "supported…`"),
    "Sun": (PARTLY, "azimuth and elevation; intensity/illuminance not read"),
    "Fog": (PARTLY, "visualRange: fog density 1 − range / 1000 m; its BoundingBox not read"),
    "Precipitation": (PARTLY, "precipitationIntensity (intensity in 1.0): 10 mm/h = 1.0; "
                      "precipitationType not read"),
    "RoadCondition": (PARTLY, "wetness (dry 0 … highFlooded 1); frictionScaleFactor and "
                      "Properties not read"),
    "Wind": (REFUSED, "`event 'NAME': <Weather><Wind> is not supported…`"),
    "DomeImage": (REFUSED, "`event 'NAME': <Weather><DomeImage> is not supported…`"),
    "BoundingBox": (NOT_READ, "not read (Fog's, and entities')"),
    "Properties": (NOT_READ, "not read"),
}  # fmt: skip
_OTHER_POSITIONS = ("GeoPosition", "LanePosition", "RelativeLanePosition", "RelativeObjectPosition",
                    "RelativeRoadPosition", "RelativeWorldPosition", "RoadPosition",
                    "RoutePosition", "TrajectoryPosition")  # fmt: skip
EXPLICIT |= {
    name: (REFUSED, "in a condition: `event 'NAME': <…> with a position other "
           "than WorldPosition is not supported…`; elsewhere inside refused actions")
    for name in _OTHER_POSITIONS
}  # fmt: skip
# children of these types are conditions or actions the importer names when it refuses them
_REFUSED_CHOICES = ("EntityCondition", "ByValueCondition", "GlobalAction", "TrafficSignalAction",
                    "UserDefinedAction")  # fmt: skip
_NOT_READ_ROOTS = {k for k, (status, _) in EXPLICIT.items() if status == NOT_READ}


class CoverageError(RuntimeError):
    """The schema could not be found, or EXPLICIT misses a part of a supported element."""


@dataclass(frozen=True, slots=True)
class Row:
    element: str
    since: str  # the first OpenSCENARIO version whose schema has it
    status: str
    detail: str


@dataclass
class Schema:
    """Element names and the elements each type may contain, over every 1.x schema."""

    children: dict[str, set[tuple[str, str]]]  # type -> {(child element, child type)}
    since: dict[str, str]  # element name -> first version


def schema_files() -> list[tuple[str, Path]]:
    """(version, path) of the OpenSCENARIO XSDs scenariogeneration installs, oldest first."""
    try:
        files = metadata.files("scenariogeneration") or []
    except metadata.PackageNotFoundError as exc:
        raise CoverageError(
            "scenariogeneration is not installed: pip install scenariogeneration"
        ) from exc
    found = []
    for file in files:
        match = re.fullmatch(r"schemas/OpenSCENARIO_(\d+)_(\d+)(?:_\d+)?\.xsd", str(file))
        if match:
            found.append((f"{match[1]}.{match[2]}", Path(str(file.locate()))))
    if not found:
        raise CoverageError("scenariogeneration ships no schemas/OpenSCENARIO_*.xsd")
    return sorted(found, key=lambda vp: tuple(int(n) for n in vp[0].split(".")))


def read_schema(files: list[tuple[str, Path]]) -> Schema:
    schema = Schema(defaultdict(set), {})
    for version, path in files:
        root = ET.parse(path).getroot()
        groups = {g.get("name"): g for g in root.findall(f"{XSD}group")}
        for holder in [*root.findall(f"{XSD}complexType"), *groups.values()]:
            name = holder.get("name", "")
            key = f"group:{name}" if holder.tag == f"{XSD}group" else name
            for child in holder.iter(f"{XSD}element"):
                schema.children[key].add((child.get("name", ""), child.get("type", "")))
                schema.since.setdefault(child.get("name", ""), version)
            for ref in holder.iter(f"{XSD}group"):
                if ref.get("ref"):
                    schema.children[key].add(("", f"group:{ref.get('ref')}"))
        for top in root.findall(f"{XSD}element"):
            schema.children[""].add((top.get("name", ""), top.get("type", "")))
            schema.since.setdefault(top.get("name", ""), version)
    return schema


def _contents(schema: Schema, type_name: str) -> set[tuple[str, str]]:
    """The elements a type may contain, groups resolved."""
    out, todo, seen = set(), [type_name], set()
    while todo:
        current = todo.pop()
        if current in seen:
            continue
        seen.add(current)
        for name, child_type in schema.children.get(current, ()):
            if name:
                out.add((name, child_type))
            else:
                todo.append(child_type)
    return out


def _anchors(schema: Schema) -> tuple[dict[str, set[str]], dict[str, str], dict[str, set[str]]]:
    """For each element, the nearest elements with a status of their own above it (its
    "anchors"), the refused conditions and actions with their message, and each element's
    children."""
    refused: dict[str, str] = {}
    for chooser in _REFUSED_CHOICES:
        for name, _ in _contents(schema, chooser):
            refused.setdefault(name, EVENT_REFUSAL.format(chain=f"<{name}>"))
    for name, _ in _contents(schema, "PrivateAction"):
        refused[name] = EVENT_REFUSAL.format(chain=f"<PrivateAction><{name}>")
    anchors: dict[str, set[str]] = defaultdict(set)
    children: dict[str, set[str]] = defaultdict(set)
    queue: deque[tuple[str, str, str]] = deque([("", "", "")])
    seen: set[tuple[str, str, str]] = set()
    while queue:
        name, type_name, anchor = queue.popleft()
        for child, child_type in _contents(schema, type_name):
            children[name].add(child)
            # outside the storyboard nothing is read, whatever it would be inside
            own = (child in EXPLICIT or child in refused) and anchor not in _NOT_READ_ROOTS
            state = (child, child_type, child if own else anchor)
            if not own:
                anchors[child].add(anchor)
            if state not in seen:
                seen.add(state)
                queue.append(state)
    return anchors, refused, children


def coverage(schema: Schema | None = None) -> list[Row]:
    """One row per element, sorted by name."""
    schema = schema or read_schema(schema_files())
    anchors, refused, children = _anchors(schema)
    for name, (status, _) in EXPLICIT.items():
        known = EXPLICIT.keys() | refused.keys()
        missing = children[name] - known if status in (SUPPORTED, PARTLY) else set()
        if missing:
            raise CoverageError(
                f"{name} is {status}: add its children {sorted(missing)} to EXPLICIT"
            )
    rows = []
    for name in sorted(schema.since, key=str.lower):
        if name in EXPLICIT:
            status, detail = EXPLICIT[name]
        elif name in refused:
            status, detail = REFUSED, f"`{refused[name]}`"
        else:
            status, detail = _inherited(name, anchors[name], refused)
        rows.append(Row(name, schema.since[name], status, detail))
    return rows


def _status_of(anchor: str, refused: dict[str, str]) -> str:
    if anchor in EXPLICIT:
        return EXPLICIT[anchor][0]
    return REFUSED if anchor in refused else NOT_READ


def _inherited(name: str, anchors: set[str], refused: dict[str, str]) -> tuple[str, str]:
    """An element without a status of its own: refused inside refused elements, not read
    outside the storyboard."""
    by_status: dict[str, list[str]] = defaultdict(list)
    for anchor in sorted(anchors - {""}):
        by_status[_status_of(anchor, refused)].append(f"`{anchor}`")
    unexpected = by_status.keys() - {REFUSED, NOT_READ}
    if unexpected:
        raise CoverageError(f"{name} sits in a {'/'.join(unexpected)} element: add it to EXPLICIT")
    statuses = [s for s in (REFUSED, NOT_READ) if s in by_status]
    detail = "; ".join(f"{', '.join(by_status[s])} ({s})" for s in statuses)
    return " / ".join(statuses), f"only inside {detail}"


def markdown(rows: list[Row]) -> str:
    """The table, and a count per status."""
    counts: dict[str, int] = defaultdict(int)
    for row in rows:
        counts[row.status] += 1
    lines = [
        f"{len(rows)} elements: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())) + ".",
        "",
        "| element | since | status | what is read, or the error |",
        "|---|---|---|---|",
    ]
    lines += [f"| `{r.element}` | {r.since} | {r.status} | {r.detail} |" for r in rows]
    return "\n".join(lines) + "\n"
