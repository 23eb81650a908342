"""`carlaverse body angles`: the joint angles of the person in a photo, in-process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from carlaverse.cli import main

# The landmarks each joint's angles are computed from, by MediaPipe's documented pose landmark
# indices (0 nose ... 10 mouth_right, 11/12 shoulders, 13/14 elbows, 15/16 wrists, 23/24 hips,
# 25/26 knees, 27/28 ankles): the neck from the eyes, ears and mouth, a limb's upper and hinge
# joint from its three landmarks (shoulder-elbow-wrist, hip-knee-ankle).
MEDIAPIPE_LANDMARKS = {"neck": (2, 5, 7, 8, 9, 10)} | {
    f"{side}_{joint}": limb
    for side, arm, leg in (
        ("left", (11, 13, 15), (23, 25, 27)),
        ("right", (12, 14, 16), (24, 26, 28)),
    )
    for joint, limb in (("shoulder", arm), ("elbow", arm), ("hip", leg), ("knee", leg))
}  # fmt: skip


def test_angles_of_a_photo_as_json(pose_model: Path, grace_hopper: Path, capsys) -> None:
    assert main(["body", "angles", str(grace_hopper), "--model", str(pose_model), "--json"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert len(found["visibility"]) == 33 and found["visibility"][0] > 0.9  # her nose
    assert "neck" in found["joints_deg"]  # a head-and-shoulders portrait: her face is seen


def test_angles_shows_only_joints_seen_at_min_visibility(
    pose_model: Path, grace_hopper: Path, capsys
) -> None:
    """The README: "a joint is sent only when MediaPipe sees all its landmarks", at the walk
    node's default min_visibility 0.5. The portrait ends above her knees, so MediaPipe guesses
    her legs (visibility near 0) and those joints must not be shown; with 0 all nine are."""
    base = ["body", "angles", str(grace_hopper), "--model", str(pose_model), "--json"]
    assert main(base) == 0
    found = json.loads(capsys.readouterr().out)
    for joint in found["joints_deg"]:
        seen = [found["visibility"][i] for i in MEDIAPIPE_LANDMARKS[joint]]
        assert min(seen) >= 0.5, f"{joint} shown though a landmark has visibility {min(seen)}"
    hidden = {
        j
        for j, idx in MEDIAPIPE_LANDMARKS.items()
        if min(found["visibility"][i] for i in idx) < 0.5
    }
    assert {"left_knee", "right_knee"} <= hidden  # out of the picture
    assert set(found["unseen"]) == hidden
    assert main([*base, "--min-visibility", "0"]) == 0
    assert set(json.loads(capsys.readouterr().out)["joints_deg"]) == set(MEDIAPIPE_LANDMARKS)


def test_angles_text_names_the_joints_not_seen(
    pose_model: Path, grace_hopper: Path, capsys
) -> None:
    assert main(["body", "angles", str(grace_hopper), "--model", str(pose_model)]) == 0
    lines = capsys.readouterr().out.splitlines()
    shown = {line.split()[0] for line in lines if "[deg]" in line}
    assert "right_knee" not in shown and "neck" in shown
    assert lines[-1].startswith("not seen (a landmark below visibility 0.5): ")
    assert "right_knee" in lines[-1]


def test_min_visibility_out_of_range_is_a_usage_error(capsys) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["body", "angles", "photo.png", "--min-visibility", "1.5"])
    assert exited.value.code == 2
    assert "'1.5' is not a visibility between 0 and 1" in capsys.readouterr().err


def test_not_an_image_and_no_model_are_one_line_each(tmp_path: Path, capsys) -> None:
    assert main(["body", "angles", str(tmp_path)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    pytest.importorskip("cv2")
    photo = tmp_path / "black.png"
    import cv2
    import numpy as np

    cv2.imwrite(str(photo), np.zeros((48, 64, 3), np.uint8))
    no_model = ["body", "angles", str(photo), "--model", str(tmp_path / "none.task")]
    assert main(no_model) == 2  # a missing input file (docs/protocol.md, Exit codes)
    err = capsys.readouterr().err
    assert err.startswith("carlaverse body: pose model") and err.count("\n") == 1
