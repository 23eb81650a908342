"""`carlaverse body angles`: the joint angles of the person in a photo, in-process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from carlaverse.cli import main


def test_angles_of_a_photo_as_json(pose_model: Path, grace_hopper: Path, capsys) -> None:
    assert main(["body", "angles", str(grace_hopper), "--model", str(pose_model), "--json"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert set(found["joints_deg"]) >= {"neck", "left_shoulder", "right_knee"}
    assert len(found["visibility"]) == 33 and found["visibility"][0] > 0.9  # her nose


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
