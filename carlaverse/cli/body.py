"""`carlaverse body`: the body-pose model and a check of it on a photograph.

    carlaverse body build-model [--out FILE] [--wheel FILE]   # once per machine (CI: the tests)
    carlaverse body angles PHOTO [--model FILE] [--min-visibility V] [--json]

`build-model` makes MediaPipe's pose landmarker .task offline from the models in the pinned
mediapipe 0.10 wheel (see `carlaverse.body.model`); `angles` runs it on one picture, prints
the joint angles [deg] the walk node would send — only the joints whose landmarks are all at
least `min_visibility` visible, as the node filters them — and exits 1 when it finds nobody.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TextIO

from carlaverse.cli.common import fail, json_stdout
from carlaverse.cli.exit_codes import Exit


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    build = sub.add_parser("build-model", help="build the pose landmarker .task offline")
    build.add_argument("--out", type=Path, help="where to write it (default: the user cache)")
    build.add_argument("--wheel", type=Path, help="the pinned mediapipe 0.10 wheel, if at hand")
    angles = sub.add_parser("angles", help="joint angles of the person in a photograph")
    angles.add_argument("photo", type=Path, help="an image file (PNG, JPEG, ...)")
    angles.add_argument("--model", type=Path, help="the .task file (default: the built one)")
    angles.add_argument(
        "--min-visibility", type=_visibility, metavar="V",
        help="a joint is shown only when all its landmarks are at least this visible, 0..1 "
        "(default: a walk node's default body.options.min_visibility)",
    )  # fmt: skip
    angles.add_argument("--json", action="store_true", help="one JSON object on stdout")


def _visibility(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 <= value <= 1.0:  # also false for NaN
        raise argparse.ArgumentTypeError(f"{text!r} is not a visibility between 0 and 1")
    return value


def run(args: argparse.Namespace) -> int:
    from carlaverse.body.errors import BodyPoseError, PoseModelError, PoseRuntimeMissing

    try:
        if args.action == "build-model":
            return _build(args)
        with json_stdout(args.json) as out:  # nor what mediapipe or TFLite prints
            return _angles(args, out)
    except (PoseRuntimeMissing, PoseModelError) as exc:  # an install, a missing model file
        return fail("body", str(exc))
    except BodyPoseError as exc:
        return fail("body", str(exc), Exit.FAILED)


def _build(args: argparse.Namespace) -> int:
    from carlaverse.body import model

    path = model.build(args.out, args.wheel)
    print(f"pose model written to {path}")
    return 0


def _angles(args: argparse.Namespace, out: TextIO) -> int:
    import cv2

    from carlaverse.body.kinematics import JOINTS, joint_angles
    from carlaverse.body.landmarker import PoseLandmarker
    from carlaverse.body.skeleton import BodyConfig, visible_joints

    if not args.photo.is_file():  # said before OpenCV says it in its own words on stderr
        return fail("body", f"{args.photo}: no such file")
    bgr = cv2.imread(str(args.photo))
    if bgr is None:
        return fail("body", f"{args.photo} is not a readable image")
    with PoseLandmarker(args.model) as landmarker:
        found = landmarker.detect(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), 0.0)
    if found is None:
        return fail("body", f"no person found in {args.photo}", Exit.FAILED)
    minimum = BodyConfig().min_visibility if args.min_visibility is None else args.min_visibility
    seen = visible_joints(joint_angles(found.world), found.visibility, minimum)
    degrees = {joint: [round(math.degrees(a), 1) for a in rpy] for joint, rpy in seen.items()}
    unseen = [joint for joint in JOINTS if joint not in seen]
    if args.json:
        visibility = [round(float(v), 2) for v in found.visibility]
        out.write(json.dumps({"joints_deg": degrees, "unseen": unseen,
                              "min_visibility": minimum,
                              "visibility": visibility}) + "\n")  # fmt: skip
        return 0
    for joint, (roll, pitch, yaw) in degrees.items():
        print(f"{joint:15s} roll {roll:7.1f}  pitch {pitch:7.1f}  yaw {yaw:7.1f}  [deg]")
    if unseen:  # guessed by MediaPipe, not seen: the walk node would not send them either
        print(f"not seen (a landmark below visibility {minimum}): {', '.join(unseen)}")
    return 0
