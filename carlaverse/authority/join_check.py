"""Is this join request one the authority can accept? One reason per problem, naming the fix.

A request that decodes can still describe no real node: a pose rate of zero, an infinite
extent, an actor kind nobody renders, a config that is not YAML, an id that would widen a key.
Each is refused here with one line naming the field, the value and what to do, which the
node prints as it exits.
"""

from __future__ import annotations

import math

import yaml

from carlaverse.keys import AUTHORITY_ID, KeySpaceError, check_token
from carlaverse.messages import ACTOR_KINDS, SCHEMA_VERSION, JoinRequest
from carlaverse.patterns import whole_ascii

OBSERVER_KIND = "observer"  # the one node kind without an actor
MAX_POSE_RATE_HZ = 1000.0
MAX_EXTENT_M = 50.0  # [m] longer than any road vehicle with trailers
MAX_MASS_KG = 200_000.0  # [kg] a heavy-haul truck
MAX_CONFIG_BYTES = 64 * 1024
MAX_CONFIG_DEPTH = 32  # nesting levels of the config; real ones use fewer than 10
TEXT_LIMITS = {"instance": 64, "kind": 32, "site": 64, "hostname": 255, "version": 64}
# hostname and version are shown to people (logs, "already in use ... from <hostname>"):
# no control character, space or look-alike letter may travel in them.
_SHOWN_TEXT = whole_ascii(r"[!-~]*")

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # C parser: a join stays cheap


def join_problem(req: JoinRequest) -> str:
    """Why `req` cannot be accepted, or "" if it can."""
    for check in (_schema, _node_id, _texts, _kinds, _numbers, _config):
        problem = check(req)
        if problem:
            return problem
    return ""


def _schema(req: JoinRequest) -> str:
    if req.schema == SCHEMA_VERSION:
        return ""
    return (
        f"schema version {req.schema} does not match the authority's {SCHEMA_VERSION}; "
        "run the same carlaverse version on every node"
    )


def _node_id(req: JoinRequest) -> str:
    if req.node_id == AUTHORITY_ID:
        return f"node id {AUTHORITY_ID!r} is reserved for the authority; choose another --id"
    try:
        check_token(req.node_id)
    except KeySpaceError as exc:
        return str(exc)
    return ""


def _texts(req: JoinRequest) -> str:
    for field, limit in TEXT_LIMITS.items():
        value = getattr(req, field)
        if len(value) > limit:
            return f"{field} is {len(value)} characters long; at most {limit} are allowed"
    if not req.instance:
        return "instance is empty; send a random id per process run (e.g. a UUID)"
    for field, what in (("instance", "instance"), ("site", "site name")):
        value = getattr(req, field)
        if field == "instance" or value:
            try:
                check_token(value, what)
            except KeySpaceError as exc:
                return str(exc)
    for field in ("hostname", "version"):
        if not _SHOWN_TEXT.fullmatch(getattr(req, field)):
            return f"{field} {getattr(req, field)!r} is not printable ASCII without spaces"
    return ""


def _kinds(req: JoinRequest) -> str:
    try:
        check_token(req.kind, "node kind")
    except KeySpaceError as exc:
        return str(exc)
    if req.actor_kind in ACTOR_KINDS:
        return ""
    if req.actor_kind == "" and req.kind == OBSERVER_KIND:
        return ""
    if req.actor_kind == "":
        return f"actor_kind is empty for a {req.kind!r} node; only observers have no actor"
    return f"unknown actor_kind {req.actor_kind!r}; expected one of {', '.join(ACTOR_KINDS)}"


def _numbers(req: JoinRequest) -> str:
    ranges = {
        "pose_rate_hz": (req.pose_rate_hz, MAX_POSE_RATE_HZ, "Hz"),
        "extent.length": (req.extent.length, MAX_EXTENT_M, "m"),
        "extent.width": (req.extent.width, MAX_EXTENT_M, "m"),
        "extent.height": (req.extent.height, MAX_EXTENT_M, "m"),
        "mass_kg": (req.mass_kg, MAX_MASS_KG, "kg"),
    }
    for field, (value, limit, unit) in ranges.items():
        if not (math.isfinite(value) and 0.0 < value <= limit):
            return f"{field} = {value!r}: must be in (0, {limit:g}] {unit}; fix the node's config"
    return ""


def _config(req: JoinRequest) -> str:
    text = req.config_yaml
    size = len(text.encode("utf-8", "replace"))
    if size > MAX_CONFIG_BYTES:
        return f"config_yaml is {size} bytes; at most {MAX_CONFIG_BYTES} are archived"
    # Deep nesting is checked before libyaml sees it: it recurses without a limit when it
    # builds objects (a segfault at ~100k levels) and slows down quadratically on deep flow
    # collections ("[" * 100_000 takes ~30 s).
    if _flow_depth(text) > MAX_CONFIG_DEPTH:
        return f"config_yaml nests deeper than {MAX_CONFIG_DEPTH} levels"
    try:
        if _block_depth(text) > MAX_CONFIG_DEPTH:
            return f"config_yaml nests deeper than {MAX_CONFIG_DEPTH} levels"
        yaml.load(text, Loader=_Loader)  # a safe loader, C or Python
    except Exception as exc:  # YAMLError and whatever a hostile document provokes
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return f"config_yaml does not parse as YAML ({first}); send the node's config as YAML"
    return ""


def _flow_depth(text: str) -> int:
    """An upper bound of the `[`/`{` nesting (brackets inside strings count too)."""
    depth = deepest = 0
    for char in text:
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}" and depth:
            depth -= 1
    return deepest


def _block_depth(text: str) -> int:
    """The nesting of collections, from libyaml's event stream; stops once past the limit."""
    depth = deepest = 0
    for event in yaml.parse(text, Loader=_Loader):
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            deepest = max(deepest, depth)
            if deepest > MAX_CONFIG_DEPTH:
                break
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1
    return deepest
