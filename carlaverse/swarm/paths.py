"""Where the egos of a swarm drive: loops around city blocks, computed for all egos at once.

Each synthetic ego circles one block of a street grid (the shape of a scripted node's
`PolylinePath` over the block's four corners, driven at constant speed), so positions,
headings and speeds look like traffic in a grid town rather than points on a circle. The
swarm asks for many egos' poses per timer slot; a Python call per ego would cost more than
sending the pose, so the loops are arrays and one call answers a whole group.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_SPEED_MPS = 8.0  # [m/s] ~30 km/h: a town street
MAX_SPEED_MPS = 14.0  # [m/s] ~50 km/h
# The four sides of a block in driving order (counter-clockwise): unit direction of each.
_SIDE_DIRECTIONS = np.array([(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)])


@dataclass(frozen=True, slots=True)
class LoopStates:
    """Where a group of egos is at one time: one row per ego (SI units, world frame)."""

    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    vx: np.ndarray  # [m/s]
    vy: np.ndarray  # [m/s]


class BlockLoops:
    """Egos each driving around one rectangular block at constant speed.

    `corners[i]` is the south-west corner of ego i's block [m], `size[i]` its (width, height)
    [m], `speed[i]` [m/s] and `offset[i]` the arc length driven at t = 0 [m].
    """

    def __init__(
        self, corners: np.ndarray, size: np.ndarray, speed: np.ndarray, offset: np.ndarray
    ) -> None:
        self.corners = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
        self.size = np.asarray(size, dtype=np.float64).reshape(-1, 2)
        self.speed = np.asarray(speed, dtype=np.float64)
        self.offset = np.asarray(offset, dtype=np.float64)
        w, h = self.size[:, 0], self.size[:, 1]
        # Arc length at which each side starts: bottom, right, top, left.
        self._starts = np.stack([np.zeros_like(w), w, w + h, 2 * w + h], axis=1)
        self._perimeter = 2 * (w + h)

    def __len__(self) -> int:
        return len(self.speed)

    @classmethod
    def scattered(
        cls,
        count: int,
        spread_m: float,
        block_m: float,
        rng: np.random.Generator,
        origin: tuple[float, float] = (0.0, 0.0),
    ) -> BlockLoops:
        """`count` loops on random blocks of a `block_m` grid filling the square of side
        `spread_m` whose south-west corner is `origin` [m] (put it on a junction of a grid
        town and the egos drive its streets)."""
        blocks = max(1, int(spread_m // block_m))
        cells = rng.integers(0, blocks, size=(count, 2))
        size = np.full((count, 2), min(block_m, spread_m))
        speed = rng.uniform(MIN_SPEED_MPS, MAX_SPEED_MPS, size=count)
        offset = rng.uniform(0.0, 4 * size[:, 0])
        return cls(cells * block_m + np.asarray(origin, dtype=np.float64), size, speed, offset)

    def at(self, t: float, which: np.ndarray | slice = slice(None)) -> LoopStates:
        """The states of egos `which` at time `t` [s]."""
        corner, size = self.corners[which], self.size[which]
        starts, speed = self._starts[which], self.speed[which]
        s = (self.offset[which] + speed * t) % self._perimeter[which]
        side = np.minimum((s[:, None] >= starts[:, 1:]).sum(axis=1), 3)
        along = s - starts[np.arange(len(s)), side]
        direction = _SIDE_DIRECTIONS[side]
        # Each side starts at a corner of the block: (0,0), (w,0), (w,h), (0,h).
        start = corner + size * np.array([(0, 0), (1, 0), (1, 1), (0, 1)])[side]
        x = start[:, 0] + direction[:, 0] * along
        y = start[:, 1] + direction[:, 1] * along
        yaw = np.arctan2(direction[:, 1], direction[:, 0])
        return LoopStates(x, y, yaw, direction[:, 0] * speed, direction[:, 1] * speed)
