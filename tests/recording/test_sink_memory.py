"""A recording of hours holds its memory: what the MCAP writer keeps per chunk until the
file is closed does not grow with the channels in the chunk.

The writer keeps every chunk's index in memory for the summary it writes at the end. With
message indexes, each of those held an entry per channel of the chunk: at 256 egos (a chunk
every ~70 ms, ~256 pose channels each) the recorder grew by 1.4 GB an hour. A real sink,
real chunks, read back.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

from mcap.reader import make_reader

from carlaverse.recording.reading import iter_samples
from carlaverse.recording.sink import McapSink

CHANNELS = 200
CHUNKS = 300
PAYLOAD = b"x" * 290  # about a recorded pose


def test_memory_per_chunk_does_not_grow_with_its_channels(tmp_path: Path) -> None:
    path = tmp_path / "long.mcap"
    sink = McapSink(path, monotonic=lambda: 0.0)
    keys = [f"carlaverse/s/ego/n{i:03d}/pose/0_0" for i in range(CHANNELS)]

    def chunk(k: int) -> None:
        for key in keys:
            sink.write(key, PAYLOAD, 1_000_000_000 + k * 1_000_000)
        sink.flush()

    chunk(0)  # channels and schemas exist before the measurement
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        for k in range(1, CHUNKS + 1):
            chunk(k)
        per_chunk = (tracemalloc.get_traced_memory()[0] - before) / CHUNKS
    finally:
        tracemalloc.stop()
    sink.close()
    # A chunk index with an entry per channel held ~100 B per channel (20 kB here).
    assert per_chunk < 2_000, f"{per_chunk:.0f} B kept per chunk of {CHANNELS} channels"
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and len(summary.chunk_indexes) == CHUNKS + 1
    assert all(not c.message_index_offsets for c in summary.chunk_indexes)
    assert sum(1 for _ in iter_samples(path)) == CHANNELS * (CHUNKS + 1)
