"""`carlaverse certs`, `carlaverse roster` and `carlaverse router --site`, run in-process."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest
import yaml

from carlaverse.cli import main
from carlaverse.security.certs import common_name
from tests.support import free_port

ROSTER = {
    "session": "eu",
    "security": {"mtls": True, "usrpwd": True},
    "sites": [
        {"name": "tum", "listen": ["tls/127.0.0.1:PORT"], "hostnames": ["tum.example.org"]},
        {"name": "kth", "connect": ["tls/tum.example.org:7447"]},
    ],
    "nodes": [
        {"id": "authority", "kind": "authority", "site": "tum"},
        {"id": "kth-bike-1", "kind": "bike", "site": "kth"},
    ],
}


@pytest.fixture
def roster(tmp_path: Path) -> Path:
    path = tmp_path / "session.yaml"
    text = yaml.safe_dump(ROSTER).replace("PORT", str(free_port()))
    path.write_text(text, encoding="utf-8")
    return path


def test_certs_for_a_whole_roster_then_kept(roster: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["certs", "--roster", str(roster)]) == 0
    certs = roster.parent / "certs"
    for name in ("tum", "kth", "authority", "kth-bike-1"):
        assert common_name(certs / f"{name}.pem") == name
    assert "tum.example.org" in capsys.readouterr().out
    before = (certs / "tum.pem").read_bytes()
    assert main(["certs", "--roster", str(roster), "--site", "tum"]) == 0
    assert (certs / "tum.pem").read_bytes() == before  # kept unless --force
    assert main(["certs", "--roster", str(roster), "--site", "tum", "--force"]) == 0
    assert (certs / "tum.pem").read_bytes() != before


def test_certs_by_name_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["certs", "--out", str(tmp_path), "--name", "lab-x", "--san-ip", "10.1.2.3"]) == 0
    assert "10.1.2.3" in capsys.readouterr().out
    assert main(["certs", "--name", "x"]) == 2  # no --out, no --roster
    assert main(["certs", "--out", str(tmp_path), "--name", "a/b"]) == 2
    assert "invalid certificate common name" in capsys.readouterr().err


def test_roster_check_acl_and_passwords(roster: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["roster", "check", str(roster)]) == 0
    assert "kth-bike-1 (bike)" in capsys.readouterr().out
    out = roster.parent / "tum-acl.json"
    assert main(["roster", "acl", str(roster), "--site", "tum", "--out", str(out)]) == 0
    acl = json.loads(out.read_text())["access_control"]
    assert acl["default_permission"] == "deny"
    assert main(["roster", "passwords", str(roster)]) == 0
    secret = roster.parent / "secrets" / "kth-bike-1.password"
    assert stat.S_IMODE(secret.stat().st_mode) == 0o600 and len(secret.read_text()) > 20
    assert main(["roster", "acl", str(roster), "--site", "mit"]) == 2
    assert "no site 'mit'" in capsys.readouterr().err


def test_router_runs_a_site_from_the_roster(roster: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["router", "--site", "tum", "--config", str(roster)]) == 2
    assert "no session CA certificate" in capsys.readouterr().err
    assert main(["certs", "--roster", str(roster)]) == 0
    assert main(["router", "--site", "tum", "--config", str(roster)]) == 2
    assert "carlaverse roster passwords" in capsys.readouterr().err
    assert main(["roster", "passwords", str(roster)]) == 0
    assert main(["router", "--site", "tum", "--config", str(roster), "--duration", "0.2"]) == 0
    dictionary = roster.parent / "secrets" / "tum.dictionary"
    users = {line.split(":")[0] for line in dictionary.read_text().splitlines()}
    assert users == {"authority", "kth"}  # its own nodes and the routers that dial it


def test_zenoh_config_for_zenohd_users(roster: Path, capsys: pytest.CaptureFixture) -> None:
    main(["certs", "--roster", str(roster)])
    main(["roster", "passwords", str(roster)])
    capsys.readouterr()
    args = ["roster", "zenoh-config", str(roster), "--node", "kth-bike-1", "--connect", "tls/h:1"]
    assert main(args) == 0
    config = json.loads(capsys.readouterr().out)
    assert config["mode"] == "client" and config["connect"]["endpoints"] == ["tls/h:1"]
    assert config["transport"]["link"]["tls"]["enable_mtls"] is True
    assert config["transport"]["auth"]["usrpwd"]["user"] == "kth-bike-1"


# ------------------------------------------------------------- files that hold secrets


def _mode(path: Path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def _world_readable(path: Path, text: str = "old\n") -> Path:
    """A file left 0644 by an older version: rewriting it must not keep that mode."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    path.chmod(0o644)
    return path


def test_zenoh_config_with_a_login_is_written_0600(
    roster: Path, capsys: pytest.CaptureFixture
) -> None:
    assert main(["certs", "--roster", str(roster)]) == 0
    assert main(["roster", "passwords", str(roster)]) == 0
    for who in (["--site", "tum"], ["--node", "kth-bike-1", "--connect", "tls/h:1"]):
        out = _world_readable(roster.parent / "out" / f"{who[1]}.json")
        assert main(["roster", "zenoh-config", str(roster), *who, "--out", str(out)]) == 0
        assert "password" in json.loads(out.read_text())["transport"]["auth"]["usrpwd"]
        assert _mode(out) == 0o600, who
    assert "readable by you only" in capsys.readouterr().err


def test_passwords_dictionaries_and_keys_are_0600(roster: Path) -> None:
    secrets_dir = roster.parent / "secrets"
    assert main(["roster", "passwords", str(roster)]) == 0
    assert _mode(secrets_dir) == 0o700
    assert all(_mode(p) == 0o600 for p in secrets_dir.glob("*.password"))
    kept = _world_readable(secrets_dir / "authority.password", "an-older-password-file\n")
    assert main(["roster", "passwords", str(roster)]) == 0
    assert _mode(kept) == 0o600 and kept.read_text() == "an-older-password-file\n"

    certs = roster.parent / "certs"
    _world_readable(certs / "kth-bike-1.key")
    _world_readable(secrets_dir / "tum.dictionary")
    assert main(["certs", "--roster", str(roster), "--name", "kth-bike-1"]) == 0
    assert main(["router", "--site", "tum", "--config", str(roster), "--duration", "0.2"]) == 0
    assert _mode(secrets_dir / "tum.dictionary") == 0o600
    keys = list(certs.glob("*.key"))
    assert len(keys) >= 3 and all(_mode(k) == 0o600 for k in keys), keys
