"""The key-expression space (docs/architecture.md §3): the only module that builds or parses keys.

Every key starts with `carlaverse/<session>/`. Node ids and session names are short,
human-readable tokens; anything that could act as a Zenoh wildcard or separator is refused
so a node id can never widen an ACL rule or collide with another key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from carlaverse.patterns import whole_ascii

ROOT = "carlaverse"
AUTHORITY_ID = "authority"

# Whole text, ASCII only (carlaverse.patterns): `gx\n` or a Cyrillic look-alike is no id.
_TOKEN = whole_ascii(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,62}")

# Interest management (docs/architecture.md §3): the world is cut into square tiles and the
# keys of what is spatial -- ego poses, NPC batches -- end in their tile, so a node subscribes
# to the tiles around it and Zenoh (the router, or a peer's writer-side filter) delivers
# nothing from elsewhere. The size is part of the protocol: every process must agree on it.
TILE_SIZE_M = 250.0  # [m]
# Canonical decimal only (no `-0`, no leading zero): one spelling per tile, so one key.
_TILE = whole_ascii(r"t(0|-?[1-9][0-9]{0,6})_(0|-?[1-9][0-9]{0,6})")
# Channels whose keys carry a tile: ego/<id>/pose/<tile>, world/npc/<tile>.
TILED_EGO_CHANNELS = ("pose",)
TILED_WORLD_CHANNELS = ("npc",)

# Per-node channels under ego/<node_id>/...
EGO_CHANNELS = ("pose", "skeleton", "state", "override")
WORLD_CHANNELS = ("npc", "lights", "weather", "events")
# `world/@egos`: the authority's pose digest (`messages.PoseDigest`), every ego's pose relayed
# many to a message for nodes that hear the whole session. A chunk starting with `@` is
# verbatim in Zenoh: no wildcard matches it, so a recorder or viewer subscribed to `**` does
# not take a second copy of every pose, and only a node that names the key receives it.
DIGEST_CHANNEL = "@egos"
# Per-node study channels under study/<node_id>/... (issue 44): the study runner asks a
# participant's node to show a questionnaire (`ask`), the node sends the answers (`answers`);
# under the study's own name as session, the runner briefs a participant's agent (`brief`).
STUDY_CHANNELS = ("ask", "answers", "brief")
KEY_AREAS = ("node", "ego", "world", "impulse", "audio", "authority", "study")
AUTHORITY_QUERIES = ("clock", "join", "leave", "snapshot", "map", "scenario", "configs")


class KeySpaceError(ValueError):
    """A node id, session name or key expression that does not belong to the key space."""


def check_token(value: str, what: str = "node id") -> str:
    """Return `value` if it is a valid session name or node id, else raise with the rule."""
    if not _TOKEN.fullmatch(value):
        raise KeySpaceError(
            f"invalid {what} {value!r}: use 1-63 letters, digits, '_', '.' or '-', "
            "starting with a letter or digit (e.g. 'tum-drive-1')"
        )
    return value


def tile_token(ix: int, iy: int) -> str:
    """The key chunk of tile (ix, iy): `t<ix>_<iy>`, e.g. `t3_-2`."""
    return f"t{ix}_{iy}"


def tile_of(x: float, y: float) -> tuple[int, int]:
    """The tile (ix, iy) holding world position (x, y) [m]."""
    return math.floor(x / TILE_SIZE_M), math.floor(y / TILE_SIZE_M)


def tile_index(token: str) -> tuple[int, int]:
    """(ix, iy) of a tile token; raise KeySpaceError naming it otherwise."""
    match = _TILE.fullmatch(token)
    if match is None:
        raise KeySpaceError(f"invalid tile {token!r}: expected t<ix>_<iy>, e.g. 't3_-2'")
    return int(match[1]), int(match[2])


@dataclass(frozen=True, slots=True)
class Keys:
    """Key builders for one session. Build once, reuse the strings."""

    session: str

    def __post_init__(self) -> None:
        check_token(self.session, "session name")

    @property
    def prefix(self) -> str:
        return f"{ROOT}/{self.session}"

    @property
    def everything(self) -> str:
        """Every key of the session but the verbatim one (`pose_digest`)."""
        return f"{self.prefix}/**"

    @property
    def pose_digest(self) -> str:
        return f"{self.prefix}/world/{DIGEST_CHANNEL}"

    @property
    def every_key(self) -> tuple[str, ...]:
        """Expressions that together cover every key of the session (ACL rules)."""
        return (self.everything, self.pose_digest)

    # presence
    def node(self, node_id: str) -> str:
        return f"{self.prefix}/node/{check_token(node_id)}"

    @property
    def all_nodes(self) -> str:
        return f"{self.prefix}/node/*"

    # ego channels
    def ego(self, node_id: str, channel: str) -> str:
        if channel not in EGO_CHANNELS:
            raise KeySpaceError(f"unknown ego channel {channel!r}; expected one of {EGO_CHANNELS}")
        return f"{self.prefix}/ego/{check_token(node_id)}/{channel}"

    def pose(self, node_id: str, tile: str) -> str:
        """Where node `node_id` publishes its pose while it is in `tile`."""
        tile_index(tile)
        return f"{self.ego(node_id, 'pose')}/{tile}"

    def poses_of(self, node_id: str) -> str:
        """Every pose of one node, whichever tile it is in."""
        return f"{self.ego(node_id, 'pose')}/**"

    def poses_in(self, tile: str) -> str:
        """Every node's pose published in `tile`."""
        tile_index(tile)
        return f"{self.prefix}/ego/*/pose/{tile}"

    def npc_in(self, tile: str) -> str:
        """The authority's batch of the NPCs in `tile` (`world/npc` carries all of them)."""
        tile_index(tile)
        return f"{self.world('npc')}/{tile}"

    def state(self, node_id: str) -> str:
        return self.ego(node_id, "state")

    def override(self, node_id: str) -> str:
        return self.ego(node_id, "override")

    def all_ego(self, channel: str) -> str:
        """Every node's `channel`; for a tiled channel (pose) in every tile."""
        if channel not in EGO_CHANNELS:
            raise KeySpaceError(f"unknown ego channel {channel!r}; expected one of {EGO_CHANNELS}")
        if channel in TILED_EGO_CHANNELS:
            return f"{self.prefix}/ego/*/{channel}/**"
        return f"{self.prefix}/ego/*/{channel}"

    # world, written by the authority
    def world(self, channel: str) -> str:
        if channel not in WORLD_CHANNELS:
            raise KeySpaceError(f"unknown world channel {channel!r}; expected {WORLD_CHANNELS}")
        return f"{self.prefix}/world/{channel}"

    def impulse(self, node_id: str) -> str:
        return f"{self.prefix}/impulse/{check_token(node_id)}"

    def audio(self, node_id: str) -> str:
        return f"{self.prefix}/audio/{check_token(node_id)}"

    # authority queryables
    def authority(self, query: str) -> str:
        if query not in AUTHORITY_QUERIES:
            raise KeySpaceError(f"unknown authority query {query!r}; expected {AUTHORITY_QUERIES}")
        return f"{self.prefix}/authority/{query}"

    # study: questionnaires between trials
    def study(self, node_id: str, channel: str) -> str:
        if channel not in STUDY_CHANNELS:
            raise KeySpaceError(f"unknown study channel {channel!r}; expected {STUDY_CHANNELS}")
        return f"{self.prefix}/study/{check_token(node_id)}/{channel}"

    def subtree(self, area: str, node_id: str | None = None) -> str:
        """`<prefix>/<area>/**` or `<prefix>/<area>/<node_id>/**`: ACL rules and wide queries."""
        if area not in KEY_AREAS:
            raise KeySpaceError(f"unknown key area {area!r}; expected one of {KEY_AREAS}")
        if node_id is None:
            return f"{self.prefix}/{area}/**"
        return f"{self.prefix}/{area}/{check_token(node_id)}/**"

    def with_session(self, key: str, session: str) -> str:
        """The same key under another session (replay rewrites keys this way)."""
        parsed = parse(key)
        return f"{ROOT}/{check_token(session, 'session name')}/{parsed.path}"


