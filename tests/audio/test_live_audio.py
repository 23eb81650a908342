"""A live node's audio: `join … --audio` in a process of its own, fed by the node's client over
real Zenoh (the authority's scenes only), played on the simulated device at real-time pace;
the real output's absence in one line; underruns counted honestly by the simulated device."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import msgspec
import numpy as np
import pytest
import yaml

from carlaverse import messages as m
from carlaverse.audio.config import AudioConfig
from carlaverse.audio.output import SimulatedOutput
from carlaverse.audio.wav import read_wav
from carlaverse.cli import main
from carlaverse.keys import Keys
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, InProcessAuthority

BLOCK_S = 512 / 48_000  # [s] the shipped configs' block


def engine(name: str, y: float) -> m.AudioEmitter:
    return m.AudioEmitter(name, "engine", 0.0, y, 0.5, 0.0, 0.0, 0.0, 85.0, drive_a=2400.0,
                          drive_b=0.4)  # fmt: skip


def publish_scenes(
    authority: InProcessAuthority, endpoint: str, node_id: str, stop: threading.Event
) -> int:
    """20 scenes a second: the authority's (an engine 8 m north of the map origin), and a
    forger's beside them on the same key (two engines), which the node must not play."""
    session = open_session(FabricSettings(connect=[endpoint]), deadline=time.monotonic() + 30)
    forger = session.declare_publisher(Keys("t").audio(node_id))
    assert authority.authority is not None
    outbox = authority.authority.outbox
    seq = 0
    try:
        while not stop.wait(0.05):
            t = float(seq) / 20
            outbox.audio(node_id, m.AudioScene(seq, t, node_id, [engine("npc1.engine", 8.0)]))
            forged = m.AudioScene(seq, t, node_id, [engine("x1", 2.0), engine("x2", -2.0)])
            forger.put(m.AUDIO_SCENE.encode(forged))
            seq += 1
    finally:
        session.close()
    return seq


def test_a_node_plays_what_it_hears_in_real_time(tmp_path: Path) -> None:
    wav = tmp_path / "played.wav"
    config = tmp_path / "audio.yaml"
    config.write_text(yaml.safe_dump({"layout": "binaural", "output": {
        "backend": "sim", "wav": str(wav)}}))  # fmt: skip
    cluster = Cluster(tmp_path)
    authority = cluster.in_process_authority()
    stop = threading.Event()
    feeder = threading.Thread(
        target=publish_scenes, args=(authority, cluster.endpoint, "car-1", stop)
    )
    try:
        cluster.router()
        authority.start()
        node = cluster.scripted("car-1", None, "--audio", str(config), "--duration", "5")
        feeder.start()
        assert node.wait(90) == 0, node.output()[-2000:]
    finally:
        stop.set()
        if feeder.is_alive():
            feeder.join(timeout=30)
        authority.stop()
        cluster.close()
    summary = node.json()
    audio = summary["extra"]["audio"]
    assert audio["error"] == "" and audio["device"] == "simulated"
    # the authority's scenes, one engine each; every forged one refused by the node's client
    assert audio["scenes"] >= 20 and audio["emitters_max"] == 1, audio
    assert summary["rejected"].get("audio/not_from_authority", 0) >= 20, summary["rejected"]
    assert audio["handover_dropped"] == 0
    # The device ran at real-time pace: every period it played a block or counted a miss.
    periods = audio["playing_s"] / BLOCK_S
    assert audio["blocks"] + audio["underruns"] == pytest.approx(periods, rel=0.1)
    assert audio["underruns"] <= 0.05 * audio["blocks"], audio
    # An update reaches the ear after the queued blocks (3) and one being rendered, or so.
    assert 2 * BLOCK_S * 1e3 <= audio["latency_ms_p50"] <= 12 * BLOCK_S * 1e3, audio
    played, rate = read_wav(wav)
    assert played.shape[1] == 2 and rate == 48_000
    assert np.sqrt(np.mean(played[len(played) // 2 :] ** 2)) > 1e-4  # the engine is heard


def test_without_an_audio_device_the_real_output_fails_in_one_line(
    capsys: pytest.CaptureFixture,
) -> None:
    code = main(["join", "scripted", "--id", "car-9", "--session", "t", "--connect",
                 "tcp/127.0.0.1:9", "--audio", "audio/headphones", "--duration", "1"])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.count("\n") == 0 and "--audio" in err and "PortAudio" in err, err


def test_the_simulated_device_counts_the_blocks_a_stalled_renderer_missed() -> None:
    """Blocks of 0.25 s (4096 at 16 kHz) so that scheduling noise cannot count: the renderer
    keeps the queue fed for 1 s, stalls for 1.5 s, then feeds it again."""
    sim = {"backend": "sim", "prefill_blocks": 2}
    config = msgspec.convert({"sample_rate_hz": 16_000, "block_size": 4096, "output": sim},
                             AudioConfig)  # fmt: skip
    output = SimulatedOutput(config, 2)
    block = np.zeros((4096, 2), dtype=np.float32)
    for _ in range(2):
        output.queue.put(block, None, 1.0)
    output.start()
    try:

        def feed(seconds: float) -> None:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                output.queue.put(block, time.monotonic(), 0.05)

        feed(1.0)
        assert output.underruns == 0
        time.sleep(1.5)  # the renderer stalls: the queue (0.5 s) runs dry, then 4 periods pass
        feed(1.0)
    finally:
        output.close()
    assert 3 <= output.underruns <= 5, output.underruns
