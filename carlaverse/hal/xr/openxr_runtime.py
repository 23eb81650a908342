"""Is there an OpenXR runtime? The loader's own search, done first so a missing one is one line.

The OpenXR loader (bundled with pyopenxr) finds the runtime on Linux through the environment
variable XR_RUNTIME_JSON, else the first `openxr/1/active_runtime.json` in $XDG_CONFIG_HOME
(~/.config), then each of $XDG_CONFIG_DIRS (/etc/xdg), then /etc; on Windows through the
registry (HKLM\\SOFTWARE\\Khronos\\OpenXR\\1\\ActiveRuntime), which we leave to the loader.
A headset vendor's runtime (SteamVR, Monado, Meta Quest Link, WMR) writes that file or key
when it is made the active runtime.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path

from carlaverse.hal.errors import DeviceError

MANIFEST = Path("openxr") / "1" / "active_runtime.json"


def manifest_candidates(env: Mapping[str, str]) -> list[Path]:
    """Where the Linux loader looks for the active runtime, in its order."""
    home = Path(env.get("HOME", "~")).expanduser()
    config_home = Path(env.get("XDG_CONFIG_HOME") or home / ".config")
    dirs = [Path(d) for d in (env.get("XDG_CONFIG_DIRS") or "/etc/xdg").split(":") if d]
    return [base / MANIFEST for base in (config_home, *dirs, Path("/etc"))]


def find_runtime(env: Mapping[str, str] | None = None) -> Path | None:
    """The runtime manifest the loader would use, or None when there is none."""
    env = os.environ if env is None else env
    named = env.get("XR_RUNTIME_JSON")
    if named:
        return Path(named) if Path(named).is_file() else None
    return next((p for p in manifest_candidates(env) if p.is_file()), None)


def missing_runtime(env: Mapping[str, str] | None = None) -> str:
    """The one line that says no runtime was found, and where it was looked for."""
    env = os.environ if env is None else env
    named = env.get("XR_RUNTIME_JSON")
    if named:
        return (
            f"xr backend 'openxr': no OpenXR runtime: XR_RUNTIME_JSON={named} is not a "
            "file; point it at your runtime's manifest (e.g. SteamVR's or Monado's "
            "openxr_*.json)"
        )
    looked = ", ".join(str(p) for p in manifest_candidates(env))
    return (
        f"xr backend 'openxr': no OpenXR runtime: XR_RUNTIME_JSON is unset and there is "
        f"no active_runtime.json ({looked}); install the headset's runtime (SteamVR, "
        "Monado, ...) and make it the active one, or use xr backend 'sim' or 'mouse'"
    )


def preflight(env: Mapping[str, str] | None = None) -> None:
    """Raise DeviceError (one line) when the loader would find no runtime."""
    if sys.platform.startswith("linux") and find_runtime(env) is None:
        raise DeviceError(missing_runtime(env))
