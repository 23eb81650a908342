"""A real headset through OpenXR (pyopenxr): `xr: {backend: openxr}`.

Opening it creates the instance (OpenGL enabled), finds the head-mounted system, creates a
session on an offscreen OpenGL context, the stage space, the view space (the head), one
swapchain per eye at the runtime's recommended size, and the `walk` action set with its
suggested bindings (`openxr_bindings`). Each `pose()` runs one turn of the frame loop: it
handles the session's state changes, waits for the runtime's frame, locates the head and
both eyes (their asymmetric fields of view are `eye_fovs()`, for the renderer's off-axis
lenses, `carlaverse.render.stereo`, or the symmetric render and crop, `fov`), syncs and
reads the actions, and ends the frame.

The eyes it shows: the walk node's view renders both eyes in a process of its own and hands
them over through shared memory (`eye_images`); `present()` keeps the newest, and the next
frame uploads them into the eyes' swapchain images and ends with a projection layer at the eyes'
poses and fields of view located for that frame (`openxr_present`). Until the first image
arrives, frames end without a layer (the runtime shows its own backdrop). The layer names the
pose of the frame it is shown in, not the one the image was drawn at, so the runtime's
reprojection cannot hide the view's age (one view frame or less): a known limit.

No runtime, no headset: opening fails with one line naming what is missing
(`openxr_runtime`); the loader's own error output is silenced unless XR_LOADER_DEBUG is set.
"""

from __future__ import annotations

import logging
import math
import os
import time
from ctypes import POINTER, byref, cast
from typing import Any, Literal

import xr
from xr.utils.gl import OpenGLGraphics
from xr.utils.gl.glfw_util import GLFWOffscreenContextProvider

from carlaverse.config import StrictStruct
from carlaverse.fov import EyeFov
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.xr import XrActions, XrHeadset
from carlaverse.hal.xr.eye_images import EyeFrame
from carlaverse.hal.xr.frames import quaternion_matrix
from carlaverse.hal.xr.openxr_bindings import ACTIONS, ActionSpec, suggest_bindings
from carlaverse.hal.xr.openxr_present import EyeSwapchain, layer_list, projection_layer
from carlaverse.hal.xr.openxr_runtime import find_runtime, preflight

log = logging.getLogger(__name__)

SPACES = {"stage": xr.ReferenceSpaceType.STAGE, "local": xr.ReferenceSpaceType.LOCAL}
ACTION_TYPES = {"vector2f": xr.ActionType.VECTOR2F_INPUT, "boolean": xr.ActionType.BOOLEAN_INPUT,
                "pose": xr.ActionType.POSE_INPUT}  # fmt: skip
RUNNING_STATES = (xr.SessionState.READY, xr.SessionState.SYNCHRONIZED,
                  xr.SessionState.VISIBLE, xr.SessionState.FOCUSED)  # fmt: skip


class OpenXrOptions(StrictStruct):
    application_name: str = "CARLAverse walk node"
    reference_space: Literal["stage", "local"] = "stage"  # stage: the floor is y = 0


def probe_runtime() -> None:
    """One line when OpenXR cannot start here: no runtime, or one the loader cannot load."""
    preflight()
    os.environ.setdefault("XR_LOADER_DEBUG", "none")  # our one line instead of its many
    info = xr.InstanceCreateInfo(application_info=xr.ApplicationInfo(
        "carlaverse probe", 1, "carlaverse", 1, xr.XR_CURRENT_API_VERSION))  # fmt: skip
    try:
        xr.destroy_instance(xr.create_instance(info))
    except xr.exception.XrException as exc:
        raise _fail("loading the runtime", exc) from exc


def _fail(what: str, exc: Exception) -> DeviceError:
    runtime = find_runtime()
    return DeviceError(f"xr backend 'openxr': {what} failed ({type(exc).__name__}: {exc}); "
                       f"runtime {runtime or 'not found'}")  # fmt: skip


