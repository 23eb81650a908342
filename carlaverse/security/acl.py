"""Zenoh `access_control` for one site router, generated from the session roster
(docs/architecture.md §12).

Default deny. A router only sees its next hop, so each site's router enforces the rules for
its own nodes, and treats the routers of other sites as one identity each that may carry
only what nodes of *other* sites may write (defence in depth: a compromised remote router
still cannot speak for this site's nodes, nor for the authority unless it is behind it).

What each role may do (`S` = `carlaverse/<session>`), as verified against zenoh 1.10:

| role             | ingress (what it may send)                                   |
|------------------|--------------------------------------------------------------|
| every node       | its own liveliness token `S/node/<id>`; subscriptions,        |
|                  | liveliness subscriptions and queries on `S/**`;               |
|                  | queries to `S/authority/**`                                   |
| ego node         | + put/delete on `S/ego/<id>/**`; put on `S/study/<id>/answers`|
| authority        | + put/delete on `S/world/**`, `S/world/@egos`, `S/impulse/**`,|
|                  | `S/audio/**`; queryables on and replies from `S/authority/**` |
| study runner     | + put on `S/study/**` (questionnaires, trial briefs)          |
| observer/recorder| nothing more: read only                                      |
| other sites      | the union of the above for the nodes not at this site        |

Egress (what the router may deliver): to a node, puts on `S/**` — but to a participant (not
an observer/recorder) `S/audio/**` and `S/study/**` only as its own `S/audio/<id>` and
`S/study/<id>/**` (what it hears, and its questionnaires and answers, are its own) — replies from
`S/authority/**`, liveliness tokens and the declarations a peer-mode node needs for
write-side filtering; queries only to the authority. To another site's router, every message
on `S/**`: it applies its own rules to its own nodes. Nothing outside `S/**` passes.

`S/**` does not cover `S/world/@egos` (the pose digest): an `@` chunk is verbatim in Zenoh, no
wildcard matches it. So every rule that means "the whole session" names both
(`Keys.every_key`), and only the authority may put the digest.
A `liveliness_query` is answered with `liveliness_token` messages, hence the token egress.

Subjects: a node is matched by everything the session uses (its certificate's common name
and/or its username, AND-ed). Another site's router is matched by its certificate *or* its
login, because of how zenoh 1.10 authenticates links: the dialer of a TLS link always sees
the listener's certificate, the listener sees the dialer's certificate only with mutual TLS,
and a login is only ever presented by the dialer.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from carlaverse.keys import KEY_AREAS, Keys
from carlaverse.security.roster import (
    AUTHORITY_KIND,
    READ_ONLY_KINDS,
    STUDY_RUNNER_KIND,
    Identity,
    LoadedRoster,
    RosterNode,
)

ALL_MESSAGES = (
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "declare_queryable",
    "reply",
    "liveliness_token",
    "declare_liveliness_subscriber",
    "liveliness_query",
)
AUTHORITY_AREAS = ("world", "impulse", "audio")
PRIVATE_AREAS = ("audio", "study")  # per node: a participant receives only its own
READ_MESSAGES = ("declare_subscriber", "declare_liveliness_subscriber", "liveliness_query")
DECLARATIONS = ("declare_subscriber", "declare_queryable", "declare_liveliness_subscriber")


@dataclass(frozen=True, slots=True)
class Grant:
    """An allow rule before it is named after its subject."""

    tag: str
    messages: tuple[str, ...]
    key_exprs: tuple[str, ...]
    flow: str  # ingress | egress

    def rule(self, subject_id: str) -> dict[str, Any]:
        return {
            "id": f"{subject_id}/{self.tag}",
            "permission": "allow",
            "flows": [self.flow],
            "messages": list(self.messages),
            "key_exprs": list(self.key_exprs),
        }


def node_grants(keys: Keys, node: RosterNode) -> list[Grant]:
    """What one node of this site may send and receive."""
    everything = keys.every_key
    grants = [
        Grant("presence", ("liveliness_token",), (keys.node(node.id),), "ingress"),
        Grant("read", READ_MESSAGES, everything, "ingress"),
        Grant("ask", ("query",), (keys.subtree("authority"),), "ingress"),
        Grant("receive", ("put", "delete"), receivable(keys, node), "egress"),
        Grant("answers", ("reply",), (keys.subtree("authority"),), "egress"),
        Grant("presence-of-others", ("liveliness_token",), (keys.subtree("node"),), "egress"),
        Grant("declarations", DECLARATIONS, everything, "egress"),
    ]
    if node.kind == AUTHORITY_KIND:
        grants += authority_grants(keys)
    elif node.kind == STUDY_RUNNER_KIND:
        grants.append(Grant("study", ("put",), (keys.subtree("study"),), "ingress"))
    elif node.kind not in READ_ONLY_KINDS:
        grants += participant_grants(keys, node.id)
    return grants


def participant_grants(keys: Keys, node_id: str) -> list[Grant]:
    """A participant writes its own ego channels and its own questionnaire answers."""
    return [
        Grant("ego", ("put", "delete"), (keys.subtree("ego", node_id),), "ingress"),
        Grant("study", ("put",), (keys.study(node_id, "answers"),), "ingress"),
    ]


def receivable(keys: Keys, node: RosterNode) -> tuple[str, ...]:
    """What the router may deliver to a node: all of the session, except that a participant
    gets only its own `audio/<id>` (what it can hear is private to it) and `study/<id>/**`
    (its questionnaires and answers); read-only kinds (observers, recorders) keep all of it,
    so a recording can be rendered for any listener, and so does the study runner."""
    if node.kind in READ_ONLY_KINDS | {AUTHORITY_KIND, STUDY_RUNNER_KIND}:
        return keys.every_key
    areas = tuple(keys.subtree(area) for area in KEY_AREAS if area not in PRIVATE_AREAS)
    return (*areas, keys.pose_digest, keys.audio(node.id), keys.subtree("study", node.id))


def authority_grants(keys: Keys) -> list[Grant]:
    """The authority writes the world and serves the session's queries."""
    world = (*(keys.subtree(area) for area in AUTHORITY_AREAS), keys.pose_digest)
    serve = (keys.subtree("authority"),)
    return [
        Grant("world", ("put", "delete"), world, "ingress"),
        Grant("serve", ("declare_queryable", "reply"), serve, "ingress"),
        Grant("queries", ("query",), serve, "egress"),
    ]


