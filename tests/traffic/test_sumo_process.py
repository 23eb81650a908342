"""SUMO in a process of its own: the same traffic as in-process, at most one step behind,
errors that name what failed, and a child that never outlives its authority."""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.traffic.engine import NpcFrame
from carlaverse.traffic.netbuild import build_map
from carlaverse.traffic.scenario import load_scenario
from carlaverse.traffic.sumo_engine import SumoEngine, SumoSettings
from carlaverse.traffic.sumo_process import SumoProcess, SumoProcessError
from tests.support import Cluster, wait_until
from tests.traffic.helpers import (
    CROSSING_MAP,
    FOLLOWER,
    T0,
    domain_of,
    npc_row,
    run,
    write_scenario,
)

BUSY = "traffic:\n  vehicles: {count: 12}\n  pedestrians: {count: 6}\n  step_length_s: 0.1\n"


def settings_of(tmp_path: Path, net_cache: Path, body: str, seed: int = 7) -> SumoSettings:
    scenario = load_scenario(write_scenario(tmp_path, CROSSING_MAP + body))
    net = build_map(scenario, net_cache).net
    return SumoSettings(net, seed, scenario.spec.step_length_s, scenario.spec.traffic)


def frame_at(engine: SumoProcess, t: float, timeout_s: float = 30.0) -> NpcFrame:
    """The process engine's frame once the step reaching engine time t has come back."""
    deadline = time.monotonic() + timeout_s
    while (frame := engine.last_read()).t < t - 1e-9:
        assert time.monotonic() < deadline, f"no frame of t={t} within {timeout_s} s"
        time.sleep(0.001)
    return frame


