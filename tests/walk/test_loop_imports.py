"""The walk node's 90 Hz loop process loads what its tick needs, not the network or a renderer.

Its shared-memory contract with the view (`carlaverse.shm_layouts`), its config's `node:` and
`fabric:` settings (`carlaverse.transport.settings`) and its event queue (`loop_events`) import
neither Zenoh nor Panda3D; before, the loop imported Zenoh (and 51 modules of the transport,
world and renderer) for two tuples of eye-field names and `drain`.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

LOOP_MODULES = (
    "carlaverse_nodes.walk.loop_process",
    "carlaverse_nodes.drive.loop_process",
    "carlaverse_nodes.bike.loop_process",
)
HEAVY = ("zenoh", "panda3d", "carlaverse.transport.node_client", "carlaverse.render")


def _loaded_after_import(module: str) -> list[str]:
    # A fresh interpreter: this test process has imported everything already.
    code = (
        "import json, sys\n"
        f"import {module}\n"
        f"print(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    return list(json.loads(done.stdout))


@pytest.mark.parametrize("module", LOOP_MODULES)
def test_a_loop_process_imports_neither_zenoh_nor_panda3d(module: str) -> None:
    # the drive and bike loops share the config settings and `drain`: they stay as light
    assert _loaded_after_import(module) == []
