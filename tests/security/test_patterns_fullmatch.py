"""Every pattern that validates outside text holds for the whole text, in ASCII (issue 39 item 6).

The attack: node ids `f-a\\n` and `gx\\n` were admitted and observers listed them as actors,
because the id pattern ended in `$`, which in Python also matches before a final newline.

Each validator is fed one value it must accept (so the test shows the validator works) and
variants of it that no rule of docs/protocol.md ("Names") admits: a trailing or leading
newline, a NUL, spaces and tabs at either end, and look-alikes that are not ASCII -- Cyrillic
'а' for Latin 'a', fullwidth letters, Arabic-Indic digits ('٣' is a digit to `str.isdigit`,
`\\d` and `int`), the Kelvin sign 'K' (which lowercases to 'k'). Every variant must be refused.

The msgspec patterns are found by walking the Structs of every module that declares one, so a
new pattern without an example here fails `test_every_msgspec_pattern_has_an_example`; each
is checked as msgspec applies it (a search) and, because `carlaverse schema --json` copies it
into JSON Schema, by a real ECMA-262 engine (Node's) with the `u` flag.

The live test joins `gx\\n` through a real router and a real authority, and forges its
presence token and poses, while a real observer watches.
"""

from __future__ import annotations

import importlib
import json
import re
import shutil
import subprocess
import typing
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import msgspec
import pytest

from carlaverse import messages as m
from carlaverse.authority.join_check import join_problem
from carlaverse.cli.doctor import host_port
from carlaverse.hmi.config import PAGE_NAME
from carlaverse.hmi.site import ASSET
from carlaverse.keys import Keys, KeySpaceError, check_token, parse, tile_index
from carlaverse.render.scene_roads import edge_and_index
from carlaverse.security.roster import load_roster
from carlaverse.traffic.openscenario import _identifier
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricError, FabricSettings, check_endpoint, open_session
from tests.support import Cluster, wait_until

REPO = Path(__file__).resolve().parents[2]
CYRILLIC = dict(zip("aceopxyAEKMHOPCTX", "асеорхуАЕКМНОРСТХ", strict=True))
KELVIN = "\u212a"  # 'K': "K".lower() == "k"


def hostile_variants(valid: str) -> list[str]:
    """Values a whole-text, ASCII-only validator must refuse, derived from one it accepts."""
    out = [valid + "\n", "\n" + valid, valid + "\r\n", valid + "\n\n", valid + "\x00",
           valid[:1] + "\x00" + valid[1:], " " + valid, valid + " ", valid + "\t"]  # fmt: skip
    if any(c in CYRILLIC for c in valid):
        out.append("".join(CYRILLIC.get(c, c) for c in valid))
    if any("!" <= c <= "~" for c in valid):  # fullwidth forms are ASCII + 0xFEE0
        out.append("".join(chr(ord(c) + 0xFEE0) if "!" <= c <= "~" else c for c in valid))
    if any(c in "kK" for c in valid):
        out.append("".join(KELVIN if c in "kK" else c for c in valid))
    if any(c in "0123456789" for c in valid):  # Arabic-Indic digits are U+0660..U+0669
        out.append("".join(chr(0x660 + int(c)) if c in "0123456789" else c for c in valid))
    return out


def _ids(params: list[Any]) -> list[str]:
    return [p.values[0] if hasattr(p, "values") else p[0] for p in params]


def refuses(check: Callable[[str], object], errors: tuple[type[Exception], ...]) -> Callable:
    """`check` as a predicate: False when it raises one of `errors` (its way of refusing)."""

    def accepted(value: str) -> bool:
        try:
            check(value)
        except errors:
            return False
        return True

    return accepted


def _roster_accepts(node_id: str, tmp: Path, kind: str = "drive") -> bool:
    path = tmp / "roster.yaml"
    path.write_text(json.dumps({  # JSON is YAML: the id's control characters stay escaped
        "session": "lab", "sites": [{"name": "a"}],
        "nodes": [{"id": "authority", "kind": "authority", "site": "a"},
                  {"id": node_id, "kind": kind, "site": "a"}],
    }))  # fmt: skip
    try:
        load_roster(path)
    except Exception:  # RosterError / ConfigError: refused, whichever names the entry
        return False
    return True


