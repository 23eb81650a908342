"""A TLS + login session, recorded and replayed: no password leaves the node that holds it.

The login of `join --roster` sits in the node's effective config (`fabric.zenoh`), which
the node sends at join, the authority serves on `authority/configs`, the recorder archives
and `replay` serves again. Every one of those places, and every process's output, is
searched for every password of the session, in every form a recording stores bytes.
"""

from __future__ import annotations

import base64
import re
import secrets
from pathlib import Path

import yaml
import zenoh

from carlaverse import messages
from carlaverse.keys import Keys
from carlaverse.recording.archive import CONFIG_ATTACHMENT
from carlaverse.recording.reading import iter_samples, read_attachments, read_metadata
from carlaverse.redact import REDACTED
from carlaverse.security.zenoh_entries import write_private
from carlaverse.transport.session import FabricSettings, open_session
from tests.security.lab import SESSION, Lab
from tests.support import Cluster, Proc, free_port, wait_until

NODES = [
    ("authority", "authority", "a"),
    ("a-drive", "drive", "a"),
    ("rec", "recorder", "a"),
    ("watch", "observer", "a"),
]


def _write_lab(tmp_path: Path) -> tuple[Lab, list[bytes]]:
    """A mutual-TLS + login roster whose passwords are long random strings."""
    lab = Lab(tmp_path, NODES, mtls=True, usrpwd=True)
    loaded = lab.write()
    passwords = []
    for file in sorted(loaded.secrets_dir.glob("*.password")):
        password = f"pw-{secrets.token_hex(12)}"
        write_private(file, password + "\n")
        passwords.append(password.encode())
    return lab, passwords


def _forms(password: bytes) -> list[bytes]:
    """The password as it is, and as base64 at each of the 3 alignments (JSON `raw` fields)."""
    return [password] + [base64.b64encode(b"x" * k + password)[4:-4] for k in range(3)]


def _leaks(data: bytes, passwords: list[bytes]) -> list[bytes]:
    return [p for p in passwords if any(form in data for form in _forms(p))]


def _configs_reply(session: zenoh.Session, key: str) -> tuple[bytes, messages.ConfigsReply]:
    for reply in session.get(key, timeout=2):
        if reply.ok is not None:
            payload = reply.ok.payload.to_bytes()
            return payload, messages.CONFIGS.decode(payload)
    raise AssertionError(f"no answer on {key}")


def _has_config(session: zenoh.Session, key: str, node_id: str) -> bytes | None:
    try:
        payload, reply = _configs_reply(session, key)
    except AssertionError:
        return None
    return payload if node_id in reply.nodes else None


def _attachments(proc: Proc) -> int:
    counts = re.findall(r"(\d+) attachments", proc.output())
    return int(counts[-1]) if counts else 0


def _start_session(cluster: Cluster, lab: Lab, mcap: Path) -> list[Proc]:
    roster, endpoint = str(lab.roster_path), lab.endpoint("a")
    router = cluster.start("router", "--site", "a", "--config", roster, name="router")
    wait_until(lambda: "listening" in router.output() or not router.alive(), 20, "the router")
    common = ["--session", SESSION, "--roster", roster, "--connect", endpoint]
    recorder = cluster.start(
        "record", *common, "--id", "rec", "-o", str(mcap), "--compression", "none",
        "--progress-s", "0.5", name="recorder",
    )  # fmt: skip
    authority = cluster.start(
        "authority", "--scenario", "none", *common, "--duration", "40", name="authority"
    )
    drive = cluster.start("join", "scripted", "--id", "a-drive", *common, "--duration", "30")
    return [router, recorder, authority, drive]


def test_the_login_is_in_no_reply_recording_replay_or_output(
    cluster: Cluster, tmp_path: Path
) -> None:
    lab, passwords = _write_lab(tmp_path)
    mcap = tmp_path / "secure.mcap"
    procs = _start_session(cluster, lab, mcap)
    recorder = procs[1]
    watch = lab.node("watch", "a")
    configs_key = Keys(SESSION).authority("configs")
    payload = wait_until(lambda: _has_config(watch, configs_key, "a-drive"), 40, "a-drive joined")
    config = yaml.safe_load(messages.CONFIGS.decode(payload).nodes["a-drive"])
    assert config["fabric"]["zenoh"]["transport/auth/usrpwd/password"] == REDACTED
    assert not _leaks(payload, passwords), "authority/configs serves a password"
    wait_until(lambda: _attachments(recorder) >= 1, 20, "the recorder archiving a-drive's config")
    assert recorder.stop() == 0, recorder.output()
    lab.close()

    _assert_recording_clean(mcap, passwords)
    replay = _assert_replay_clean(cluster, mcap, passwords)
    for proc in [*procs, replay]:
        proc.stop()
        leaked = _leaks(proc.output().encode(), passwords)
        assert not leaked, f"{proc.name} printed a password"


def _assert_recording_clean(mcap: Path, passwords: list[bytes]) -> None:
    assert not _leaks(mcap.read_bytes(), passwords), "password bytes in the MCAP file"
    samples = list(iter_samples(mcap))
    assert any(s.key.endswith("authority/configs") for s in samples)
    for sample in samples:
        assert not _leaks(sample.payload, passwords), f"password in a sample on {sample.key}"
    attachments = read_attachments(mcap)
    archived = yaml.safe_load(attachments[CONFIG_ATTACHMENT.format(node_id="a-drive")])
    assert archived["fabric"]["zenoh"]["transport/auth/usrpwd/password"] == REDACTED
    for name, data in attachments.items():
        assert not _leaks(data, passwords), f"password in attachment {name}"
    assert not _leaks(repr(read_metadata(mcap)).encode(), passwords), "password in metadata"


def _assert_replay_clean(cluster: Cluster, mcap: Path, passwords: list[bytes]) -> Proc:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    replay = cluster.start(
        "replay", str(mcap), "--speed", "20", "--loop", "--listen", endpoint, name="replay"
    )
    session = open_session(FabricSettings(connect=[endpoint]))
    try:
        key = Keys(f"{SESSION}-replay").authority("configs")  # the default target session
        served = wait_until(lambda: _has_config(session, key, "a-drive"), 30, "replayed configs")
    finally:
        session.close()
    assert not _leaks(served, passwords), "replay serves a password"
    return replay
