"""Forged keys cannot crowd a real node out of a recording (issue 39 item 7).

The attack: a flood of made-up keys filled the recorder's 4096 keys, and 1002 samples were
refused after it; a real node's next tile would have been among them. Here, on loopback, a
real router, a real authority, a real node (its liveliness token, its poses), a real
`carlaverse record` process, and an outsider's session that puts one sample on each of
`FLOOD` made-up keys -- ids that hold no token, and keys of no known shape -- then stops.
After the flood the node drives into a tile it has not been in: that key is new to the
recorder, and the file read back must hold its poses.

Expected numbers, from docs/protocol.md ("Recording: which keys"): keys of senders without a
token share 512 (`stranger_channels`, 4096 / 8) apart from present senders' 4096, so of the
`FLOOD` forged keys exactly 512 are recorded and the rest refused as `strangers_full`, and
the node's new tile is taken from the present senders' room, which the flood never touched.
"""

from __future__ import annotations

import re
import threading
from pathlib import Path

import zenoh

from carlaverse import messages as m
from carlaverse.keys import TILE_SIZE_M, Keys
from carlaverse.recording.reading import iter_samples, read_metadata
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, Proc, wait_until

K = Keys("t")
FLOOD = 5000  # forged keys: more than the 4096 a recording took in all before
STRANGER_SHARE = 4096 // 8  # docs/protocol.md: keys of senders without a token, together
WRITTEN = re.compile(r"^recording: (\d+) messages")
REJECTED = re.compile(r", (\d+) rejected")


def _progress(recorder: Proc) -> tuple[int, int]:
    """(messages written, samples rejected) from the recorder's last progress line."""
    lines = [line for line in recorder.output().splitlines() if WRITTEN.match(line)]
    if not lines:
        return 0, 0
    rejected = REJECTED.search(lines[-1])
    return int(WRITTEN.match(lines[-1])[1]), int(rejected[1]) if rejected else 0  # type: ignore[index]


def _judged(recorder: Proc) -> int:
    """Samples the recorder has written or refused."""
    return sum(_progress(recorder))


class Rider:
    """Poses of a real node at an x the test moves (tile t<⌊x / 250 m⌋>_0)."""

    def __init__(self) -> None:
        self.x = 10.0  # [m]
        self.lock = threading.Lock()

    def pose(self, t: float) -> m.Pose:
        with self.lock:
            return m.Pose(0, t, self.x, 10.0)

    def move_to(self, x: float) -> None:
        with self.lock:
            self.x = x


def _forged_keys(n: int) -> list[str]:
    """Keys no present node owns: ids that hold no token, and keys of no known shape."""
    out = []
    for i in range(n):
        if i % 3 == 0:
            out.append(K.pose(f"forged-{i}", "t0_0"))
        elif i % 3 == 1:
            out.append(K.state(f"ghost{i}"))
        else:
            out.append(f"{K.prefix}/junk/{i}")
    return out


def test_a_flood_of_forged_keys_cannot_keep_a_real_nodes_new_tile_out(
    cluster: Cluster, tmp_path: Path
) -> None:
    mcap = tmp_path / "flood.mcap"
    cluster.router()
    cluster.in_process_authority().start()
    recorder = cluster.start(
        "record", "--session", "t", "--connect", cluster.endpoint, "-o", str(mcap),
        "--progress-s", "0.1", name="recorder",
    )  # fmt: skip
    wait_until(lambda: "recording session t" in recorder.output(), 30, "the recorder to listen")
    rider = Rider()
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    node = NodeClient(session, NodeSettings(node_id="rider", session="t"), MonotonicClock())
    cluster.sessions.append(node)
    node.start(pose_source=rider.pose)
    assert node.wait_joined(10)
    # the rider's token, state and first tile are recorded before the flood starts
    wait_until(lambda: _progress(recorder)[0] > 50, 20, "the rider's poses in the recording")

    outsider = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(outsider)
    before = _judged(recorder)
    for key in _forged_keys(FLOOD):  # bounded: one sample per key, then it stops
        outsider.put(key, b"forged", congestion_control=zenoh.CongestionControl.BLOCK)
    # the rider's poses count too, so this holds at the latest once the flood is judged
    wait_until(lambda: _judged(recorder) >= before + FLOOD, 60, "the flood judged")

    # into the middle of t1_0 (past the 25 m a node may keep its old tile): a new key
    rider.move_to(1.5 * TILE_SIZE_M)
    after = _judged(recorder)
    # 50 Hz: a second of poses, all on the new tile but the first few
    wait_until(lambda: _judged(recorder) >= after + 50, 20, "the rider's poses after the flood")
    assert recorder.stop() == 0, recorder.output()[-2000:]

    keys = {s.key for s in iter_samples(mcap)}
    assert K.pose("rider", "t1_0") in keys, "the real node's new tile was kept out"
    forged = keys & set(_forged_keys(FLOOD))
    assert 0 < len(forged) <= STRANGER_SHARE
    summary = read_metadata(mcap)["carlaverse.summary"]
    assert summary.get("rejected_strangers_full") == str(FLOOD - len(forged)), summary
    assert "rejected_present_full" not in summary and "rejected_sender_full" not in summary
