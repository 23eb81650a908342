"""Panda3D's graphics engine, windows or offscreen buffers chosen by config, and pixels out.

One code path: `offscreen` asks Panda3D's headless GL pipe (EGL; Mesa llvmpipe without a GPU,
the GPU's driver with one) for buffers, `window` asks the default pipe for windows; the
outputs, display regions and cameras are the same either way. No ShowBase: we hold our own
`GraphicsEngine`, so two renderers can live in one process (tests do) and nothing is global.

The quality (`quality.py`) is settled here, before any output opens: `auto` asks the driver
through a 16×16 probe buffer whether it rasterises on the CPU. A preset with multisampling
draws offscreen into framebuffer objects hosted by that buffer: an EGL pbuffer takes the
sample count but llvmpipe does not resolve it, an FBO does.

Errors (one tree, all `RenderError`, a RuntimeError):
    RenderError
     └─ NoDisplayError   a window was asked for where there is no display
"""

from __future__ import annotations

import logging
import os

import numpy as np
from panda3d.core import (
    AntialiasAttrib,
    FrameBufferProperties,
    GraphicsEngine,
    GraphicsOutput,
    GraphicsPipe,
    GraphicsPipeSelection,
    Texture,
    WindowProperties,
    load_prc_file_data,
)

from carlaverse.render.quality import Preset, Quality, resolve

log = logging.getLogger(__name__)

# Panda3D reads these once per process; the same values are safe to load again.
PRC = """
audio-library-name null
window-type none
sync-video false
framebuffer-multisample false
rescale-normal auto
notify-level-display error
notify-level-glgsg error
load-display pandagl
aux-display p3headlessgl
"""


class RenderError(RuntimeError):
    """The renderer cannot start or draw."""


class NoDisplayError(RenderError):
    """A window was requested but no display is available."""


class Graphics:
    """The engine, its pipe and one output (window or buffer) per entry of `sizes`."""

    def __init__(self, sizes: tuple[tuple[int, int], ...], offscreen: bool, title: str,
                 quality: Quality = "flat") -> None:  # fmt: skip
        load_prc_file_data("carlaverse-render", PRC)
        self.offscreen = offscreen
        self.pipe = _pipe(offscreen)
        self.engine = GraphicsEngine(self.pipe)
        self.host: GraphicsOutput | None = None  # the probe, host of multisampled buffers
        self.preset: Preset = self._settle(quality)
        self.outputs: list[GraphicsOutput] = []
        for i, (w, h) in enumerate(sizes):
            self.outputs.append(self._make_output(i, w, h, title))
        self.sizes = sizes

    def _settle(self, quality: Quality) -> Preset:
        """The preset; the probe stays open only to host multisampled buffers."""
        preset = resolve(quality, self._probe() if quality == "auto" else "")
        hosts = bool(preset.multisamples) and self.offscreen
        if hosts and self.host is None:
            self._probe()
        elif not hosts and self.host is not None:  # as if never opened
            self.engine.remove_window(self.host)
            self.host = None
        return preset

    def _probe(self) -> str:
        """Open a tiny offscreen buffer and return the GL renderer its driver reports."""
        fb = FrameBufferProperties()
        fb.set_rgb_color(True)
        flags = GraphicsPipe.BF_refuse_window
        self.host = self.engine.make_output(
            self.pipe, "probe", -20, fb, WindowProperties.size(16, 16), flags
        )
        if self.host is None:
            log.warning("no probe buffer on %s: taking the GL renderer for a GPU", self.pipe_name)
            return ""
        self.engine.open_windows()
        gsg = self.host.get_gsg()
        return f"{gsg.get_driver_renderer()} / {gsg.get_driver_vendor()}" if gsg else ""

    def _make_output(self, i: int, w: int, h: int, title: str) -> GraphicsOutput:
        fb = FrameBufferProperties()
        fb.set_rgb_color(True)
        fb.set_color_bits(24)
        fb.set_depth_bits(24)
        samples = self.preset.multisamples
        if samples:
            fb.set_multisamples(samples)
        props = WindowProperties.size(w, h)
        if not self.offscreen:
            props.set_title(f"{title} {i}" if i else title)
            props.set_origin(w * i, 0)  # one window per display, left to right
        flags = GraphicsPipe.BF_refuse_window if self.offscreen else GraphicsPipe.BF_require_window
        host = self.host if samples and self.offscreen else None
        shares = host or (self.outputs[0] if self.outputs else None)  # one GL context for all
        gsg = shares.get_gsg() if shares is not None else None
        out = self.engine.make_output(self.pipe, f"out{i}", i, fb, props, flags, gsg, host)
        if out is None:
            kind = "offscreen buffer" if self.offscreen else "window"
            raise RenderError(f"Panda3D could not open a {w}x{h} {kind} on {self.pipe_name}")
        out.set_clear_color_active(True)
        return out

    def antialias(self) -> AntialiasAttrib | None:
        """The attrib that turns multisampling on for a scene, when this preset has it."""
        if not self.preset.multisamples:
            return None
        return AntialiasAttrib.make(AntialiasAttrib.M_multisample)

    @property
    def pipe_name(self) -> str:
        return f"{self.pipe.get_interface_name()} ({type(self.pipe).__name__})"

    def gl_renderer(self) -> str:
        """The GL renderer string the driver reports, e.g. 'llvmpipe (LLVM 15.0.6, 256 bits)'."""
        gsg = self.outputs[0].get_gsg() if self.outputs else None
        return f"{gsg.get_driver_renderer()} / {gsg.get_driver_vendor()}" if gsg else "unknown"

    def render(self) -> None:
        self.engine.render_frame()

    def closed(self) -> bool:
        """True when a window was closed by its user."""
        return any(out.is_closed() for out in self.outputs) if not self.offscreen else False

    def image(self, output: int = 0) -> np.ndarray:
        """The last frame of one output as an (h, w, 3) uint8 array, top row first."""
        self.engine.sync_frame()
        tex: Texture | None = self.outputs[output].get_screenshot()
        if tex is None:
            raise RenderError(f"output {output} has no frame to read yet: render first")
        data = np.frombuffer(bytes(tex.get_ram_image_as("RGB")), dtype=np.uint8)
        img = data.reshape(tex.get_y_size(), tex.get_x_size(), 3)
        return np.ascontiguousarray(img[::-1])

    def close(self) -> None:
        self.engine.remove_all_windows()
        self.outputs.clear()


def _pipe(offscreen: bool) -> GraphicsPipe:
    selection = GraphicsPipeSelection.get_global_ptr()
    if offscreen:
        pipe = selection.make_module_pipe("p3headlessgl")
        if pipe is None:
            raise RenderError(
                "no headless GL pipe (p3headlessgl): install EGL and Mesa "
                "(apt-get install libegl1 libgl1-mesa-dri)"
            )
        return pipe
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise NoDisplayError("no display to open a window on: use output: offscreen (--offscreen)")
    pipe = selection.make_default_pipe()
    if pipe is None:
        raise NoDisplayError("Panda3D found no window pipe: use output: offscreen (--offscreen)")
    return pipe
