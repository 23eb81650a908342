"""The Bluetooth FTMS transport against a real trainer: runs only with `pytest --hardware`.

Needs a powered FTMS trainer in range (and BlueZ); the first device advertising 0x1826 is used,
or the one named by CARLAVERSE_FTMS_NAME.
"""

from __future__ import annotations

import os

import pytest

from carlaverse.hal import open_trainer
from tests.support import wait_until

pytestmark = pytest.mark.hardware


def test_a_real_trainer_takes_control_reports_data_and_takes_resistance() -> None:
    pytest.importorskip("bleak", reason="pip install 'carlaverse[bike]'")
    name = os.environ.get("CARLAVERSE_FTMS_NAME", "")
    trainer = open_trainer({"backend": "ftms", "options": {"name": name, "scan_timeout_s": 15}})
    try:
        wait_until(lambda: trainer.in_control, 30, "the trainer granting control (0x80 00 01)")
        wait_until(lambda: trainer.counters["bike_data"] >= 3, 10, "Indoor Bike Data (0x2AD2)")
        trainer.set_resistance(20.0)
        wait_until(
            lambda: any(r.op == 0x04 and r.ok for r in trainer.responses), 5, "resistance ack"
        )
        state = trainer.read()
        assert state.speed_mps is not None and state.speed_mps >= 0.0
        assert not trainer.counters["bad_bike_data"]
    finally:
        trainer.close()
