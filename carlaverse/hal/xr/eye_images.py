"""The rendered eyes, from the view process to the headset: one shared-memory block.

The walk node's view renders both eyes in a process of its own (Panda3D, `render/process.py`);
the headset lives in the loop process, which runs the OpenXR frame loop. The loop creates this
block once its headset says how large its eye images are (`XrHeadset.display_size()`, the
swapchains' recommended size); the view attaches when the block appears, reads that size from
the block's first fields, and writes each frame's two eye images into it (resampled when its
rig renders another size). The loop reads the newest frame before each headset frame and hands
it to `XrHeadset.present`. A seqlock (`carlaverse.shm`): neither side ever waits for the other;
a frame the loop misses is simply superseded.

Images are RGB, top row first, as the renderer returns them.
"""

from __future__ import annotations

import numpy as np

from carlaverse.shm import SharedBlock, TornRead, new_record

SIZE_FIELDS = np.dtype([("width", "<u4"), ("height", "<u4")])  # what an attaching view reads first


def eye_images_dtype(width: int, height: int) -> np.dtype:
    """The block's record: its size, then the frame counter, then both eyes."""
    eye = ("u1", (height, width, 3))
    return np.dtype([("width", "<u4"), ("height", "<u4"), ("frame", "<u8"),
                     ("left", *eye), ("right", *eye)])  # fmt: skip


def fit_image(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """`image` at (height, width): itself when it has that size, else the nearest samples
    (a rig that renders another size than the headset's is a setup to fix, not to polish)."""
    if image.shape[:2] == size:
        return image
    rows = np.arange(size[0]) * image.shape[0] // size[0]
    cols = np.arange(size[1]) * image.shape[1] // size[1]
    return image[rows[:, None], cols[None, :]]


class EyeFrame:
    """One frame of both eyes, as the loop hands it to the headset."""

    __slots__ = ("frame", "left", "right")

    def __init__(self, frame: int, left: np.ndarray, right: np.ndarray) -> None:
        self.frame, self.left, self.right = frame, left, right


class EyeImageBlock:
    """The loop's side: creates the block at the headset's size; `newest()` never waits."""

    def __init__(self, name: str, width: int, height: int) -> None:
        if width <= 0 or height <= 0:
            raise ValueError(f"eye images of {width}×{height} px: give a positive size")
        self.block = SharedBlock(name, eye_images_dtype(width, height), create=True)
        self.block.write_fields(width=width, height=height)
        self.torn_reads = 0
        self._shown = 0

    @property
    def name(self) -> str:
        return self.block.name

    def newest(self) -> EyeFrame | None:
        """The frame the view wrote since the last call, or None."""
        if self.block.peek("frame") == self._shown:
            return None  # a cheap look first: copying both eyes costs milliseconds
        try:
            record = self.block.read()
        except TornRead:
            self.torn_reads += 1
            return None
        frame = int(record["frame"])
        if frame == self._shown:
            return None
        self._shown = frame
        return EyeFrame(frame, record["left"], record["right"])

    def close(self) -> None:
        self.block.close()


class EyeImageWriter:
    """The view's side: attaches once the loop created the block; `offer()` never waits."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.frames = 0  # written
        self.resampled = False  # the rig renders another size than the headset's
        self._block: SharedBlock | None = None
        self._record: np.void | None = None

    def offer(self, eyes: list[np.ndarray]) -> bool:
        """Write the two eye images of this frame; False while there is no block yet."""
        if len(eyes) != 2:
            raise ValueError(f"eye images: the rig drew {len(eyes)} cameras, a headset has 2")
        if self._block is None and not self._attach():
            return False
        block, record = self._block, self._record
        assert block is not None and record is not None  # `_attach` sets both
        size = (int(record["height"]), int(record["width"]))
        record["left"], record["right"] = (self._fit(eye, size) for eye in eyes)
        self.frames += 1
        record["frame"] = self.frames
        block.write(record)
        return True

    def _attach(self) -> bool:
        try:
            header = SharedBlock(self.name, SIZE_FIELDS)
        except FileNotFoundError:
            return False  # the loop creates it once its headset is open
        width, height = int(header.read()["width"]), int(header.read()["height"])
        header.close()
        if width == 0 or height == 0:
            return False  # created, size not written yet
        self._block = SharedBlock(self.name, eye_images_dtype(width, height))
        self._record = record = new_record(self._block.dtype)
        record["width"], record["height"] = width, height
        return True

    def _fit(self, image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
        if image.shape[:2] != size:
            self.resampled = True
        return fit_image(image, size)

    def close(self) -> None:
        if self._block is not None:
            self._block.close()
            self._block = None