def peer_site_grants(keys: Keys, remote_nodes: list[RosterNode]) -> list[Grant]:
    """What another site's router may carry into this site: only its side's nodes' writes."""
    grants = [
        Grant("read", READ_MESSAGES, keys.every_key, "ingress"),
        Grant("ask", ("query",), (keys.subtree("authority"),), "ingress"),
        Grant("forward", ALL_MESSAGES, keys.every_key, "egress"),
    ]
    if remote_nodes:
        tokens = tuple(keys.node(n.id) for n in remote_nodes)
        grants.append(Grant("presence", ("liveliness_token",), tokens, "ingress"))
    not_writers = READ_ONLY_KINDS | {AUTHORITY_KIND, STUDY_RUNNER_KIND}
    writers = [n for n in remote_nodes if n.kind not in not_writers]
    if writers:
        egos = tuple(keys.subtree("ego", n.id) for n in writers)
        grants.append(Grant("ego", ("put", "delete"), egos, "ingress"))
        answers = tuple(keys.study(n.id, "answers") for n in writers)
        grants.append(Grant("study-answers", ("put",), answers, "ingress"))
    if any(n.kind == STUDY_RUNNER_KIND for n in remote_nodes):
        grants.append(Grant("study", ("put",), (keys.subtree("study"),), "ingress"))
    if any(n.kind == AUTHORITY_KIND for n in remote_nodes):
        grants += [g for g in authority_grants(keys) if g.flow == "ingress"]
    return grants


def subject(subject_id: str, identity: Identity, by: str = "all") -> dict[str, Any]:
    """A Zenoh subject; lists within are OR, across are AND. An empty list would be a wildcard,
    which the roster's validation rules out (every identity has a CN or a username).
    `by`: "all" (every credential must match), "cert" or "login" (that one only)."""
    out: dict[str, Any] = {"id": subject_id}
    if identity.common_name and by in ("all", "cert"):
        out["cert_common_names"] = [identity.common_name]
    if identity.username and by in ("all", "login"):
        out["usernames"] = [identity.username]
    if len(out) == 1:
        raise ValueError(f"identity {identity.name!r} has no credential for subject {by!r}")
    if identity.interfaces:
        out["interfaces"] = list(identity.interfaces)
    return out


def site_subjects(subject_id: str, identity: Identity) -> list[dict[str, Any]]:
    """Another site's router, either way its link was opened. Its certificate names it on a
    link it accepted from us (TLS always shows the server's certificate) and, with mutual TLS,
    on a link it opened to us; its login names it on a link it opened to us."""
    subjects = [subject(f"{subject_id}:cert", identity, "cert")]
    if identity.username:
        subjects.append(subject(f"{subject_id}:login", identity, "login"))
    return subjects


def site_acl(loaded: LoadedRoster, site: str) -> dict[str, Any]:
    """The `access_control` object for the router of `site`."""
    loaded.site(site)  # raises naming the known sites
    keys = Keys(loaded.session)
    entries: list[tuple[str, list[dict[str, Any]], list[Grant]]] = []
    for node in loaded.nodes_at(site):
        subject_id = f"node:{node.id}"
        identity = loaded.node_identity(node.id)
        entries.append((subject_id, [subject(subject_id, identity)], node_grants(keys, node)))
    remote = [n for n in loaded.roster.nodes if n.site != site]
    for other in loaded.roster.sites:
        if other.name != site:
            subject_id = f"site:{other.name}"
            subjects = site_subjects(subject_id, loaded.site_identity(other.name))
            entries.append((subject_id, subjects, peer_site_grants(keys, remote)))
    return _assemble(entries)


def _assemble(entries: list[tuple[str, list[dict[str, Any]], list[Grant]]]) -> dict[str, Any]:
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    for policy_id, own_subjects, grants in entries:
        own_rules = [g.rule(policy_id) for g in grants]
        rules += own_rules
        subjects += own_subjects
        policies.append(
            {
                "id": policy_id,
                "rules": [r["id"] for r in own_rules],
                "subjects": [s["id"] for s in own_subjects],
            }
        )
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }
