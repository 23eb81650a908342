"""Putting the rendered eyes into an OpenXR frame: swapchain textures and the projection layer.

OpenXR hands out each eye's swapchain images as OpenGL textures of the session's context (the
headset's offscreen context, `openxr_headset`). The view process renders in a context of its own,
so its pixels arrive as arrays (`eye_images`) and go into the texture with `glTexSubImage2D`;
GL stores rows bottom first, so the image is flipped on the way in. The projection layer then
names, per eye, the swapchain rectangle and the pose and field of view to show it with.
"""

from __future__ import annotations

from ctypes import byref
from typing import Any

import numpy as np
import xr

from carlaverse.hal.xr.eye_images import fit_image


def upload_rgb(texture: int, image: np.ndarray) -> None:
    """Replace the whole of a 2-D texture with `image` ((h, w, 3) uint8, top row first)."""
    from OpenGL import GL

    height, width = image.shape[:2]
    GL.glBindTexture(GL.GL_TEXTURE_2D, texture)
    GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)  # rows of 3-byte pixels are not 4-aligned
    GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, width, height, GL.GL_RGB,
                       GL.GL_UNSIGNED_BYTE, np.ascontiguousarray(image[::-1]))  # fmt: skip
    GL.glBindTexture(GL.GL_TEXTURE_2D, 0)


class EyeSwapchain:
    """One eye's swapchain and its OpenGL textures."""

    def __init__(self, handle: Any, width: int, height: int) -> None:
        self.handle, self.width, self.height = handle, width, height
        images = xr.enumerate_swapchain_images(handle, xr.SwapchainImageOpenGLKHR)
        self.textures = [int(image.image) for image in images]

    def draw(self, image: np.ndarray) -> None:
        """Acquire the next image of the chain, fill it with `image`, release it."""
        image = fit_image(image, (self.height, self.width))  # the eyes' chains may differ
        index = xr.acquire_swapchain_image(self.handle, xr.SwapchainImageAcquireInfo())
        xr.wait_swapchain_image(self.handle, xr.SwapchainImageWaitInfo(
            timeout=xr.INFINITE_DURATION))  # fmt: skip
        try:
            upload_rgb(self.textures[index], image)
        finally:
            xr.release_swapchain_image(self.handle, xr.SwapchainImageReleaseInfo())


def projection_layer(space: Any, views: Any, chains: list[EyeSwapchain]) -> Any:
    """The layer that shows each chain's last image with its eye's pose and field of view."""
    eyes = []
    for view, chain in zip(views, chains, strict=True):
        eye = xr.CompositionLayerProjectionView(pose=view.pose, fov=view.fov)
        eye.sub_image.swapchain = chain.handle
        eye.sub_image.image_rect.offset.x = eye.sub_image.image_rect.offset.y = 0
        eye.sub_image.image_rect.extent.width = chain.width
        eye.sub_image.image_rect.extent.height = chain.height
        eyes.append(eye)
    return xr.CompositionLayerProjection(space=space, views=eyes)


def layer_list(layer: Any) -> list[Any]:
    """`FrameEndInfo.layers` for one layer (the layer must outlive `end_frame`)."""
    return [byref(layer)]
