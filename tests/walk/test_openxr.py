"""OpenXR without a runtime: one clear line through the CLI; the runtime search; the bindings."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from carlaverse.cli import main
from carlaverse.hal.xr.openxr_bindings import ACTIONS, PROFILES
from carlaverse.hal.xr.openxr_runtime import find_runtime, manifest_candidates

pytest.importorskip("xr")  # pyopenxr: the `xr` extra


def no_runtime_env(tmp_path: Path, **extra: str) -> dict[str, str]:
    """This machine's environment with the runtime search pointed at empty directories."""
    env = {k: v for k, v in os.environ.items() if k != "XR_RUNTIME_JSON"}
    env.update(HOME=str(tmp_path / "home"), XDG_CONFIG_HOME=str(tmp_path / "config"),
               XDG_CONFIG_DIRS=str(tmp_path / "xdg"), **extra)  # fmt: skip
    return env


JOIN_VR = ["join", "walk", "--config", "walk-vr", "--id", "vr-1", "--session", "t",
           "--connect", "tcp/127.0.0.1:9", "--duration", "5"]  # fmt: skip


def join_vr(env: dict[str, str]) -> subprocess.CompletedProcess:
    """The CLI as a user runs it, in a process of its own."""
    if Path("/etc/openxr/1/active_runtime.json").exists():
        pytest.skip("this machine has a system-wide OpenXR runtime")
    return subprocess.run([sys.executable, "-m", "carlaverse", *JOIN_VR],
                          capture_output=True, text=True, timeout=60, env=env)  # fmt: skip


def join_vr_here(env: dict[str, str], monkeypatch: pytest.MonkeyPatch,
                 capfd: pytest.CaptureFixture[str]) -> tuple[int, str]:  # fmt: skip
    """The CLI in this process (`main(argv)`); fd-level capture sees the loader's C output."""
    for name in ("XR_RUNTIME_JSON", "XR_LOADER_DEBUG"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    code = main(JOIN_VR)
    return code, capfd.readouterr().err


def test_no_runtime_fails_in_one_line_naming_it(tmp_path: Path) -> None:
    done = join_vr(no_runtime_env(tmp_path))
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("carlaverse join: walk: xr backend 'openxr': no OpenXR runtime")
    assert "XR_RUNTIME_JSON is unset" in lines[0]
    assert str(tmp_path / "config" / "openxr" / "1" / "active_runtime.json") in lines[0]
    assert "Traceback" not in done.stderr


def test_runtime_json_naming_no_file_is_said(tmp_path: Path, monkeypatch, capfd) -> None:
    missing = tmp_path / "steamvr.json"
    code, err = join_vr_here(no_runtime_env(tmp_path, XR_RUNTIME_JSON=str(missing)),
                             monkeypatch, capfd)  # fmt: skip
    assert code == 2
    assert err.strip() == (
        f"carlaverse join: walk: xr backend 'openxr': no OpenXR runtime: XR_RUNTIME_JSON="
        f"{missing} is not a file; point it at your runtime's manifest (e.g. SteamVR's or "
        "Monado's openxr_*.json)"
    )


def test_a_runtime_the_loader_cannot_load_is_one_line_too(tmp_path: Path, monkeypatch,
                                                          capfd) -> None:  # fmt: skip
    manifest = tmp_path / "broken.json"
    library = str(tmp_path / "none.so")
    manifest.write_text(json.dumps({"file_format_version": "1.0.0",
                                    "runtime": {"library_path": library}}))  # fmt: skip
    env = no_runtime_env(tmp_path, XR_RUNTIME_JSON=str(manifest))
    code, err = join_vr_here({"XR_RUNTIME_JSON": env["XR_RUNTIME_JSON"]}, monkeypatch, capfd)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err  # the loader's own error lines are silenced
    assert "loading the runtime failed" in lines[0] and str(manifest) in lines[0]


def test_runtime_search_follows_the_loader_order(tmp_path: Path) -> None:
    env = {"HOME": str(tmp_path / "h"), "XDG_CONFIG_DIRS": f"{tmp_path / 'a'}:{tmp_path / 'b'}"}
    rel = Path("openxr/1/active_runtime.json")
    expected = [tmp_path / "h/.config", tmp_path / "a", tmp_path / "b", Path("/etc")]
    assert manifest_candidates(env) == [base / rel for base in expected]
    assert find_runtime(env) is None or str(find_runtime(env)).startswith("/etc")
    second = tmp_path / "b" / rel
    second.parent.mkdir(parents=True)
    second.write_text("{}")
    assert find_runtime(env) == second
    first = tmp_path / "h/.config" / rel
    first.parent.mkdir(parents=True)
    first.write_text("{}")
    assert find_runtime(env) == first  # the user's own config wins


PATH = re.compile(r"^/user/hand/(left|right)/input/[a-z_]+(/(click|value|pose|touch))?$")


def test_bindings_cover_walk_run_interact_on_thumbstick_controllers() -> None:
    names = {a.name for a in ACTIONS}
    assert names == {"move", "run", "interact", "hand"}
    for profile, table in PROFILES.items():
        assert profile.startswith("/interaction_profiles/")
        assert set(table) <= names and {"run", "interact"} <= set(table), profile
        for paths in table.values():
            assert all(PATH.match(p) for p in paths), paths
    with_stick = [p for p, t in PROFILES.items() if "move" in t]
    assert len(with_stick) == len(PROFILES) - 1  # all but the Khronos simple controller
    for profile in with_stick:  # the walking vector is a 2D input, never a click
        assert all(not p.endswith(("/click", "/value")) for p in PROFILES[profile]["move"])
