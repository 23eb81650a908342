"""The walk node's OpenXR actions and their suggested bindings per interaction profile.

One action set `walk`: `move` (a 2D vector: the thumbstick or trackpad that walks), `run` and
`interact` (booleans; a runtime thresholds a bound `/value`), `hand` (the left hand's aim pose:
where "forward" is with `gait.direction: controller`). Suggested for the controllers labs
have; the runtime remaps for others (and the user may rebind in the runtime's UI). Pure data
and one function that hands it to an instance, so the table is testable without a runtime.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

LEFT, RIGHT = "/user/hand/left", "/user/hand/right"


@dataclass(frozen=True, slots=True)
class ActionSpec:
    name: str  # OpenXR action name: lower case, digits, -_.
    kind: str  # "vector2f" | "boolean" | "pose"
    label: str  # shown to the user by the runtime


ACTIONS = (
    ActionSpec("move", "vector2f", "Walk"),
    ActionSpec("run", "boolean", "Run"),
    ActionSpec("interact", "boolean", "Interact"),
    ActionSpec("hand", "pose", "Walking direction hand"),
)

# interaction profile -> action -> input paths
PROFILES: dict[str, dict[str, tuple[str, ...]]] = {
    "/interaction_profiles/khr/simple_controller": {
        "run": (f"{LEFT}/input/select/click",),
        "interact": (f"{RIGHT}/input/select/click",),
        "hand": (f"{LEFT}/input/aim/pose",),
    },
    "/interaction_profiles/oculus/touch_controller": {
        "move": (f"{LEFT}/input/thumbstick",),
        "run": (f"{LEFT}/input/thumbstick/click", f"{LEFT}/input/x/click"),
        "interact": (f"{RIGHT}/input/trigger/value",),
        "hand": (f"{LEFT}/input/aim/pose",),
    },
    "/interaction_profiles/valve/index_controller": {
        "move": (f"{LEFT}/input/thumbstick",),
        "run": (f"{LEFT}/input/thumbstick/click", f"{LEFT}/input/a/click"),
        "interact": (f"{RIGHT}/input/trigger/click",),
        "hand": (f"{LEFT}/input/aim/pose",),
    },
    "/interaction_profiles/htc/vive_controller": {
        "move": (f"{LEFT}/input/trackpad",),
        "run": (f"{LEFT}/input/trackpad/click",),
        "interact": (f"{RIGHT}/input/trigger/click",),
        "hand": (f"{LEFT}/input/aim/pose",),
    },
    "/interaction_profiles/microsoft/motion_controller": {
        "move": (f"{LEFT}/input/thumbstick",),
        "run": (f"{LEFT}/input/thumbstick/click",),
        "interact": (f"{RIGHT}/input/trigger/value",),
        "hand": (f"{LEFT}/input/aim/pose",),
    },
}


def suggest_bindings(xr: Any, instance: Any, actions: dict[str, Any]) -> list[str]:
    """Suggest every profile's bindings; return the profiles the runtime refused (it may not
    know a vendor's profile: that is not an error, the others still apply)."""
    refused = []
    for profile, table in PROFILES.items():
        bindings = [
            xr.ActionSuggestedBinding(actions[name], xr.string_to_path(instance, path))
            for name, paths in table.items() for path in paths
        ]  # fmt: skip
        suggested = xr.InteractionProfileSuggestedBinding(
            interaction_profile=xr.string_to_path(instance, profile),
            suggested_bindings=bindings,
        )
        try:
            xr.suggest_interaction_profile_bindings(instance, suggested)
        except xr.exception.XrException:
            refused.append(profile)
    return refused
