"""Stills (PNG) and clips (MP4, H.264 through the ffmpeg that imageio-ffmpeg ships)."""

from __future__ import annotations

from collections.abc import Generator
from pathlib import Path

import numpy as np

from carlaverse.render.graphics import RenderError


def save_png(path: str | Path, image: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(image).save(path)


class ClipWriter:
    """Writes RGB frames of one size into an MP4 file; close() finishes the file."""

    def __init__(self, path: str | Path, width: int, height: int, fps: float) -> None:
        try:
            import imageio_ffmpeg
        except ImportError as exc:
            raise RenderError("MP4 needs imageio-ffmpeg: pip install 'carlaverse[render]'") from exc
        # H.264 in yuv420p wants even sizes; frames are cropped by at most one pixel
        self.size = (width - width % 2, height - height % 2)
        self._writer: Generator[None, bytes, None] = imageio_ffmpeg.write_frames(
            str(path), self.size, fps=fps, codec="libx264", pix_fmt_out="yuv420p",
            macro_block_size=1, quality=7,
        )  # fmt: skip
        self._writer.send(None)  # start ffmpeg
        self.frames = 0

    def add(self, image: np.ndarray) -> None:
        w, h = self.size
        self._writer.send(np.ascontiguousarray(image[:h, :w]).tobytes())
        self.frames += 1

    def close(self) -> None:
        self._writer.close()