@dataclass(frozen=True, slots=True)
class ParsedKey:
    """A concrete key split into its parts; `node_id` is empty where the key has none."""

    session: str
    area: str  # node | ego | world | impulse | audio | authority | study
    channel: str  # pose/state/... for ego; npc/lights/... for world; query name for authority;
    # ask/answers for study
    node_id: str
    tile: str = ""  # tiled channels: the tile the key addresses ("" for the whole world)

    @property
    def path(self) -> str:
        """The key after `carlaverse/<session>/`."""
        suffix = f"/{self.tile}" if self.tile else ""
        if self.area in ("ego", "study"):
            return f"{self.area}/{self.node_id}/{self.channel}{suffix}"
        if self.area in ("node", "impulse", "audio"):
            return f"{self.area}/{self.node_id}"
        return f"{self.area}/{self.channel}{suffix}"


def parse(key: str) -> ParsedKey:
    """Split a concrete key of the space; raise KeySpaceError naming the key otherwise."""
    parts = str(key).split("/")
    if len(parts) < 4 or parts[0] != ROOT or not _TOKEN.fullmatch(parts[1]):
        raise KeySpaceError(f"not a carlaverse key: {key!r}")
    session, area, rest = parts[1], parts[2], parts[3:]
    if area == "ego" and len(rest) == 3 and rest[1] in TILED_EGO_CHANNELS and _tiled(rest):
        return ParsedKey(session, area, rest[1], rest[0], rest[2])
    if area == "ego" and len(rest) == 2 and rest[1] in EGO_CHANNELS and _TOKEN.fullmatch(rest[0]):
        return ParsedKey(session, area, rest[1], rest[0])
    if (
        area == "world"
        and len(rest) == 2
        and rest[0] in TILED_WORLD_CHANNELS
        and _TILE.fullmatch(rest[1])
    ):
        return ParsedKey(session, area, rest[0], "", rest[1])
    if (
        area == "study"
        and len(rest) == 2
        and rest[1] in STUDY_CHANNELS
        and _TOKEN.fullmatch(rest[0])
    ):
        return ParsedKey(session, area, rest[1], rest[0])
    if area in ("node", "impulse", "audio") and len(rest) == 1 and _TOKEN.fullmatch(rest[0]):
        return ParsedKey(session, area, "", rest[0])
    if area == "world" and len(rest) == 1 and rest[0] in (*WORLD_CHANNELS, DIGEST_CHANNEL):
        return ParsedKey(session, area, rest[0], "")
    if area == "authority" and len(rest) == 1 and rest[0] in AUTHORITY_QUERIES:
        return ParsedKey(session, area, rest[0], "")
    raise KeySpaceError(f"not a carlaverse key: {key!r}")


@lru_cache(maxsize=4096)
def parse_cached(key: str) -> ParsedKey:
    """`parse`, remembered: a pose subscriber meets the same few hundred keys thousands of
    times a second. Bounded, so a flood of new keys costs no more than parsing each; a key
    that does not parse raises every time (exceptions are not cached)."""
    return parse(key)


def _tiled(rest: list[str]) -> bool:
    """`<id>/<channel>/<tile>` with a valid id and tile."""
    return bool(_TOKEN.fullmatch(rest[0]) and _TILE.fullmatch(rest[2]))
