"""A synthetic world to view, and a reader for .rrd files."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyarrow as pa
import pytest
import rerun.chunk as rrc

from carlaverse.keys import Keys
from carlaverse.recording.synthetic import SyntheticSession, SyntheticSpec
from carlaverse.transport.session import FabricSettings, open_session
from tests.recording.conftest import World
from tests.support import free_port

SKIP_COLUMNS = {"log_time", "rerun.controls.RowId"}


@pytest.fixture
def world() -> Iterator[World]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = open_session(FabricSettings(listen=[endpoint]))
    spec = SyntheticSpec(egos=2, npcs=5, reliable_state=True)
    synthetic = SyntheticSession(session, Keys("view"), spec, keep_payloads=True)
    synthetic.serve_queries()
    try:
        yield World(endpoint, session, synthetic)
    finally:
        synthetic.close()
        session.close()


def rrd_rows(path: Path) -> dict[str, list[dict[str, Any]]]:
    """Entity path -> its rows: {'sim_time': s | None, 'static': bool, component: values};
    every timeline of durations (sim_time, a recording's from_start) in seconds."""
    out: dict[str, list[dict[str, Any]]] = {}
    for chunk in rrc.RrdReader(path).stream():
        batch = chunk.to_record_batch()
        columns = {}
        for name in batch.schema.names:
            if name in SKIP_COLUMNS:
                continue
            col = batch.column(name)
            if name == "sim_time" or pa.types.is_duration(col.type):  # e.g. from_start
                columns[name] = [
                    None if v is None else v / 1e9 for v in col.cast(pa.int64()).to_pylist()
                ]
            else:
                columns[name] = col.to_pylist()
        for i in range(batch.num_rows):
            row = {name: values[i] for name, values in columns.items()}
            row["static"] = chunk.is_static
            out.setdefault(chunk.entity_path, []).append(row)
    for rows in out.values():
        rows.sort(key=lambda r: r.get("sim_time") or 0.0)
    return out