def is_gone(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return True
    return state in ("Z", "X")  # a zombie nobody reaped has exited too


def test_same_traffic_as_in_process_each_step(tmp_path: Path, net_cache: Path) -> None:
    settings = settings_of(tmp_path, net_cache, BUSY)
    local = SumoEngine(settings)
    try:
        expected = []
        for _ in range(80):
            local.step()
            expected.append(local.npcs())
    finally:
        local.close()
    remote = SumoProcess(settings)
    try:
        got = []
        for _ in range(80):
            remote.step()
            got.append(frame_at(remote, remote.time_s))
    finally:
        remote.close()
    assert sum(len(f) for f in expected) > 200  # traffic was there to compare
    for want, have in zip(expected, got, strict=True):
        assert have.t == pytest.approx(want.t)
        assert have.ids == want.ids
        np.testing.assert_array_equal(have.rows, want.rows)


def test_npcs_are_never_more_than_one_step_old(tmp_path: Path, net_cache: Path) -> None:
    engine = SumoProcess(settings_of(tmp_path, net_cache, BUSY))
    try:
        for _ in range(60):
            engine.step()  # the step before has come back by now, whatever the timing
            assert engine.last_read().t >= engine.time_s - 2 * engine.step_length_s + 1e-9
        assert frame_at(engine, engine.time_s).t == pytest.approx(engine.time_s)
        assert set(engine.counters()) == {"failed_routes", "ego_failures", "sumo_late_steps"}
    finally:
        engine.close()


def test_a_refused_call_names_the_cause_and_stepping_goes_on(
    tmp_path: Path, net_cache: Path
) -> None:
    engine = SumoProcess(settings_of(tmp_path, net_cache, BUSY))
    try:
        engine.step()
        with pytest.raises(ValueError, match="no traffic light 'nope'"):
            engine.set_light_state("nope", "r")
        with pytest.raises(ValueError, match="cannot release ghost"):
            engine.release_npc("ghost")
        light = engine.light_readings()[0]
        engine.set_light_state(light.id, "r" * len(light.state))
        assert engine.light_readings()[0].state == "r" * len(light.state)  # seen at once
        engine.step()
        assert frame_at(engine, engine.time_s).t == pytest.approx(2 * engine.step_length_s)
    finally:
        engine.close()


def test_traffic_that_does_not_fit_is_refused_at_start(tmp_path: Path, net_cache: Path) -> None:
    body = "traffic:\n  scripted_vehicles:\n    - {id: lost, edges: [NOWHERE]}\n"
    with pytest.raises(ValueError, match="traffic does not fit the network"):
        SumoProcess(settings_of(tmp_path, net_cache, body))


def test_a_killed_sumo_process_is_reported_not_waited_for(tmp_path: Path, net_cache: Path) -> None:
    engine = SumoProcess(settings_of(tmp_path, net_cache, BUSY))
    os.kill(engine.pid, signal.SIGKILL)
    started = time.monotonic()
    with pytest.raises(SumoProcessError, match=r"exited \(code -9\) while stepping"):
        for _ in range(3):
            engine.step()
    assert time.monotonic() - started < 10.0
    engine.close()  # closing a dead one is quiet


def test_closing_ends_the_child(tmp_path: Path, net_cache: Path) -> None:
    engine = SumoProcess(settings_of(tmp_path, net_cache, BUSY))
    engine.step()
    engine.close()
    assert is_gone(engine.pid)
    with pytest.raises(SumoProcessError, match="closed"):
        engine.step()


def test_sumo_does_not_outlive_an_authority_that_dies(tmp_path: Path, net_cache: Path) -> None:
    settings = settings_of(tmp_path, net_cache, BUSY)
    script = (
        "import os, pickle, sys\n"
        "from carlaverse.traffic.sumo_process import SumoProcess\n"
        "engine = SumoProcess(pickle.loads(sys.stdin.buffer.read()))\n"
        "print(engine.pid, flush=True)\n"
        "os._exit(0)  # no close, no atexit: as a crash would leave it\n"
    )

    done = subprocess.run(
        [sys.executable, "-c", script],
        input=pickle.dumps(settings),
        capture_output=True,
        timeout=120,
        check=True,
    )
    child = int(done.stdout.split()[-1])
    deadline = time.monotonic() + 20.0
    while not is_gone(child):
        assert time.monotonic() < deadline, f"SUMO process {child} outlived its authority"
        time.sleep(0.05)


def test_domain_on_the_process_drives_the_same_car(tmp_path: Path, net_cache: Path) -> None:
    """Through the whole domain: the follower is where the in-process run puts it, though
    its frames come one step later (the domain dead-reckons them to its tick)."""
    path = write_scenario(tmp_path, CROSSING_MAP + FOLLOWER)
    rows = {}
    for separate in (False, True):
        with domain_of(path, net_cache, sumo_process=separate) as domain:
            out = MemoryOutbox()
            run(domain, out, T0, 6.0, every=lambda t: time.sleep(0.002))
            rows[separate] = npc_row(out.npcs[-1], "follower")
    assert rows[True]["x"] == pytest.approx(rows[False]["x"], abs=0.3)
    assert rows[True]["y"] == pytest.approx(rows[False]["y"], abs=0.05)
    assert rows[True]["vx"] == pytest.approx(rows[False]["vx"], abs=0.5)


def test_the_domain_never_waits_for_sumo_s_process(
    tmp_path: Path, net_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ticks as fast as the loop goes (far faster than SUMO answers): a tick whose step is
    not back yet leaves stepping to a later tick instead of waiting for it."""
    with domain_of(
        write_scenario(tmp_path, CROSSING_MAP + BUSY), net_cache, sumo_process=True
    ) as domain:
        engine = domain.engine
        assert isinstance(engine, SumoProcess)

        def refuse() -> None:
            raise AssertionError("a tick waited for SUMO's process")

        monkeypatch.setattr(engine, "_await_step", refuse)
        out = MemoryOutbox()
        run(domain, out, T0, 10.0)
        assert domain.stats.steps > 0 and engine.late_steps == 0
        assert domain.stats.steps + domain.stats.deferred_steps > 0


def sumo_children(pid: int) -> list[int]:
    """The SUMO processes a process started (from /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            command = (stat.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if int(fields[1]) == pid and b"carlaverse.traffic.sumo_process" in command:
            found.append(int(stat.parent.name))
    return found


def test_an_authority_whose_sumo_dies_says_so_in_a_line_and_exits(cluster: Cluster) -> None:
    cluster.router()
    authority = cluster.authority("--scenario", "crossing")
    wait_until(lambda: "ticking at" in authority.output(), 90, "the authority to tick")
    (child,) = sumo_children(authority.proc.pid)
    os.kill(child, signal.SIGKILL)
    assert authority.wait(30) == 1
    err = "".join(authority.stderr)
    assert "carlaverse authority: traffic stopped: the SUMO process exited (code -9) while " in err
    assert "Traceback" not in err, err
