"""Angles wrapped onto one turn: yaw, roll and pitch [rad] to [−π, π), bearings [deg] to
[−180, 180). Differences of wrapped angles wrap again, so `wrap_angle(b − a)` is the signed
shortest turn from a to b."""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(a: float) -> float:
    """Map an angle [rad] to [−π, π); an angle already there is returned unchanged."""
    return a - 2 * math.pi * math.floor((a + math.pi) / (2 * math.pi))


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """`wrap_angle` for an array of angles [rad]."""
    return a - 2 * np.pi * np.floor((a + np.pi) / (2 * np.pi))


def wrap_degrees(a: float) -> float:
    """Map an angle [deg] to [−180, 180)."""
    return (a + 180.0) % 360.0 - 180.0
