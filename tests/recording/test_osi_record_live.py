"""`carlaverse record --osi` on a live synthetic session: the recording and its OSI trace."""

from __future__ import annotations

import threading
from pathlib import Path

import betterosi

from carlaverse.cli import main
from tests.recording.conftest import World


def test_record_osi_writes_the_ground_truth_beside_the_recording(
    world: World, tmp_path: Path, capsys
) -> None:
    stop = threading.Event()
    publisher = threading.Thread(target=world.synthetic.run, args=(stop,), daemon=True)
    publisher.start()
    out = tmp_path / "live.mcap"
    try:
        argv = ["record", "--session", "rec", "--connect", world.endpoint, "-o", str(out),
                "--duration", "3", "--progress-s", "0", "--osi", "--osi-rate", "10"]  # fmt: skip
        code = main(argv)
    finally:
        stop.set()
        publisher.join(timeout=10)
    err = capsys.readouterr().err
    assert code == 0, err
    trace = tmp_path / "live.osi.mcap"
    assert f"into {trace}" in err.splitlines()[-1], err
    frames = list(betterosi.read(str(trace), return_ground_truth=True))
    assert len(frames) >= 10, "over a second of session at 10 Hz"
    actors = {o.source_reference[0].identifier[0] for f in frames for o in f.moving_object}
    assert actors == {"ego-0", "ego-1"} | {f"npc-{i}" for i in range(6)}
    assert frames[0].lane and frames[-1].traffic_light


def test_without_the_osi_extra_both_commands_name_its_install(tmp_path: Path) -> None:
    # run_uninstalled makes osi3 missing in the command's process as pip would leave it;
    # `record --osi` must say so before it records anything (nothing listens at NOWHERE).
    from tests.cli.test_missing_extras import nowhere, run_uninstalled

    lines = {
        "osi": ["osi", "x.mcap", "-o", "y.mcap"],
        "record": ["record", "--session", "s", "-o", "r.mcap", "--osi", "--connect", nowhere()],
    }
    for command, argv in lines.items():
        done = run_uninstalled(tmp_path, "osi3", *argv)
        assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr[-2000:]
        assert (
            done.stderr.strip()
            == f"carlaverse {command}: needs osi3: pip install 'carlaverse[osi]'"
        )