class OpenXrHeadset(XrHeadset):
    Options = OpenXrOptions
    preflight = staticmethod(probe_runtime)

    def __init__(self, options: OpenXrOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        probe_runtime()
        self._eye_fovs: tuple[EyeFov, EyeFov] | None = None
        self.session_state = xr.SessionState.IDLE
        self.running = False
        self._last = ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), False)
        self._actions_now = XrActions()
        self._pending: EyeFrame | None = None  # the newest eye images from the view
        self.frames_shown = 0  # frames ended with the eyes' projection layer
        self._handles: list[tuple[Any, Any]] = []  # (destroy function, handle), newest last
        try:
            self._open(options)
        except xr.exception.XrException as exc:
            self._close()
            raise _fail("opening the session", exc) from exc

    # ------------------------------------------------------------------ opening

    def _keep(self, destroy: Any, handle: Any) -> Any:
        self._handles.append((destroy, handle))
        return handle

    def _open(self, options: OpenXrOptions) -> None:
        info = xr.InstanceCreateInfo(
            application_info=xr.ApplicationInfo(options.application_name, 1, "carlaverse", 1,
                                                xr.XR_CURRENT_API_VERSION),
            enabled_extension_names=[xr.KHR_OPENGL_ENABLE_EXTENSION_NAME],
        )  # fmt: skip
        self.instance = self._keep(xr.destroy_instance, xr.create_instance(info))
        self.system = xr.get_system(self.instance, xr.SystemGetInfo(
            form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY))  # fmt: skip
        self.context = GLFWOffscreenContextProvider()
        self.graphics = OpenGLGraphics(self.instance, self.system, self.context)
        binding = self.graphics.graphics_binding.pointer
        info = xr.SessionCreateInfo(system_id=self.system, next=binding)
        self.session = self._keep(xr.destroy_session, xr.create_session(self.instance, info))
        self.space = self._reference_space(SPACES[options.reference_space])
        self.head_space = self._reference_space(xr.ReferenceSpaceType.VIEW)
        self._make_swapchains()
        self._make_actions()

    def _action(self, spec: ActionSpec) -> Any:
        info = xr.ActionCreateInfo(action_name=spec.name, action_type=ACTION_TYPES[spec.kind],
                                   localized_action_name=spec.label)  # fmt: skip
        return xr.create_action(self.action_set, info)

    def _reference_space(self, kind: Any) -> Any:
        info = xr.ReferenceSpaceCreateInfo(reference_space_type=kind)
        return self._keep(xr.destroy_space, xr.create_reference_space(self.session, info))

    def _make_swapchains(self) -> None:
        views = xr.enumerate_view_configuration_views(
            self.instance, self.system, xr.ViewConfigurationType.PRIMARY_STEREO
        )
        self.graphics.initialize_resources()
        fmt = self.graphics.select_color_swapchain_format(
            xr.enumerate_swapchain_formats(self.session)
        )
        self.swapchains = []
        for view in views:
            info = xr.SwapchainCreateInfo(
                array_size=1, format=fmt, width=view.recommended_image_rect_width,
                height=view.recommended_image_rect_height, mip_count=1, face_count=1,
                sample_count=view.recommended_swapchain_sample_count,
                usage_flags=(xr.SwapchainUsageFlags.SAMPLED_BIT
                             | xr.SwapchainUsageFlags.COLOR_ATTACHMENT_BIT),
            )  # fmt: skip
            chain = self._keep(xr.destroy_swapchain, xr.create_swapchain(self.session, info))
            self.swapchains.append(EyeSwapchain(chain, info.width, info.height))

    def _make_actions(self) -> None:
        self.action_set = self._keep(xr.destroy_action_set, xr.create_action_set(
            self.instance, xr.ActionSetCreateInfo("walk", "Walk", 0)))  # fmt: skip
        self.xr_actions = {a.name: self._action(a) for a in ACTIONS}
        refused = suggest_bindings(xr, self.instance, self.xr_actions)
        if refused:  # a vendor's profile this runtime does not know: the others still apply
            log.info("the OpenXR runtime refused the bindings of %s", ", ".join(refused))
        xr.attach_session_action_sets(self.session, xr.SessionActionSetsAttachInfo(
            action_sets=[self.action_set]))  # fmt: skip
        self.hand_space = self._keep(xr.destroy_space, xr.create_action_space(
            self.session, xr.ActionSpaceCreateInfo(action=self.xr_actions["hand"])))  # fmt: skip

    # ------------------------------------------------------------------ the frame loop

    def _pose(self, now: float) -> tuple[tuple[float, float, float], tuple, bool]:
        self._poll_events()
        if not (self.running and self.session_state in RUNNING_STATES):
            return self._last[0], self._last[1], False
        frame = xr.wait_frame(self.session)
        xr.begin_frame(self.session)
        layer = None
        try:
            views = self._track(frame.predicted_display_time)
            if frame.should_render and self._pending is not None and len(views) == 2:
                layer = self._draw(self._pending, views)
        finally:
            xr.end_frame(self.session, xr.FrameEndInfo(
                display_time=frame.predicted_display_time,
                environment_blend_mode=xr.EnvironmentBlendMode.OPAQUE,
                layers=layer_list(layer) if layer is not None else []))  # fmt: skip
        return self._last

    def display_size(self) -> tuple[int, int] | None:
        left = self.swapchains[0]
        return left.width, left.height

    def present(self, eyes: EyeFrame) -> None:
        self._pending = eyes

    def _draw(self, eyes: EyeFrame, views: Any) -> Any:
        """Upload the newest eye images and make the layer that shows them."""
        for chain, image in zip(self.swapchains, (eyes.left, eyes.right), strict=True):
            chain.draw(image)
        self.frames_shown += 1
        return projection_layer(self.space, views, self.swapchains)

    def _actions(self, now: float) -> XrActions:
        return self._actions_now

    def eye_fovs(self) -> tuple[EyeFov, EyeFov] | None:
        """The runtime's per-eye frusta at the last frame (they may change, e.g. with IPD)."""
        return self._eye_fovs

    def _track(self, display_time: int) -> Any:
        """Locate the head and eyes, read the actions; the eyes' views when they are known."""
        head = xr.locate_space(self.head_space, self.space, display_time)
        valid = (
            xr.SpaceLocationFlags.POSITION_VALID_BIT | xr.SpaceLocationFlags.ORIENTATION_VALID_BIT
        )
        tracked = (head.location_flags & valid) == valid
        if tracked:
            p, q = head.pose.position, head.pose.orientation
            self._last = ((p.x, p.y, p.z), (q.w, q.x, q.y, q.z), True)
        else:
            self._last = (self._last[0], self._last[1], False)
        state, views = xr.locate_views(self.session, xr.ViewLocateInfo(
            view_configuration_type=xr.ViewConfigurationType.PRIMARY_STEREO,
            display_time=display_time, space=self.space))  # fmt: skip
        if len(views) == 2:  # primary stereo: left, then right
            left, right = (EyeFov(v.fov.angle_left, v.fov.angle_right, v.fov.angle_up,
                                  v.fov.angle_down) for v in views)  # fmt: skip
            self._eye_fovs = (left, right)
        self._actions_now = self._read_actions(display_time)
        oriented = state.view_state_flags & xr.ViewStateFlags.ORIENTATION_VALID_BIT
        return views if oriented else ()  # no pose to show the eyes at: no layer

    def _read_actions(self, display_time: int) -> XrActions:
        xr.sync_actions(self.session, xr.ActionsSyncInfo(
            active_action_sets=[xr.ActiveActionSet(self.action_set, xr.NULL_PATH)]))  # fmt: skip
        get = lambda name: xr.ActionStateGetInfo(action=self.xr_actions[name])  # noqa: E731
        move = xr.get_action_state_vector2f(self.session, get("move"))
        run = xr.get_action_state_boolean(self.session, get("run"))
        interact = xr.get_action_state_boolean(self.session, get("interact"))
        stick = (move.current_state.x, move.current_state.y) if move.is_active else (0.0, 0.0)
        return XrActions(stick, bool(run.is_active and run.current_state),
                         bool(interact.is_active and interact.current_state),
                         self._hand_yaw(display_time))  # fmt: skip

    def _hand_yaw(self, display_time: int) -> float | None:
        """The left hand's pointing yaw in the stage [rad, left positive], when tracked."""
        hand = xr.locate_space(self.hand_space, self.space, display_time)
        if not hand.location_flags & xr.SpaceLocationFlags.ORIENTATION_VALID_BIT:
            return None
        q = hand.pose.orientation
        r = quaternion_matrix((q.w, q.x, q.y, q.z))
        forward_x, forward_z = -r[0][2], -r[2][2]  # the aim's −z in stage coordinates
        return math.atan2(-forward_x, -forward_z)  # 0 along the stage's −z, left positive

    def _poll_events(self) -> None:
        while True:
            try:
                event = xr.poll_event(self.instance)
            except xr.EventUnavailable:
                return
            kind = xr.StructureType(event.type)
            if kind == xr.StructureType.EVENT_DATA_SESSION_STATE_CHANGED:
                changed = cast(byref(event), POINTER(xr.EventDataSessionStateChanged)).contents
                self._on_state(xr.SessionState(changed.state))
            elif kind == xr.StructureType.EVENT_DATA_INSTANCE_LOSS_PENDING:
                raise DeviceError("xr backend 'openxr': the runtime is going away (instance "
                                  "loss pending); restart the node once it is back")  # fmt: skip

    def _on_state(self, state: Any) -> None:
        self.session_state = state
        if state == xr.SessionState.READY:
            xr.begin_session(self.session, xr.SessionBeginInfo(
                xr.ViewConfigurationType.PRIMARY_STEREO))  # fmt: skip
            self.running = True
        elif state == xr.SessionState.STOPPING:
            xr.end_session(self.session)
            self.running = False
        elif state in (xr.SessionState.EXITING, xr.SessionState.LOSS_PENDING):
            self.running = False

    def _close(self) -> None:
        for destroy, handle in reversed(self._handles):
            try:
                destroy(handle)
            except xr.exception.XrException:
                pass  # the runtime may already have dropped it; nothing else to free
        self._handles.clear()
        graphics = getattr(self, "graphics", None)
        if graphics is not None:
            graphics.destroy()