def _join_accepts(**fields: str) -> bool:
    request = m.JoinRequest(m.SCHEMA_VERSION, **{"node_id": "n1", "instance": "i1",
                                                 "kind": "drive", **fields})  # type: ignore[arg-type]  # fmt: skip
    return join_problem(request) == ""


def _key(template: str) -> Callable[[str], bool]:
    return refuses(lambda v: parse(template.format(v)), (KeySpaceError,))


K = Keys("lab")

# (name, accepts(value) -> bool, a value it must accept)
VALIDATORS: list[Any] = [
    ("node id", refuses(check_token, (KeySpaceError,)), "tum-drive-1"),
    ("node id (upper, dots)", refuses(check_token, (KeySpaceError,)), "Kth.Bike_2"),
    ("session name", refuses(Keys, (KeySpaceError,)), "eu-demo"),
    ("tile", refuses(tile_index, (KeySpaceError,)), "t3_-2"),
    ("key: session", _key("carlaverse/{}/node/a"), "demo"),
    ("key: presence id", _key("carlaverse/demo/node/{}"), "gx"),
    ("key: ego id", _key("carlaverse/demo/ego/{}/state"), "f-a"),
    ("key: pose id", _key("carlaverse/demo/ego/{}/pose/t0_0"), "f-a"),
    ("key: pose tile", _key("carlaverse/demo/ego/gx/pose/{}"), "t10_-7"),
    ("key: npc tile", _key("carlaverse/demo/world/npc/{}"), "t0_0"),
    ("key: audio id", _key("carlaverse/demo/audio/{}"), "kth-bike-1"),
    ("key: impulse id", _key("carlaverse/demo/impulse/{}"), "k9"),
    ("endpoint tcp", refuses(check_endpoint, (FabricError,)), "tcp/127.0.0.1:7447"),
    ("endpoint host name", refuses(check_endpoint, (FabricError,)), "tls/tum.example.org:7447"),
    ("endpoint ipv6", refuses(check_endpoint, (FabricError,)), "quic/[::1]:7447"),
    ("endpoint unix socket", refuses(check_endpoint, (FabricError,)), "unixsock-stream/run/z.sock"),
    ("doctor HOST:PORT", refuses(host_port, (ValueError,)), "127.0.0.1:45500"),
    ("join: node id", lambda v: _join_accepts(node_id=v), "kth-bike-1"),
    ("join: node kind", lambda v: _join_accepts(kind=v), "drive"),
    ("join: site", lambda v: _join_accepts(site=v), "kth"),
    ("join: instance", lambda v: _join_accepts(instance=v), "4f2a9c"),
    ("join: hostname", lambda v: _join_accepts(hostname=v), "rig-7.example.org"),
    ("join: version", lambda v: _join_accepts(version=v), "0.7.2"),
    ("map lane id index", lambda v: edge_and_index(f"edge_{v}") is not None, "12"),
    pytest.param("hmi page name", lambda v: bool(PAGE_NAME.match(v)), "dash-1"),
    pytest.param("hmi asset name", lambda v: bool(ASSET.match(v)), "hmi.js"),
]


@pytest.mark.parametrize(("name", "accepts", "valid"), VALIDATORS, ids=_ids(VALIDATORS))
def test_each_validator_refuses_newlines_nuls_spaces_and_look_alikes(
    name: str, accepts: Callable[[str], bool], valid: str
) -> None:
    assert accepts(valid), f"{name}: the valid example {valid!r} was refused"
    admitted = [v for v in hostile_variants(valid) if accepts(v)]
    assert admitted == [], f"{name} admitted {admitted}"


def test_a_roster_refuses_an_id_with_a_newline_or_a_look_alike(tmp_path: Path) -> None:
    assert _roster_accepts("gx", tmp_path)
    admitted = [v for v in hostile_variants("gx") if _roster_accepts(v, tmp_path)]
    assert admitted == []
    # the kind decides what the router lets the node do (security/acl.py)
    kinds = [v for v in hostile_variants("observer") if _roster_accepts("gx", tmp_path, v)]
    assert kinds == []


