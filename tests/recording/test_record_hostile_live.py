"""A running `carlaverse record` under hostile payloads on real Zenoh, and on a full disk.

The recorder must write every sample it receives (raw when it does not decode), keep its
memory bounded, finish a readable file and exit 0; and when it cannot write any more, say
so and exit non-zero by itself instead of printing a count that no longer moves.
"""

from __future__ import annotations

import os
import re
import resource
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.recording.reading import is_finished, iter_samples, read_metadata
from carlaverse.transport.session import FabricSettings, open_session
from tests.recording.hostile import hostile_payloads
from tests.support import Cluster, Proc, wait_until

K = Keys("h")
STORM_ROUNDS = 600  # x 17 payloads: ~10,000 hostile samples
RELIABLE = {
    "congestion_control": zenoh.CongestionControl.BLOCK,
    "reliability": zenoh.Reliability.RELIABLE,
}


def _written(proc: Proc) -> int:
    counts = re.findall(r"recording: (\d+) messages", proc.output())
    return int(counts[-1]) if counts else 0


def _rss_mib(pid: int) -> float:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(r"VmRSS:\s+(\d+) kB", status).group(1)) / 1024  # type: ignore[union-attr]


class Publisher:
    """One reliable publisher per key, and what was put on each, in order."""

    def __init__(self, session: zenoh.Session, keys: list[str]) -> None:
        self.publishers = {k: session.declare_publisher(k, **RELIABLE) for k in set(keys)}
        self.sent: list[tuple[str, bytes]] = []

    def matched(self) -> bool:
        return all(p.matching_status.matching for p in self.publishers.values())

    def put(self, key: str, payload: bytes) -> None:
        self.publishers[key].put(payload)
        self.sent.append((key, payload))


def test_a_live_recorder_keeps_every_hostile_sample_and_stays_bounded(
    cluster: Cluster, tmp_path: Path
) -> None:
    mcap = tmp_path / "storm.mcap"
    router = cluster.router()
    wait_until(lambda: "listening" in router.output() or not router.alive(), 20, "the router")
    recorder = cluster.start(
        "record", "--session", "h", "--connect", cluster.endpoint, "-o", str(mcap),
        "--progress-s", "0.2", "--queue-mib", "64", name="recorder",
    )  # fmt: skip
    full = hostile_payloads(K)
    storm = hostile_payloads(K, depth=2_000, garbage_bytes=20_000)
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    try:
        pub = Publisher(session, [k for k, _, _ in full] + [K.pose("good", "t0_0")])
        wait_until(pub.matched, 20, "the recorder subscribed to every key")
        for i, (key, payload, _) in enumerate(full * 3):
            pub.put(K.pose("good", "t0_0"), m.encode_pose(m.Pose(i, 1.0 + i, 0.0, 0.0)))
            pub.put(key, payload)
        wait_until(lambda: _written(recorder) >= len(pub.sent), 60, "the hostile set written")
        rss_before = _rss_mib(recorder.proc.pid)
        started = time.monotonic()
        for key, payload, _ in storm * STORM_ROUNDS:
            pub.put(key, payload)
        wait_until(lambda: _written(recorder) >= len(pub.sent), 120, "the storm written")
        storm_s = time.monotonic() - started
        rss_after = _rss_mib(recorder.proc.pid)
    finally:
        session.close()
    assert recorder.stop() == 0, recorder.output()[-3000:]

    storm_n = len(storm) * STORM_ROUNDS
    print(f"\nstorm: {storm_n} hostile samples in {storm_s:.2f} s = {storm_n / storm_s:.0f} msg/s "
          f"recorded; recorder RSS {rss_before:.0f} -> {rss_after:.0f} MiB")  # fmt: skip
    assert rss_after - rss_before < 100, "memory grows with the storm"
    assert "Traceback" not in recorder.output()
    assert is_finished(mcap)
    samples = [
        (s.key, s.payload) for s in iter_samples(mcap) if not s.key.startswith(K.prefix + "/node")
    ]
    assert samples == pub.sent  # continuous: every sample, in order, byte for byte
    summary = read_metadata(mcap)["carlaverse.summary"]
    assert (summary["received"], summary["dropped"], summary["rejected"]) == (
        str(len(pub.sent)), "0", "0",
    )  # fmt: skip
    per_key = Counter(k for k, _ in samples)
    assert per_key == Counter(k for k, _ in pub.sent)


def _limit_file_size(limit_bytes: int) -> None:
    """In the child: writes past `limit_bytes` fail with EFBIG (Python ignores SIGXFSZ)."""
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))


def test_a_recorder_that_cannot_write_says_so_and_exits_non_zero(
    cluster: Cluster, tmp_path: Path
) -> None:
    router = cluster.router()
    wait_until(lambda: "listening" in router.output() or not router.alive(), 20, "the router")
    argv = [
        sys.executable, "-m", "carlaverse", "record", "--session", "h", "--connect",
        cluster.endpoint, "-o", str(tmp_path / "full.mcap"), "--chunk-kib", "16",
        "--progress-s", "0.2",
    ]  # fmt: skip
    err_file = (tmp_path / "stderr.txt").open("w")
    recorder = subprocess.Popen(argv, stderr=err_file, preexec_fn=lambda: _limit_file_size(200_000))
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    stop = threading.Event()
    try:
        pub = Publisher(session, [K.pose("a", "t0_0")])
        wait_until(pub.matched, 20, "the recorder subscribed")
        feeder = threading.Thread(target=_feed, args=(pub, stop), daemon=True)
        feeder.start()
        code = recorder.wait(timeout=60)  # it must stop by itself: nobody signals it
    finally:
        stop.set()
        if recorder.poll() is None:
            recorder.send_signal(signal.SIGKILL)
        session.close()
        err_file.close()
    err = (tmp_path / "stderr.txt").read_text()
    assert code == 1, err[-2000:]
    assert "RECORDING FAILED" in err and "File too large" in err, err[-2000:]
    assert "Traceback" not in err


def _feed(pub: Publisher, stop: threading.Event) -> None:
    i = 0
    publisher = pub.publishers[K.pose("a", "t0_0")]
    while not stop.is_set():
        publisher.put(m.encode_pose(m.Pose(i, float(i), 0.0, 0.0)) + os.urandom(200))
        i += 1
        if i % 100 == 0:
            stop.wait(0.01)
