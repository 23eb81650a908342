"""Access control with real routers, real certificates and real Zenoh sessions (issue 7).

Two sites: `a` hosts the authority, the victim drive node `a-drive`, a same-site attacker
`a-walk` and an observer; `b` hosts the cross-site attacker `b-bike` and an observer. Every
node is a client of its site router, which enforces the roster's rules.

A denied message leaves no trace, so each negative check is ordered behind a positive one:
the attacker sends its forgeries, then a legitimate message on the same session and link;
Zenoh keeps one publisher session's messages of one priority in order, so once the
legitimate one has arrived, any forgery that was let through would have arrived first.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from carlaverse.keys import Keys
from tests.security.lab import SESSION, Inbox, Lab
from tests.support import wait_until

K = Keys(SESSION)
NODES = [
    ("authority", "authority", "a"),
    ("a-drive", "drive", "a"),
    ("a-walk", "walk", "a"),
    ("a-obs", "observer", "a"),
    ("b-bike", "bike", "b"),
    ("b-obs", "observer", "b"),
]


class Site:
    def __init__(self, lab: Lab) -> None:
        lab.write()
        self.routers = [lab.router("a"), lab.router("b")]
        self.s = {node_id: lab.node(node_id, site) for node_id, _, site in NODES}
        listening = ("a-obs", "b-obs", "a-drive", "a-walk", "b-bike", "authority")
        self.inbox = {name: Inbox() for name in listening}
        for name, inbox in self.inbox.items():
            self.s[name].declare_subscriber(K.everything, inbox)
            # `**` does not reach the verbatim digest key: named on its own, as nodes do
            self.s[name].declare_subscriber(K.pose_digest, inbox)
        auth = self.s["authority"]
        auth.declare_queryable(K.authority("clock"), lambda q: q.reply(q.key_expr, b"tick"))
        auth.declare_queryable(K.authority("join"), lambda q: q.reply(q.key_expr, b"real"))
        self.wait_connected()

    def wait_connected(self) -> None:
        """Both observers see the victim and the cross-site attacker before any test runs."""

        def flowing() -> bool:
            self.s["a-drive"].put(K.pose("a-drive", "t0_0"), b"hello-a")
            self.s["b-bike"].put(K.pose("b-bike", "t0_0"), b"hello-b")
            return all(
                self.inbox[o].has(lambda k, p: p == b"hello-a")
                and self.inbox[o].has(lambda k, p: p == b"hello-b")
                for o in ("a-obs", "b-obs")
            )

        wait_until(flowing, 15, "poses to flow across both routers", poll=0.1)

    def marker(self, node: str, text: str) -> bytes:
        """Send a legitimate pose from `node` and wait until both observers have it."""
        payload = f"marker-{text}".encode()
        self.s[node].put(K.pose(node, "t0_0"), payload)
        for observer in ("a-obs", "b-obs"):
            inbox = self.inbox[observer]
            wait_until(lambda i=inbox: payload in i.payloads(), 10, f"{text} at {observer}")
        return payload

    def flush_to_authority(self, node: str) -> None:
        """A query round trip from `node` to the authority, behind anything it sent before."""
        replies = list(self.s[node].get(K.authority("clock"), timeout=5))
        assert [r.ok.payload.to_bytes() for r in replies if r.ok] == [b"tick"]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    lab = Lab(Path(tmp_path_factory.mktemp("acl")), NODES)
    try:
        yield Site(lab)
    finally:
        lab.close()


@pytest.mark.parametrize("attacker", ["b-bike", "a-walk"])
def test_forged_pose_is_dropped_by_the_attackers_router(site: Site, attacker: str) -> None:
    victim_key = K.pose("a-drive", "t0_0")
    for i in range(5):
        site.s[attacker].put(victim_key, f"forged-{i}".encode())
        site.s[attacker].put(K.subtree("ego", "a-drive").replace("**", "state"), b"forged")
    site.s["a-drive"].put(victim_key, b"legit")
    site.marker(attacker, f"after-forgery-{attacker}")
    wait_until(lambda: b"legit" in site.inbox["b-obs"].payloads(victim_key), 10, "victim pose")
    for name in ("a-obs", "b-obs", "authority"):
        victim_stream = site.inbox[name].payloads(victim_key)
        assert not [p for p in victim_stream if p.startswith(b"forged")], name
        assert b"legit" in victim_stream or name == "authority"


@pytest.mark.parametrize("attacker", ["b-bike", "a-walk"])
def test_a_node_cannot_write_world_impulse_or_audio(site: Site, attacker: str) -> None:
    forged = [
        K.world("npc"), K.world("events"), K.pose_digest, K.impulse("a-drive"), K.audio("a-drive")
    ]  # fmt: skip
    for key in forged:
        site.s[attacker].put(key, b"forged-world")
    site.marker(attacker, f"after-world-{attacker}")
    for name in ("a-obs", "b-obs", "a-drive"):
        assert not site.inbox[name].has(lambda k, p: p == b"forged-world"), name


def test_the_authority_can_write_world_and_impulses(site: Site) -> None:
    auth = site.s["authority"]
    auth.put(K.world("npc"), b"npc-batch")
    auth.put(K.impulse("a-drive"), b"impulse")
    auth.put(K.audio("a-drive"), b"audio")
    auth.put(K.pose_digest, b"digest")
    for name in ("a-obs", "b-obs", "a-drive"):
        inbox = site.inbox[name]
        wait_until(lambda i=inbox: b"npc-batch" in i.payloads(K.world("npc")), 10, name)
    for name in ("a-obs", "b-obs", "a-drive", "b-bike"):  # participants too, on both sites
        inbox = site.inbox[name]
        wait_until(lambda i=inbox: b"digest" in i.payloads(K.pose_digest), 10, f"digest {name}")
    wait_until(lambda: b"impulse" in site.inbox["a-drive"].payloads(), 10, "impulse")
    wait_until(lambda: b"audio" in site.inbox["b-obs"].payloads(), 10, "audio at b")


def test_a_participant_receives_only_its_own_audio(site: Site) -> None:
    """Each participant's round sends the others' scenes first, then its own: once its own
    has arrived (same publisher session, same priority, in order), a leaked one would have."""
    auth, participants = site.s["authority"], ("a-drive", "a-walk", "b-bike")

    def scenes(node: str) -> set[str]:
        """Audio keys `node` received from the authority (not its own local forgeries)."""
        return {k for k, p in site.inbox[node].items if p.startswith(b"scene-")}

    for me in participants:
        for other in participants:
            if other != me:
                auth.put(K.audio(other), f"scene-{other}-round-{me}".encode())
        auth.put(K.audio(me), f"scene-{me}-round-{me}".encode())
        wait_until(lambda me=me: K.audio(me) in scenes(me), 10, f"own scene at {me}")
    for me in participants:
        assert scenes(me) == {K.audio(me)}, me
    every = {K.audio(n) for n in participants}
    for observer in ("a-obs", "b-obs"):  # read-only kinds see every scene (recordings)
        wait_until(lambda o=observer: every <= scenes(o), 10, f"all scenes at {observer}")


@pytest.mark.parametrize("spy", ["a-walk", "b-bike"])
def test_naming_another_nodes_audio_key_exactly_gets_a_participant_nothing(
    site: Site, spy: str
) -> None:
    """`audio/<id>` is private to `<id>` (docs/protocol.md, Key space) whether a participant
    subscribes to `**` or to the other node's exact key, and for deletes as for puts.

    The spy declares the exact subscription first and its own second, on one link, so once
    its own scene has arrived through the second, its router knew the first: a leaked put
    or delete (sent before the own scene, same publisher, same priority) would have come."""
    auth, session = site.s["authority"], site.s[spy]
    leaked, own = Inbox(), Inbox()
    subscriptions = [
        session.declare_subscriber(K.audio("a-drive"), leaked),
        session.declare_subscriber(K.audio(spy), own),
    ]
    try:
        own_scene = f"own-after-exact-{spy}".encode()

        def exchange() -> bool:
            auth.put(K.audio("a-drive"), f"exact-for-a-drive-{spy}".encode())
            auth.delete(K.audio("a-drive"))
            auth.put(K.audio(spy), own_scene)
            return own_scene in own.payloads()

        wait_until(exchange, 10, f"{spy}'s own scene through its exact subscription", poll=0.2)
        assert leaked.items == [], leaked.items
        wait_until(
            lambda: f"exact-for-a-drive-{spy}".encode() in site.inbox["a-drive"].payloads(),
            10, "the scene at its owner",
        )  # fmt: skip
    finally:
        for subscription in subscriptions:
            subscription.undeclare()


def test_a_node_cannot_serve_authority_queries(site: Site) -> None:
    spoof = site.s["b-bike"].declare_queryable(
        K.authority("join"), lambda q: q.reply(q.key_expr, b"spoofed")
    )
    try:
        site.marker("b-bike", "after-queryable")
        replies = site.s["a-drive"].get(
            K.authority("join"), target=zenoh.QueryTarget.ALL, timeout=3
        )
        answers = sorted(r.ok.payload.to_bytes() for r in replies if r.ok)
        assert answers == [b"real"]
    finally:
        spoof.undeclare()


def test_observers_only_read(site: Site) -> None:
    obs = site.s["b-obs"]
    obs.put(K.pose("b-obs", "t0_0"), b"observer-pose")
    obs.put(K.world("npc"), b"observer-world")
    obs.put(K.pose_digest, b"observer-digest")
    site.flush_to_authority("b-obs")
    assert not site.inbox["authority"].has(lambda k, p: p.startswith(b"observer-"))


def test_a_node_cannot_fake_another_nodes_presence(site: Site) -> None:
    seen: list[str] = []
    watcher = (
        site.s["authority"]
        .liveliness()
        .declare_subscriber(K.all_nodes, lambda s: seen.append(str(s.key_expr)), history=True)
    )
    fake = site.s["b-bike"].liveliness().declare_token(K.node("a-drive"))
    own = site.s["b-bike"].liveliness().declare_token(K.node("b-bike"))
    try:
        wait_until(lambda: K.node("b-bike") in seen, 10, "the attacker's own token")
        site.flush_to_authority("b-bike")
        assert K.node("a-drive") not in seen
    finally:
        fake.undeclare()
        own.undeclare()
        watcher.undeclare()
