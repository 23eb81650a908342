"""`carlaverse swarm`: many egos in one process join, move and leave like real nodes."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

from carlaverse.cli import main
from carlaverse.cli.swarm import add_arguments, settings_from_args
from carlaverse.messages import Pose, decode_pose
from carlaverse.swarm.generator import Swarm, SwarmSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

EGOS = 12


# `--express`: every pose in a frame of its own, as separate machines send; it must reach the
# same observers through the same router.
@pytest.mark.parametrize("framing", [[], ["--express"]], ids=["shared-frames", "express"])
def test_swarm_egos_join_publish_and_leave(cluster: Cluster, framing: list[str]) -> None:
    cluster.router()
    authority = cluster.authority()
    obs = cluster.observer()
    swarm = cluster.start(
        "swarm", "--egos", str(EGOS), "--session", "t", "--connect", cluster.endpoint,
        "--spread", "600", "--duration", "4", "--json", *framing, name="swarm",
    )  # fmt: skip
    ids = {f"swarm-{i}" for i in range(EGOS)}
    wait_until(lambda: obs.update() and ids <= set(obs.world.egos), 30, "every swarm ego")
    now = obs.update()
    for view in obs.world.ego_views(now):
        assert 0.0 <= view.x <= 600.0 and 0.0 <= view.y <= 600.0, view
        assert 8.0 <= math.hypot(view.vx, view.vy) <= 14.0, view  # block loops at town speeds
    assert swarm.wait(30) == 0, swarm.output()
    report = swarm.json()
    assert report["joined"] == EGOS and report["left"] == EGOS, report
    assert report["offered_fraction"] > 0.5, report  # a loaded host may skip slots: no more
    # Leaving on purpose reads as `left` everywhere, never as a loss.
    wait_until(lambda: obs.update() is not None and not ids & set(obs.world.egos), 10, "leaves")
    reasons = {d.actor_id: d.reason for d in obs.world.despawns}
    assert all(reasons[i] == "left" for i in ids), reasons
    assert authority.alive()


def test_swarm_refuses_bad_flags_in_one_line(capsys) -> None:
    assert main(["swarm", "--egos", "0", "--connect", "tcp/127.0.0.1:7447"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "carlaverse swarm: --egos: Expected `int` >= 1 (got 0)", err


@pytest.mark.parametrize(
    ("flags", "said"),
    [(["--rate", "0"], "--rate: Expected `float` > 0.0 (got 0.0)"),
     (["--spread", "-5"], "--spread: Expected `float` > 0.0 (got -5.0)"),
     (["--egos", "20000"], "--egos: Expected `int` <= 10000 (got 20000)"),
     (["--block", "inf"], "--block: Expected `float` <= 100000.0 (got inf)"),
     (["--origin", "1", "nan"], "--origin: Expected `float` >= -10000000.0 (got (1.0, nan))")],
)  # fmt: skip
def test_swarm_names_the_flag_the_user_typed(capsys, flags: list[str], said: str) -> None:
    assert main(["swarm", *flags, "--connect", "tcp/127.0.0.1:7447"]) == 2
    assert capsys.readouterr().err.strip() == f"carlaverse swarm: {said}"


def test_swarm_express_reaches_its_settings() -> None:
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    assert settings_from_args(parser.parse_args(["--express"])).express is True
    assert settings_from_args(parser.parse_args([])).express is False


class _SteppingClock:
    """A local clock that moves on 5 ms at every reading, as a preempted sender's would."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        self.t += 0.005
        return self.t


class _SessionClock:
    """Session time 100 s ahead of the stepping local clock."""

    def __init__(self) -> None:
        self.local = _SteppingClock()

    def now(self) -> float:
        return self.local.now() + 100.0


def test_each_swarm_pose_is_stamped_when_it_is_put_and_placed_for_that_moment() -> None:
    """A slot's poses go out one after the other; a stamp taken once for the slot would
    count the wait behind the slot's earlier puts as every receiver's delay."""
    session = open_session(FabricSettings(connect=[], listen=["tcp/127.0.0.1:0"]))
    heard: list[Pose] = []
    subscriber = session.declare_subscriber(
        "**", lambda sample: heard.append(decode_pose(sample.payload.to_bytes()))
    )
    swarm = Swarm(session, SwarmSettings(egos=6, spread_m=600.0))
    try:
        swarm.members.joined = [True] * 6
        swarm.clock = _SessionClock()  # type: ignore[assignment]
        swarm._send(np.arange(6))
        wait_until(lambda: len(heard) == 6, 10, "the slot's six poses")
    finally:
        subscriber.undeclare()
        session.close()
    # The slot reads the local clock (0.005) and the session clock (100.010) once, then the
    # local clock once per pose (0.015, 0.020, ...): each stamp is its own moment.
    t0, stamps = 100.010, sorted(p.t for p in heard)
    assert stamps == pytest.approx([t0 + 0.005 * k for k in range(2, 8)])
    for pose in heard:
        i = round((pose.t - t0) / 0.005) - 2
        truth = swarm.loops.at(pose.t, np.array([i]))
        # off only across a corner, by at most speed × the time since the group's state
        assert math.hypot(pose.x - truth.x[0], pose.y - truth.y[0]) < 14.0 * (pose.t - t0)
