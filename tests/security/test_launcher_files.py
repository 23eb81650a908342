"""The launcher's files stay in its config dir (issue 39): the confinement module driven
directly, with real files, folders, symlinks and FIFOs; and the editor, the lab and the
hardware checks that use it.

What is refused and why, stated independently of the code: the page may name any string, so a
name outside the config dir, or one that passes a symlink anywhere below it, must be refused
before anything is read (a FIFO outside proves "nothing read": opening it for reading is what
lets its writer go on), no folder may be created outside, and no refusal may carry a byte of
the refused file.
"""

from __future__ import annotations

import os
import socket
import sys
import threading
from pathlib import Path

import pytest

from carlaverse.config import ConfigError
from carlaverse.hal.errors import HalError
from carlaverse.launcher import hardware
from carlaverse.launcher.config_draft import ConfigDraft
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.lab import Lab
from carlaverse.launcher.processes import LaunchError, Supervisor

# A secret in YAML form: a strict decoder that read it would name the key in "unknown field".
SECRET_KEY = "root_secret_4f2a9c"
SECRET = f"{SECRET_KEY}: hunter2\n"


@pytest.fixture
def lab_dirs(tmp_path: Path) -> tuple[ConfigDir, Path]:
    """(the config dir, a folder beside it that the page must never reach)."""
    inside = tmp_path / "configs"
    outside = tmp_path / "private"
    inside.mkdir()
    outside.mkdir()
    (outside / "secret.yaml").write_text(SECRET)
    return ConfigDir(inside), outside


def refused(call: object, *args: object) -> str:
    """The one-line ConfigError `call(*args)` raises, checked to carry no secret."""
    with pytest.raises(ConfigError) as info:
        call(*args)  # type: ignore[operator]
    text = str(info.value)
    assert SECRET_KEY not in text and "hunter2" not in text
    assert "\n" not in text
    return text


def test_names_outside_the_config_dir_are_refused_without_their_content(
    lab_dirs: tuple[ConfigDir, Path],
) -> None:
    files, outside = lab_dirs
    secret = outside / "secret.yaml"
    for name in (str(secret), "../private/secret.yaml", "sub/../../private/secret.yaml"):
        assert "outside the config dir" in refused(files.read, name)
        assert "outside the config dir" in refused(files.read_source, name)
    assert "outside the config dir" in refused(ConfigDraft.open, files, str(secret), None, "bike")
    refused(files.read, str(files.root))  # the folder itself is no file


def test_nothing_outside_is_even_opened(lab_dirs: tuple[ConfigDir, Path]) -> None:
    """A FIFO outside: its writer's open() returns only once someone opens it for reading."""
    files, outside = lab_dirs
    fifo = outside / "pipe.yaml"
    os.mkfifo(fifo)
    opened = threading.Event()

    def writer() -> None:
        with open(fifo, "w") as pipe:
            opened.set()
            pipe.write(SECRET)

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    (files.root / "link.yaml").symlink_to(fifo)
    for name in (str(fifo), "link.yaml"):
        refused(files.read_source, name)
    assert not opened.wait(0.2), "the launcher opened a file outside its config dir"
    with open(fifo) as reader:  # let the writer finish
        reader.read()
    thread.join(5)


def test_symlinks_inside_are_never_followed(lab_dirs: tuple[ConfigDir, Path]) -> None:
    files, outside = lab_dirs
    (files.root / "link.yaml").symlink_to(outside / "secret.yaml")
    (files.root / "sub").symlink_to(outside, target_is_directory=True)
    assert "symlink" in refused(files.read, "link.yaml")
    assert "symlink" in refused(files.read, "sub/secret.yaml")
    with pytest.raises(ConfigError, match="symlink"), files.scratch("sub/new.yaml", "a: 1\n"):
        pass
    assert sorted(p.name for p in outside.iterdir()) == ["secret.yaml"]  # nothing written there


def test_a_save_never_creates_a_folder_outside(lab_dirs: tuple[ConfigDir, Path]) -> None:
    files, outside = lab_dirs
    away = outside / "new" / "deeper" / "bike.yaml"
    draft = ConfigDraft.open(files, "bike-sim", away)
    errors = draft.save()
    assert len(errors) == 1 and "outside the config dir" in errors[0].message
    assert not (outside / "new").exists()
    # inside, a missing folder is made: the editor's "save to" may name one
    draft.target = Path("rigs/bike.yaml")
    assert draft.save() == []
    assert (files.root / "rigs" / "bike.yaml").is_file()


def test_the_scratch_file_follows_no_planted_symlink(lab_dirs: tuple[ConfigDir, Path]) -> None:
    """The old scratch name was predictable (`.<stem>.launcher-<pid>.yaml`) and written with a
    plain open: a symlink planted there sent the draft into the file it pointed at."""
    files, outside = lab_dirs
    victim = outside / "victim.txt"
    victim.write_text("untouched\n")
    (files.root / f".bike.launcher-{os.getpid()}.yaml").symlink_to(victim)
    draft = ConfigDraft.open(files, "bike-sim", Path("bike.yaml"))
    assert draft.save() == []
    assert victim.read_text() == "untouched\n"
    assert (files.root / "bike.yaml").stat().st_mode & 0o777 == 0o600  # a new file: the user's
    # a symlink at the target itself is refused, and what it points at is left as it was
    (files.root / "linked.yaml").symlink_to(victim)
    draft.target = Path("linked.yaml")
    errors = draft.save()
    assert len(errors) == 1 and "symlink" in errors[0].message
    assert victim.read_text() == "untouched\n" and (files.root / "linked.yaml").is_symlink()