def test_an_openscenario_name_becomes_an_ascii_identifier() -> None:
    """Names in an imported .xosc are free text; the trigger they become needs an
    `Identifier` (ASCII), so a Cyrillic or fullwidth letter is replaced, not kept."""
    identifier = all_patterns()["carlaverse.traffic.trigger_spec.*.Identifier"]
    for name in ("Тормоз", "ｓｔｏｐ", "brake-٣", "stop"):
        made = _identifier(name)
        assert re.search(identifier, made), (name, made)


def test_a_pose_key_with_a_non_canonical_tile_is_refused() -> None:
    """One tile, one key: `t0_0` is the only spelling of tile (0, 0) (`tile_token`), so
    `t-0_0` or `t00_0` would let a sender open a second key for a tile."""
    for tile in ("t-0_0", "t00_0", "t0_-0", "t+1_0", "t01_2"):
        with pytest.raises(KeySpaceError):
            tile_index(tile)


# ------------------------------------------------------------------ msgspec patterns

# Every Struct field with a msgspec pattern, by `module.Struct.field`, and a value it accepts.
PATTERN_EXAMPLES = {
    "carlaverse.audio.config.*.Layout": "ring8",
    # a field's pattern equal to an alias's is checked once, under the alias: the sound
    # zones' names follow the node-id rule, as StudyId does
    "carlaverse.messages.study.*.StudyId": "bridge-works.2",
    "carlaverse.hmi.wire.*.StudyId": "t1.nasa-tlx",
    "carlaverse.study.study_file.*.Name": "latency-dyad",
    "carlaverse.study.study_file.*.Pseudonym": "p01",
    "carlaverse.traffic.scenario.PhaseSpec.state": "rGyo",
    "carlaverse.traffic.trigger_spec.Light.state": "GGrr",
    "carlaverse.traffic.trigger_spec.*.Identifier": "gap_1",
    "carlaverse.hmi.wire.*.ActionName": "horn",
}


def _modules_with_patterns() -> list[str]:
    names = []
    for package in ("carlaverse", "nodes"):
        for path in sorted((REPO / package).rglob("*.py")):
            if "pattern=" in path.read_text(encoding="utf-8"):
                names.append(".".join(path.relative_to(REPO).with_suffix("").parts))
    return names


def _patterns_in(hint: object) -> Iterator[str]:
    """The msgspec patterns inside a type hint (`Annotated`, nested in lists, unions ...)."""
    for meta in getattr(hint, "__metadata__", ()):
        if isinstance(meta, msgspec.Meta) and meta.pattern is not None:
            yield meta.pattern
    for arg in typing.get_args(hint):
        yield from _patterns_in(arg)


def all_patterns() -> dict[str, str]:
    """Every msgspec pattern of the code base: a module-level alias (`Identifier`) as
    `module.*.Alias`, a pattern written on a Struct field as `module.Struct.field`."""
    aliases: dict[str, str] = {}
    fields: dict[str, str] = {}
    for name in _modules_with_patterns():
        module = importlib.import_module(name)
        for attr, value in vars(module).items():
            if getattr(value, "__metadata__", None):
                aliases.update({f"{name}.*.{attr}": p for p in _patterns_in(value)})
            elif isinstance(value, type) and issubclass(value, msgspec.Struct):
                if value.__module__ != name:
                    continue
                hints = typing.get_type_hints(value, include_extras=True)
                for field, hint in hints.items():
                    fields.update({f"{name}.{attr}.{field}": p for p in _patterns_in(hint)})
    shared = set(aliases.values())
    return {**{k: p for k, p in fields.items() if p not in shared}, **aliases}


def test_every_msgspec_pattern_has_an_example() -> None:
    patterns = all_patterns()
    assert patterns, "the walk found no msgspec pattern at all"
    missing = sorted(set(patterns) - set(PATTERN_EXAMPLES))
    assert missing == [], f"add an accepted example to PATTERN_EXAMPLES for {missing}"


