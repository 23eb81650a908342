"""The world view keeps the newest valid skeleton per present walker, and forgets it with them."""

from __future__ import annotations

import numpy as np

from carlaverse import messages as m
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.world_view import WorldView


def _skeleton(t: float, joints: dict[str, tuple[float, float, float]]) -> m.Skeleton:
    raw = np.array(list(joints.values()), dtype="<f4").tobytes()
    return m.Skeleton(1, t, list(joints), raw)


def test_newest_valid_skeleton_per_present_node_until_it_leaves() -> None:
    view = WorldView("me", InterpolationSettings())
    view.intake.present("w1")
    view.intake.skeleton("w1", _skeleton(1.0, {"neck": (0.1, 0.2, 0.3)}))
    view.intake.skeleton("w1", m.Skeleton(2, 2.0, ["neck", "left_knee"], b"\x00" * 12))  # short
    view.intake.skeleton("w1", _skeleton(3.0, {"left_knee": (0.5, 0.0, 0.0)}))
    view.intake.skeleton("w1", _skeleton(0.5, {"neck": (9.0, 9.0, 9.0)}))  # older: ignored
    view.intake.skeleton("stranger", _skeleton(1.0, {"neck": (0.0, 0.0, 0.0)}))  # never joined
    view.intake.skeleton("me", _skeleton(1.0, {"neck": (0.0, 0.0, 0.0)}))  # our own echo
    view.update(3.0)
    assert set(view.skeletons) == {"w1"} and view.skeletons["w1"].t == 3.0
    assert view.rejected["skeleton_size"] == 1
    assert view.rejected["skeleton_from_absent_node"] == 1
    view.intake.gone("w1", "liveliness", 4.0)
    view.update(4.0)
    assert view.skeletons == {}
