"""What a node and the views of it agree on in shared memory: the own-pose block's name, record
fields and the headset eye fields inside it.

A node's loop writes its state block (`carlaverse.shm`) at its own rate; the render process
reads the node's own actor from it each frame (`render.live.OwnPose`). Both sides import this
module, which imports neither the network nor a renderer, so a 90 Hz loop that writes the block
loads no more than the layout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carlaverse import messages as m

OWN_POSE_FIELDS = ("t", "x", "y", "yaw")  # an own-pose block must have these (session s, m, rad)
CAR_EXTENT = m.Extent()
EYES = ("left_eye", "right_eye")  # a walker's block: `eyes` set, then <eye>_<edge> [rad]
EDGES = ("left", "right", "up", "down")


@dataclass(frozen=True, slots=True)
class OwnPoseBlock:
    """Where a node exports its own pose: a seqlock block (`carlaverse.shm`) of `dtype`.

    The dtype needs the fields `t, x, y, yaw`; `lights` (LIGHT_* bits), `pitch` and `roll`
    (a walker's head: the first-person camera nods and tilts with it), `speed_mps`,
    `yaw_rate` and `steer_rad` (the wheels' roll and steer; the speed, with `gear` and
    `blink_on`, the HUD's dashboard: `render.frame.Dashboard`), `eyes` with
    `<left|right>_eye_<left|right|up|down>` (a headset's eye frusta [rad], which an `xr` rig
    draws with) and `running` (0 until the loop's first tick) are used when present. The node
    kind names the block and its dtype, so this library never imports a node kind.
    `eye_images` names the block a headset shows the rendered eyes from (`hal.xr.eye_images`).
    """

    name: str
    dtype: np.dtype
    kind: str = "car"
    extent: m.Extent = CAR_EXTENT
    eye_images: str = ""
