"""What the drive, bike and walk nodes share: a control loop in a child process of their own.

The node (fabric side) creates two shared blocks, `state` (the loop writes, the pose
publisher and views read) and `control` (the node writes: clock offset, spawn, ...), starts
the loop process with a queue for events and one for its final report, and at the end stops
it, takes the report and frees the blocks. The loop side drains its event queue without
waiting (`loop_events.drain`), importing nothing of this module.
"""

from __future__ import annotations

import multiprocessing as mp
import threading
from collections.abc import Callable
from typing import Any

from carlaverse.messages import Pose
from carlaverse.realtime import stop_loop_process
from carlaverse.shm import SharedBlock, block_name
from carlaverse.shm_layouts import OwnPoseBlock
from carlaverse.transport.node_client import NodeClient, PoseSource

PLANAR = ("t", "x", "y", "yaw", "vx", "vy", "ax", "ay")  # pose fields every loop's state has


class LoopHost:
    """Base of a node kind whose control loop runs in a child process (see the module doc).

    `state_layout` and `control_layout` are the blocks' record layouts, `loop_name` names the
    loop in logs; a subclass also has `node_settings`.
    """

    node_settings: Any

    def __init__(self, state_layout: Any, control_layout: Any, loop_name: str) -> None:
        self._layouts = (state_layout, control_layout)
        self._loop_name = loop_name
        self._ctx = mp.get_context("spawn")
        self._state: SharedBlock | None = None
        self._control: SharedBlock | None = None
        # The pose source reads `_state` on the fabric's publisher thread while the node's
        # thread may be closing it: the lock makes "still open" and the read one step.
        self._state_lock = threading.Lock()
        self._process: Any = None
        self._events: Any = None
        self._results: Any = None
        self._stop: Any = None
        self._joins_seen = 0
        self._spawn_seq = 0
        self._loop_summary: dict[str, Any] = {}

    def _start_loop(
        self, session: str, node_id: str, target: Callable[..., None],
        spec: Callable[[str, str], Any], **control_fields: float,
    ) -> None:  # fmt: skip
        """Create the blocks, write the control's first fields, start `target(spec(...))`."""
        state, control_layout = self._layouts
        self._state = SharedBlock(block_name(session, node_id, "state"), state, create=True)
        self._control = SharedBlock(
            block_name(session, node_id, "control"), control_layout, create=True
        )
        self._control.write_fields(**control_fields)
        self._events, self._results = self._ctx.Queue(), self._ctx.Queue()
        self._stop = self._ctx.Event()
        args = (spec(self._state.name, self._control.name), self._events, self._results, self._stop)
        self._process = self._ctx.Process(
            target=target, args=args, name=f"{node_id}-loop", daemon=True
        )
        self._process.start()

    def _tend_loop(self, client: NodeClient, **control_fields: float) -> None:
        """The start of every step: start the loop on the first, hand it the session-clock
        offset (with `control_fields`) and the spawn of a new join."""
        if self._process is None:
            self.start(client.settings.session, client.node_id, client.clock.offset)
        assert self._control is not None
        self._control.write_fields(clock_offset=client.clock.offset, **control_fields)
        self._place_at_spawn(client)

    def _forward(self, inbox: Any) -> int:
        """Move what the fabric queued (impulses, overrides) onto the loop's events; how many."""
        forwarded = 0
        while inbox:
            self._events.put(inbox.popleft())
            forwarded += 1
        return forwarded

    def start(self, session: str, node_id: str, offset: float) -> None:
        raise NotImplementedError  # a node kind starts its own loop through `_start_loop`

    def own_pose_block(self) -> OwnPoseBlock:
        """Where a view reads this node's pose without network delay (the loop's state)."""
        n = self.node_settings
        name = block_name(n.session, n.node_id, "state")
        return OwnPoseBlock(name, self._layouts[0], n.actor_kind, n.extent)

    def pose_source(self) -> PoseSource | None:
        """The loop's newest pose, read from its state block at the pose rate."""

        def source(t: float) -> Pose | None:
            with self._state_lock:
                if self._state is None:
                    return None  # not started, or closed: the node is ending
                s = self._state.read_latest()
            if not s["running"]:
                return None  # no pose before the loop's first tick
            plane: dict[str, Any] = {name: float(s[name]) for name in PLANAR}
            extras: dict[str, Any] = self._pose_extras(s)
            return Pose(0, **plane, **extras)

        return source

    def _loop_pose(self) -> tuple[float, float, float] | None:
        """The loop's x, y [m] and yaw [rad] now (None before its first tick, or closed)."""
        with self._state_lock:
            if self._state is None:
                return None
            s = self._state.read_latest()
        return (float(s["x"]), float(s["y"]), float(s["yaw"])) if s["running"] else None

    def _pose_extras(self, s: Any) -> dict[str, float]:
        """Pose fields beyond the plane the loop reports too (a bike's lean, a car's yaw rate);
        none for a walker: the body stands upright, the head's pitch stays local."""
        return {}

    def _place_at_spawn(self, client: NodeClient) -> None:
        """Hand the loop the spawn of the first join; a re-join keeps the node where it is."""
        reply = client.join_reply
        if reply is None or reply.spawn is None or client.joins == self._joins_seen:
            return
        self._joins_seen = client.joins
        if self._spawn_seq:
            return
        self._spawn_seq += 1
        sp = reply.spawn
        assert self._control is not None
        self._control.write_fields(
            spawn_seq=self._spawn_seq, spawn_x=sp.x, spawn_y=sp.y, spawn_yaw=sp.yaw
        )

    def _stop_loop(self) -> None:
        """Stop the loop, keep its report, free the blocks (once; a later call does nothing)."""
        if self._process is None:
            return
        with self._state_lock:  # the pose source sees None from now on, never a closed block
            state, self._state = self._state, None
        blocks = (state, self._control)
        if self._loop_summary:  # the loop already ended and reported: only reap it
            self._process.join(timeout=5)
            for block in blocks:
                if block is not None:
                    block.close()
        else:
            report = stop_loop_process(
                self._process, self._stop, self._results, blocks, self._loop_name
            )
            self._loop_summary = report or {}
        self._process = None
