"""The session roster: defaults, validation errors that name the problem, generated ACLs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from carlaverse.config import ConfigError
from carlaverse.keys import Keys
from carlaverse.security.acl import site_acl
from carlaverse.security.roster import RosterError, load_roster

BASE: dict[str, Any] = {
    "session": "eu",
    "sites": [{"name": "tum"}, {"name": "kth", "connect": ["tls/tum.example.org:7447"]}],
    "nodes": [
        {"id": "authority", "kind": "authority", "site": "tum"},
        {"id": "tum-drive-1", "kind": "drive", "site": "tum"},
        {"id": "kth-bike-1", "kind": "bike", "site": "kth", "credential": {"common_name": "bk"}},
        {"id": "kth-rec", "kind": "recorder", "site": "kth"},
    ],
}
K = Keys("eu")


def _write(tmp: Path, data: dict[str, Any]) -> Path:
    path = tmp / "session.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def _with(**changes: Any) -> dict[str, Any]:
    return {**BASE, **changes}


def test_defaults_identify_by_certificate_named_after_the_id(tmp_path: Path) -> None:
    loaded = load_roster(_write(tmp_path, BASE))
    assert loaded.node_identity("tum-drive-1").common_name == "tum-drive-1"
    assert loaded.node_identity("kth-bike-1").common_name == "bk"
    assert loaded.node_identity("tum-drive-1").username is None
    assert loaded.site("tum").listen == ["tls/0.0.0.0:7447"]
    assert loaded.certs_dir == tmp_path / "certs"


def test_usrpwd_defaults_to_the_id_and_a_password_file(tmp_path: Path) -> None:
    loaded = load_roster(_write(tmp_path, _with(security={"mtls": False, "usrpwd": True})))
    identity = loaded.node_identity("tum-drive-1")
    assert identity.common_name is None and identity.username == "tum-drive-1"
    assert identity.password_file == tmp_path / "secrets" / "tum-drive-1.password"
    # routers keep their certificate name: TLS shows it to whoever dials them
    assert loaded.site_identity("tum").common_name == "tum"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"nodes": [*BASE["nodes"], {"id": "x", "kind": "walk", "site": "mit"}]}, "unknown site"),
        ({"nodes": [*BASE["nodes"], {"id": "tum", "kind": "walk", "site": "tum"}]}, "duplicate"),
        ({"nodes": BASE["nodes"][1:]}, "exactly one node of kind 'authority'"),
        ({"nodes": [{"id": "boss", "kind": "authority", "site": "tum"}]}, "must be 'authority'"),
        ({"security": {"mtls": False}}, "neither mtls nor usrpwd"),
        ({"session": "a/b"}, "invalid session name"),
        (
            {
                "nodes": [
                    *BASE["nodes"],
                    {"id": "x", "kind": "walk", "site": "tum", "credential": {"common_name": "bk"}},
                ]
            },
            "duplicate common name 'bk'",
        ),
    ],
)
def test_inconsistent_rosters_are_refused_naming_the_problem(
    tmp_path: Path, change: dict[str, Any], message: str
) -> None:
    with pytest.raises(RosterError, match=message) as info:
        load_roster(_write(tmp_path, _with(**change)))
    assert "session.yaml" in str(info.value)


def test_typos_are_schema_errors_with_the_field_path(tmp_path: Path) -> None:
    data = _with(sites=[{"name": "tum", "lisen": []}])
    with pytest.raises(ConfigError, match=r"lisen"):
        load_roster(_write(tmp_path, data))


def _rules_of(acl: dict[str, Any], policy_id: str) -> list[dict[str, Any]]:
    policy = next(p for p in acl["policies"] if p["id"] == policy_id)
    return [r for r in acl["rules"] if r["id"] in policy["rules"]]


def _writes(acl: dict[str, Any], policy_id: str) -> set[str]:
    return {
        key
        for r in _rules_of(acl, policy_id)
        if "ingress" in r["flows"] and {"put", "delete"} & set(r["messages"])
        for key in r["key_exprs"]
    }


def test_site_acl_default_denies_and_scopes_writes(tmp_path: Path) -> None:
    loaded = load_roster(_write(tmp_path, BASE))
    tum, kth = site_acl(loaded, "tum"), site_acl(loaded, "kth")
    assert tum["enabled"] and tum["default_permission"] == "deny"
    drive = {K.subtree("ego", "tum-drive-1"), K.study("tum-drive-1", "answers")}
    bike = {K.subtree("ego", "kth-bike-1"), K.study("kth-bike-1", "answers")}
    assert _writes(tum, "node:tum-drive-1") == drive
    world = {K.subtree(a) for a in ("world", "impulse", "audio")} | {K.pose_digest}
    assert _writes(tum, "node:authority") == world
    assert _writes(kth, "node:kth-rec") == set()  # recorders read only
    # the other site's router may carry only what the nodes behind it may write
    assert _writes(tum, "site:kth") == bike
    assert _writes(kth, "site:tum") == drive | world
    # each router rules its own nodes only
    assert not any(p["id"] == "node:kth-bike-1" for p in tum["policies"])


def _receives(acl: dict[str, Any], policy_id: str) -> set[str]:
    return {
        key
        for r in _rules_of(acl, policy_id)
        if "egress" in r["flows"] and "put" in r["messages"]
        for key in r["key_exprs"]
    }


def test_questionnaires_the_runner_asks_and_each_participant_answers_its_own(
    tmp_path: Path,
) -> None:
    runner = {"id": "runner", "kind": "study-runner", "site": "kth"}
    loaded = load_roster(_write(tmp_path, _with(nodes=[*BASE["nodes"], runner])))
    tum, kth = site_acl(loaded, "tum"), site_acl(loaded, "kth")
    assert _writes(kth, "node:runner") == {K.subtree("study")}  # asks anyone, no pose
    assert K.subtree("study") in _writes(tum, "site:kth")  # its router may carry that
    assert _receives(kth, "node:runner") == set(K.every_key)  # it hears every answer
    # A participant hears its own questionnaires and answers, not another's (personal data).
    heard = _receives(tum, "node:tum-drive-1")
    assert K.subtree("study", "tum-drive-1") in heard and K.subtree("study") not in heard
    assert not any(k.startswith(f"{K.prefix}/study/kth-bike-1") for k in heard)
    assert K.subtree("ego") in heard  # the rest of the session as before


def test_subjects_are_never_wildcards(tmp_path: Path) -> None:
    loaded = load_roster(_write(tmp_path, _with(security={"mtls": True, "usrpwd": True})))
    for site in ("tum", "kth"):
        for subject in site_acl(loaded, site)["subjects"]:
            assert subject.get("cert_common_names") or subject.get("usernames"), subject
    node = next(s for s in site_acl(loaded, "kth")["subjects"] if s["id"] == "node:kth-bike-1")
    assert node == {
        "id": "node:kth-bike-1",
        "cert_common_names": ["bk"],
        "usernames": ["kth-bike-1"],
    }


def test_unknown_site_is_named(tmp_path: Path) -> None:
    loaded = load_roster(_write(tmp_path, BASE))
    with pytest.raises(RosterError, match=r"no site 'mit'.*tum, kth"):
        site_acl(loaded, "mit")


def test_interfaces_narrow_a_subject(tmp_path: Path) -> None:
    nodes = [*BASE["nodes"], {"id": "kth-sim", "kind": "drive", "site": "kth",
                              "credential": {"interfaces": ["eth1"]}}]  # fmt: skip
    loaded = load_roster(_write(tmp_path, _with(nodes=nodes)))
    subject = next(s for s in site_acl(loaded, "kth")["subjects"] if s["id"] == "node:kth-sim")
    assert subject == {
        "id": "node:kth-sim",
        "cert_common_names": ["kth-sim"],
        "interfaces": ["eth1"],
    }
