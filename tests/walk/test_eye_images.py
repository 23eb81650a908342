"""The rendered eyes on their way to a headset: the shared-memory block, the swapchain upload
(a real OpenGL context: Mesa's llvmpipe through EGL) and the projection layer."""

from __future__ import annotations

import os
import subprocess
import sys
import uuid

import numpy as np
import pytest

from carlaverse.hal.xr.eye_images import EyeImageBlock, EyeImageWriter, fit_image


def eyes(seed: int, height: int = 48, width: int = 64) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 256, (height, width, 3), dtype=np.uint8) for _ in range(2)]


def test_each_frame_reaches_the_headset_once_and_whole() -> None:
    name = f"carlaverse-test-eyes-{uuid.uuid4().hex[:8]}"
    writer = EyeImageWriter(name)
    assert not writer.offer(eyes(0))  # no block yet: the headset has not opened
    block = EyeImageBlock(name, 64, 48)
    try:
        assert block.newest() is None  # nothing drawn yet
        first = eyes(1)
        assert writer.offer(first)
        frame = block.newest()
        assert frame is not None and frame.frame == 1
        assert np.array_equal(frame.left, first[0]) and np.array_equal(frame.right, first[1])
        assert block.newest() is None  # the same frame is not shown twice
        writer.offer(eyes(2))
        newest = eyes(3)
        writer.offer(newest)  # the headset missed frame 2: only the newest counts
        frame = block.newest()
        assert frame.frame == 3 and np.array_equal(frame.right, newest[1])
        assert not writer.resampled
    finally:
        writer.close()
        block.close()


def test_a_rig_of_another_size_is_resampled_to_the_headsets() -> None:
    image = np.arange(4 * 6 * 3, dtype=np.uint8).reshape(4, 6, 3)
    doubled = fit_image(image, (8, 12))
    assert doubled.shape == (8, 12, 3)
    assert np.array_equal(doubled[::2, ::2], image)  # nearest samples, no invented colours
    assert fit_image(image, (4, 6)) is image
    with pytest.raises(ValueError, match="2"):
        EyeImageWriter("unused").offer(eyes(0)[:1])


UPLOAD = """
import numpy as np
from OpenGL import GL
from xr.utils.gl.egl_util import EGLOffscreenContextProvider
from carlaverse.hal.xr.openxr_present import upload_rgb
context = EGLOffscreenContextProvider()
context.make_current()
texture = GL.glGenTextures(1)
GL.glBindTexture(GL.GL_TEXTURE_2D, texture)
GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, GL.GL_RGBA8, 7, 5, 0, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, None)
image = np.random.default_rng(4).integers(0, 256, (5, 7, 3), dtype=np.uint8)
upload_rgb(texture, image)
GL.glBindTexture(GL.GL_TEXTURE_2D, texture)
raw = GL.glGetTexImage(GL.GL_TEXTURE_2D, 0, GL.GL_RGB, GL.GL_UNSIGNED_BYTE)
stored = np.frombuffer(raw, np.uint8).reshape(5, 7, 3)
assert np.array_equal(stored[0], image[-1]), "GL's first row is the image's bottom row"
assert np.array_equal(stored[::-1], image)
print("uploaded", GL.glGetString(GL.GL_RENDERER).decode())
context.destroy()
"""


def test_the_upload_fills_a_real_texture_bottom_row_first() -> None:
    pytest.importorskip("xr", reason="the openxr backend needs the xr extra")
    env = {**os.environ, "PYOPENGL_PLATFORM": "egl", "EGL_PLATFORM": "surfaceless"}
    done = subprocess.run([sys.executable, "-c", UPLOAD], env=env, capture_output=True,
                          text=True, timeout=60)  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("uploaded")


def test_the_layer_shows_each_eye_with_its_pose_fov_and_rectangle() -> None:
    xr = pytest.importorskip("xr", reason="the openxr backend needs the xr extra")
    from carlaverse.hal.xr.openxr_present import EyeSwapchain, layer_list, projection_layer

    chains = []
    for width in (1000, 1008):  # the eyes' recommended sizes may differ
        chain = EyeSwapchain.__new__(EyeSwapchain)  # no runtime here: no swapchain images
        chain.handle, chain.width, chain.height = xr.Swapchain(), width, 1100
        chains.append(chain)
    fovs = [xr.Fovf(-0.90, 0.73, 0.80, -0.87), xr.Fovf(-0.73, 0.90, 0.80, -0.87)]
    views = [xr.View(pose=xr.Posef(position=xr.Vector3f(x, 1.6, 0.0)), fov=fov)
             for x, fov in zip((-0.032, 0.032), fovs, strict=True)]  # fmt: skip
    layer = projection_layer(xr.Space(), views, chains)
    assert layer.view_count == 2
    for shown, view, chain in zip(layer.views, views, chains, strict=True):
        assert shown.type == xr.StructureType.COMPOSITION_LAYER_PROJECTION_VIEW
        assert shown.pose.position.x == pytest.approx(view.pose.position.x)
        assert shown.fov.angle_left == pytest.approx(view.fov.angle_left)
        rect = shown.sub_image.image_rect
        assert (rect.offset.x, rect.offset.y) == (0, 0)
        assert (rect.extent.width, rect.extent.height) == (chain.width, 1100)
    assert xr.FrameEndInfo(display_time=1, layers=layer_list(layer)).layer_count == 1