@pytest.mark.parametrize(
    "where",
    [pytest.param(w) if ".hmi." in w else w for w in sorted(PATTERN_EXAMPLES)],
)
def test_each_msgspec_pattern_holds_for_the_whole_text(where: str) -> None:
    """As msgspec applies it: `re.search` on the value (so `^...$` alone is not whole)."""
    pattern = all_patterns()[where]
    kind = Annotated[str, msgspec.Meta(pattern=pattern)]

    def accepts(value: str) -> bool:
        try:
            msgspec.convert(value, kind)
        except msgspec.ValidationError:
            return False
        return True

    valid = PATTERN_EXAMPLES[where]
    assert accepts(valid), f"{where}: {valid!r} refused by {pattern!r}"
    admitted = [v for v in hostile_variants(valid) if accepts(v)]
    assert admitted == [], f"{where} ({pattern!r}) admitted {admitted}"


NODE_CHECK = """
const cases = JSON.parse(require("fs").readFileSync(0, "utf8"));
const out = cases.map(([pattern, valid, hostile]) => {
  const re = new RegExp(pattern, "u");  // as JSON Schema validators compile `pattern`
  return [re.test(valid), hostile.filter((s) => re.test(s))];
});
process.stdout.write(JSON.stringify(out));
"""


@pytest.mark.skipif(shutil.which("node") is None, reason="needs Node.js for an ECMA-262 engine")
def test_each_msgspec_pattern_is_the_same_rule_in_json_schema() -> None:
    """JSON Schema `pattern`s are ECMA-262 regexes, searched like msgspec's: a pattern that
    ended in `\\Z` would compile there as a literal `Z` (or not at one with `u`)."""
    patterns = all_patterns()
    cases = [(patterns[w], v, hostile_variants(v)) for w, v in sorted(PATTERN_EXAMPLES.items())]
    run = subprocess.run(["node", "-e", NODE_CHECK], input=json.dumps(cases), capture_output=True,
                         text=True, timeout=30, check=True)  # fmt: skip
    for (where, _), (valid_ok, admitted) in zip(
        sorted(PATTERN_EXAMPLES.items()), json.loads(run.stdout), strict=True
    ):
        assert valid_ok, f"{where}: the example is refused in ECMA-262"
        assert admitted == [], f"{where}: ECMA-262 admits {admitted}"


# ------------------------------------------------------------------ live: a real join


def _forged_key(area_path: str) -> str:
    return f"carlaverse/t/{area_path}"  # built by hand: `Keys` refuses the id


def test_a_node_id_with_a_newline_is_refused_by_the_authority_and_unseen_by_observers(
    cluster: Cluster,
) -> None:
    cluster.router()
    authority = cluster.in_process_authority().start()
    observer = cluster.observer("watch")
    assert observer.wait_joined(10)
    outsider = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(outsider)
    bad = "gx\n"
    request = m.JoinRequest(m.SCHEMA_VERSION, bad, "i-gx", "drive", actor_kind="car")
    join_key, payload = Keys("t").authority("join"), m.JOIN_REQUEST.encode(request)
    # asked until answered: a fresh session learns of the queryable a moment after it is up
    replies = wait_until(lambda: list(outsider.get(join_key, payload=payload)), 10, "a reply")
    reply = m.JOIN_REPLY.decode(replies[0].ok.payload.to_bytes())
    assert not reply.accepted and "invalid node id" in reply.reason, reply
    token = outsider.liveliness().declare_token(_forged_key(f"node/{bad}"))
    pose = m.encode_pose(m.Pose(1, 0.0, 5.0, 5.0))

    def forged_were_dropped() -> bool:
        outsider.put(_forged_key(f"ego/{bad}/pose/t0_0"), pose)
        observer.update()
        dropped = observer.counters().dropped
        return bad in observer.world.egos or (dropped.get("pose") and dropped.get("presence"))

    try:
        wait_until(forged_were_dropped, 10, "the forged pose and token at the observer", poll=0.1)
        observer.update()
        assert bad not in observer.world.egos and bad not in observer.world.present
        assert bad not in authority.roster.tracks and bad not in authority.roster.tokens
    finally:
        token.undeclare()


def test_a_node_client_refuses_such_an_id_before_it_touches_the_session() -> None:
    settings = NodeSettings(node_id="f-a\n", session="t")
    with pytest.raises(KeySpaceError, match="invalid node id"):
        NodeClient(None, settings, MonotonicClock())  # type: ignore[arg-type]  # never reached
