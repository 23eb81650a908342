"""Many 64-byte poses at once: as numpy columns, decoded row by row, and the authority's pose
digest (`world/@egos`) that relays them many to a message."""

from __future__ import annotations

from typing import Annotated, NamedTuple, cast

import msgspec
import numpy as np

from carlaverse.messages.base import TIME_LIMIT_S, MessageError, Seq
from carlaverse.messages.codec import Codec
from carlaverse.messages.pose import POSE_LAYOUT_VERSION, POSE_SIZE, Pose, pose_or_refusal

# POSE_LAYOUT as a numpy record, no padding: 64 bytes. Many poses are checked at once with it.
POSE_DTYPE = np.dtype(
    [
        ("version", "u1"),
        ("flags", "u1"),
        ("reserved", "<u2"),
        ("seq", "<u4"),
        ("t", "<f8"),
        ("f32", "<f4", 9),  # x y z, roll pitch yaw, vx vy vz
        ("f16", "<f2", 6),  # wx wy wz, ax ay az
    ]
)
assert POSE_DTYPE.itemsize == POSE_SIZE


class PoseColumns(NamedTuple):
    """Consecutive poses as columns: what a receiver applies many at once."""

    seq: np.ndarray  # int64
    values: np.ndarray  # float64, (n, 16): t, x y z, roll pitch yaw, vx vy vz, wx wy wz, ax ay az
    flags: np.ndarray  # int64

    def take(self, rows: np.ndarray) -> PoseColumns:
        """Only these rows (indices or a mask)."""
        return PoseColumns(self.seq[rows], self.values[rows], self.flags[rows])

    def poses(self) -> list[Pose]:
        """A `Pose` per row, built column by column without a Python loop."""
        return list(map(Pose, self.seq.tolist(), *self.values.T.tolist(), self.flags.tolist()))


def pose_columns(rows: bytes | bytearray | memoryview) -> tuple[PoseColumns, np.ndarray]:
    """Consecutive 64-byte poses as columns, and which rows `decode_pose` would accept (layout
    version, every value finite, the time in range). One numpy pass over all of them."""
    if len(rows) % POSE_SIZE:
        raise MessageError(f"pose rows: {len(rows)} bytes is not a multiple of {POSE_SIZE}")
    table = np.frombuffer(rows, dtype=POSE_DTYPE)
    values = np.empty((len(table), 16))  # t, then the 9 f32 and 6 f16 fields, as f64
    values[:, 0] = table["t"]
    values[:, 1:10] = table["f32"]
    values[:, 10:] = table["f16"]
    good = (
        (table["version"] == POSE_LAYOUT_VERSION)
        & np.isfinite(values).all(axis=1)
        & (np.abs(values[:, 0]) <= TIME_LIMIT_S)
    )
    columns = PoseColumns(table["seq"].astype(np.int64), values, table["flags"].astype(np.int64))
    return columns, good


def pose_stamps(rows: bytes | bytearray | memoryview) -> tuple[np.ndarray, np.ndarray]:
    """The sequence numbers and times of consecutive wire poses, read without checking them."""
    table = np.frombuffer(rows, dtype=POSE_DTYPE)
    return table["seq"], table["t"]


# Up to this many rows are decoded one `struct` unpack each: numpy's setup for a pass over the
# rows costs more than that (measured warm: 1 row 10 µs through numpy against 1.4 µs unpacked,
# 8 rows 12 against 9, 16 rows 15 against 19). A node's loop applies a few poses per update.
FEW_ROWS = 8


def decode_pose_rows(rows: bytes | bytearray | memoryview) -> list[Pose | None]:
    """Consecutive 64-byte poses, each decoded as `decode_pose` would; None where it would
    refuse. A relay's batch costs a fraction of a `decode_pose` call per pose."""
    if len(rows) == POSE_SIZE:  # one pose per update: a node hearing one ego at its own rate
        pose = pose_or_refusal(rows)
        return [None if isinstance(pose, str) else pose]
    if len(rows) <= FEW_ROWS * POSE_SIZE and not len(rows) % POSE_SIZE:
        decoded = [pose_or_refusal(rows[k : k + POSE_SIZE]) for k in range(0, len(rows), POSE_SIZE)]
        return [None if isinstance(pose, str) else pose for pose in decoded]
    columns, good = pose_columns(rows)
    if good.all():  # nearly always
        return cast("list[Pose | None]", columns.poses())  # a new list, held by nobody else
    keep = np.flatnonzero(good)
    poses = columns.take(keep).poses()
    out: list[Pose | None] = [None] * len(good)
    for k, pose in zip(keep.tolist(), poses, strict=True):
        out[k] = pose
    return out


# Poses relayed many to a message (`PoseDigest`): at most this many in one.
DIGEST_MAX_POSES = 4096


class PoseDigest(msgspec.Struct, frozen=True, array_like=True):
    """Egos' poses relayed by the authority, many to a message (`world/@egos`).

    For nodes that hear the whole session (docs/architecture.md §3): one sample for dozens of
    poses instead of one each, which is most of what a pose costs to receive. Each row is the
    pose exactly as its node published it."""

    seq: Seq
    ids: Annotated[list[str], msgspec.Meta(max_length=DIGEST_MAX_POSES)]  # row i's node
    rows: bytes  # len(ids) poses in the 64-byte pose layout

    def poses(self) -> list[Pose | None]:
        """Each row decoded; None for a row `decode_pose` would refuse."""
        return decode_pose_rows(self.rows)


def _check_pose_digest(digest: PoseDigest) -> None:
    if len(digest.rows) != len(digest.ids) * POSE_SIZE:
        raise MessageError(
            f"pose digest: {len(digest.ids)} ids but {len(digest.rows)} bytes of rows "
            f"(expected {len(digest.ids) * POSE_SIZE})"
        )


POSE_DIGEST: Codec[PoseDigest] = Codec(PoseDigest, _check_pose_digest)