def test_a_replaced_file_keeps_its_permissions(lab_dirs: tuple[ConfigDir, Path]) -> None:
    files, _outside = lab_dirs
    target = files.root / "shared.yaml"
    target.write_text("old: 1\n")
    target.chmod(0o644)
    with files.scratch("shared.yaml", "new: 2\n") as scratch:
        scratch.commit()
    assert target.read_text() == "new: 2\n" and target.stat().st_mode & 0o777 == 0o644
    assert [p.name for p in files.root.iterdir()] == ["shared.yaml"]  # no scratch left


def test_a_file_inside_that_names_one_outside_does_not_show_it(
    lab_dirs: tuple[ConfigDir, Path],
) -> None:
    """A scenario inside may name its OpenSCENARIO file by absolute path, and checking the
    scenario reads that file: an error about a file outside the dir says where, never what
    (a parser's message may quote what it read)."""
    files, outside = lab_dirs
    (outside / "secret.xosc").write_text(f"<OpenSCENARIO><{SECRET_KEY}>\n")
    draft = ConfigDraft.open(files, "town", Path("scenario.yaml"))
    draft.set("openscenario", str(outside / "secret.xosc"))
    errors = draft.validate()
    assert len(errors) == 1, errors
    assert SECRET_KEY not in str(errors[0]) and "not shown" in errors[0].message
    assert str(outside / "secret.xosc") in errors[0].message  # where, never what


def test_a_refused_decode_of_a_file_inside_names_only_that_file(
    lab_dirs: tuple[ConfigDir, Path],
) -> None:
    files, _outside = lab_dirs
    (files.root / "broken.yaml").write_text("a: [1,\n")
    with pytest.raises(ConfigError, match="invalid YAML"):
        ConfigDraft.open(files, "broken.yaml")
    (files.root / "binary.yaml").write_bytes(b"\xff\xfe" + SECRET.encode())
    assert "not UTF-8" in refused(files.read, "binary.yaml")


def test_shipped_configs_open_but_cannot_be_saved_over(lab_dirs: tuple[ConfigDir, Path]) -> None:
    files, _outside = lab_dirs
    draft = ConfigDraft.open(files, "bike-sim")
    assert draft.value("road.roughness") == 0.2  # the shipped file's own value
    errors = draft.save()  # its default target is the shipped file itself
    assert len(errors) == 1 and "outside the config dir" in errors[0].message


def test_a_node_starts_only_with_a_config_inside_or_shipped(
    lab_dirs: tuple[ConfigDir, Path],
) -> None:
    files, outside = lab_dirs
    (files.root / "mine.yaml").write_text("node: {kind: scripted}\n")
    # a child that only sleeps: what matters is the argv the lab gives it
    sleeper = Supervisor([sys.executable, "-c", "import time; time.sleep(30)"], grace_s=2)
    lab = Lab("lab", "tcp/127.0.0.1:1", files, supervisor=sleeper)
    try:
        for name in (str(outside / "secret.yaml"), "../private/secret.yaml"):
            with pytest.raises(LaunchError, match="outside the config dir") as info:
                lab.start_node("scripted", "n-1", name)
            assert SECRET_KEY not in str(info.value)
        with pytest.raises(LaunchError, match="outside the config dir"):
            lab.start_authority(str(outside / "secret.yaml"))
        assert sleeper.snapshot() == []
        argv = lab.start_node("scripted", "n-1", "mine.yaml").argv
        assert argv[argv.index("--config") + 1] == str(files.root / "mine.yaml")
    finally:
        lab.close()


def test_test_pulses_go_only_to_devices_a_config_inside_names(
    lab_dirs: tuple[ConfigDir, Path],
) -> None:
    """A real UDP socket stands for an FFB server the page names: it is refused until a config
    in the config dir names that very device block, then it gets its pulses (the page's own
    test, tests/security/test_launcher_lock.py, shows nothing reaches it before)."""
    files, _outside = lab_dirs
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as server:
        server.bind(("127.0.0.1", 0))
        server.settimeout(0.3)
        block = {
            "backend": "udp",
            "options": {"host": "127.0.0.1", "port": server.getsockname()[1]},
        }
        with pytest.raises(HalError, match="in no config in"):
            hardware.check_reach(block, files.device_blocks, files.given)
        hardware.check_reach({"backend": "sim"}, files.device_blocks, files.given)  # no network
        (files.root / "wheel.yaml").write_text(
            f"node: {{kind: drive}}\nffb: {{backend: udp, options: {{host: 127.0.0.1, "
            f"port: {block['options']['port']}}}}}\n"
        )
        hardware.check_reach(block, files.device_blocks, files.given)
        hardware.ffb_pulses(block, lambda _line: None, step_s=0.02, rate_hz=100)
        assert server.recv(64)  # the named device gets its test pulses
