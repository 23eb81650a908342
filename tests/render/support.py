"""Shared pieces of the render tests: small worlds, pixel masks, pinhole projections."""

from __future__ import annotations

import math

import numpy as np

from carlaverse.render.frame import KIND_EXTENTS, ActorDraw
from carlaverse.render.rig import CameraView, HeadPosition


def car(actor_id: str, x: float, y: float, yaw: float = 0.0, kind: str = "car",
        lights: int = 0, ego: bool = False) -> ActorDraw:  # fmt: skip
    e = KIND_EXTENTS[kind]
    return ActorDraw(actor_id, kind, x, y, 0.0, yaw, e.length, e.width, e.height,
                     lights=lights, ego=ego)  # fmt: skip


def changed(a: np.ndarray, b: np.ndarray, threshold: int = 12) -> np.ndarray:
    """Pixels that differ between two frames by more than `threshold` in any channel."""
    return (np.abs(a.astype(int) - b.astype(int)) > threshold).any(axis=2)


def red(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (r > 200) & (g < 90) & (b < 90)


def green(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (g > 200) & (r < 90) & (b < 120)


def yellow(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (r > 200) & (g > 150) & (b < 80)


def footprint(actor: ActorDraw) -> list[tuple[float, float]]:
    c, s = math.cos(actor.yaw), math.sin(actor.yaw)
    corners = []
    for along in (-actor.length / 2, actor.length / 2):
        for across in (-actor.width / 2, actor.width / 2):
            corners.append((actor.x + c * along - s * across, actor.y + s * along + c * across))
    return corners


def head_frame(eye: ActorDraw, head: HeadPosition, p: tuple[float, float]) -> tuple[float, float]:
    """A world point in the head's horizontal frame (forward, left) [m]."""
    c, s = math.cos(eye.yaw), math.sin(eye.yaw)
    hx = eye.x + c * head.x - s * head.y
    hy = eye.y + s * head.x + c * head.y
    dx, dy = p[0] - hx, p[1] - hy
    return c * dx + s * dy, -s * dx + c * dy


def project_row(cam: CameraView, forward: float, left: float, up: float) -> float:
    """Pixel row (0 = top) of a head-frame point, for a camera with no pitch or roll."""
    c, s = math.cos(cam.yaw), math.sin(cam.yaw)
    depth = c * forward + s * left
    ndc_y = (up / depth) / math.tan(cam.fov_v / 2)
    return (1 - ndc_y) / 2 * cam.height_px
