"""`carlaverse ros2`: its arguments, in-process; a bad one is one line naming it, exit 2."""

from __future__ import annotations

import pytest

from carlaverse.cli import main
from carlaverse.cli.exit_codes import Exit


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["av", "--id", "av-1", "--odom-topic", "av/odom"], "odom_topic 'av/odom'"),
        (["av", "--id", "av-1", "--extent", "4.5,1.8"], "--extent: '4.5,1.8'"),
        (["av", "--id", "av-1", "--extent", "4.5,-1,1.5"], "between 0 and 50 m"),
        (["av"], "no node id"),
        (["view", "--domain", "300"], "domain_id"),
        (["view", "--prefix", "carlaverse"], "prefix 'carlaverse'"),
        (["view", "--id", "bad id"], "invalid node id 'bad id'"),
    ],
)  # fmt: skip
def test_a_bad_argument_is_one_line_naming_it(
    argv: list[str], says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["ros2", *argv, "--connect", "tcp/127.0.0.1:9"]) == Exit.USAGE
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("carlaverse ros2 ")
    assert says in err


def test_help_names_the_roles_and_the_doc(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        main(["ros2", "--help"])
    assert done.value.code == 0
    out = capsys.readouterr().out
    assert "rmw_zenoh" in out and "view" in out and "av" in out
    assert "docs/protocol.md" in out


def test_no_world_leaves_the_world_to_a_view_in_the_same_domain() -> None:
    import argparse

    from carlaverse.cli import ros2

    parser = argparse.ArgumentParser()
    ros2.add_arguments(parser)
    argv = ["av", "--id", "av-1", "--odom-topic", "/car/odom", "--connect", "tcp/127.0.0.1:9"]
    config = ros2._config(parser.parse_args([*argv, "--no-world"]))
    assert (config.av.odom_topic, config.av.world) == ("/car/odom", False)
    assert ros2._config(parser.parse_args(argv)).av.world


def test_an_av_without_odometry_never_joins(capsys: pytest.CaptureFixture[str]) -> None:
    """It waits for its stack's first odometry before joining: none within --duration is
    exit 5 and one line naming the topic (no router is needed to find that out)."""
    argv = ["ros2", "av", "--id", "av-1", "--odom-topic", "/quiet/odom", "--duration", "3",
            "--connect", "tcp/127.0.0.1:9"]  # fmt: skip
    assert main(argv) == Exit.NOT_ADMITTED
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == (
        "carlaverse ros2 av: no odometry on /quiet/odom (ROS_DOMAIN_ID 0): never joined"
    )
