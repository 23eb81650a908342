"""User errors are one line naming the value and the fix, exit code 2, never Rust internals."""

from __future__ import annotations

import threading
import time

import pytest

from carlaverse.cli import main
from carlaverse.transport.session import (
    CLIENT_ATTEMPT_MS,
    FabricError,
    FabricSettings,
    FabricUnreachable,
    check_endpoint,
    open_session,
    zenoh_reason,
)
from tests.support import free_port

RUST_INTERNALS = (".rs:", "Json5Err", "Location {", "Traceback", "Single(")


@pytest.mark.parametrize(
    "endpoint",
    ["tcp/127.0.0.1:7447", "tls/localhost:7447", "quic/[::1]:7447", "udp/10.0.0.1:1",
     "tcp/router.example.org:7447?iface=eth0", "tls/h:7447#root_ca_certificate=ca.pem",
     "unixsock-stream//tmp/zenoh.sock"],
)  # fmt: skip
def test_good_endpoints_pass(endpoint: str) -> None:
    check_endpoint(endpoint)


@pytest.mark.parametrize(
    ("endpoint", "says"),
    [
        ("127.0.0.1:7447", "expected tcp/udp/tls/quic/ws/HOST:PORT"),
        ("tcp/127.0.0.1", "expected tcp/HOST:PORT"),
        ("tcp/:7447", "expected tcp/HOST:PORT"),
        ("foo/1.2.3.4:5", "expected tcp/udp/tls/quic/ws/HOST:PORT"),
        ("tcp/127.0.0.1:99999", "port must be 1-65535"),
        ("tcp/127.0.0.1:0", "port must be 1-65535"),
        ("tcp/a b:7447", "expected tcp/HOST:PORT"),
    ],
)
def test_bad_endpoints_are_named_with_the_expected_form(endpoint: str, says: str) -> None:
    with pytest.raises(FabricError) as err:
        check_endpoint(endpoint)
    assert repr(endpoint) in str(err.value) and says in str(err.value)


def test_port_zero_is_fine_to_listen_on() -> None:
    check_endpoint("tcp/127.0.0.1:0", "listen")


def test_zenoh_reasons_lose_the_rust_wrapping() -> None:
    raw = (
        'Json5Err(Message { msg: "Endpoints must be of the form <protocol>/<address>: x at '
        '/root/.cargo/git/zenoh/src/endpoint.rs:615.", location: Some(Location { line: 1 }) }) '
        "at /root/.cargo/git/zenoh/src/api/config.rs:86."
    )
    assert (
        zenoh_reason(RuntimeError(raw)) == "Endpoints must be of the form <protocol>/<address>: x"
    )
    timeout = (
        "Unable to connect to any of [Single(tcp/127.0.0.1:1)]. Timeout! at "
        "/root/.cargo/git/zenoh/src/net/runtime/orchestrator.rs:388."
    )
    assert (
        zenoh_reason(RuntimeError(timeout))
        == "Unable to connect to any of tcp/127.0.0.1:1. Timeout"
    )
    assert zenoh_reason(RuntimeError('Str("unknown key")')) == "unknown key"


COMMANDS = {
    "join": ["join", "observer", "--id", "o"],
    "stats": ["stats", "--duration", "1"],
    "view": ["view", "--session", "s", "--save", "x.rrd"],
    "authority": ["authority", "--scenario", "none"],
    "router": ["router"],
}


@pytest.mark.parametrize("flag", ["--connect", "--listen"])
@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_malformed_endpoint_is_one_line_and_exit_2(
    command: str, flag: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([*COMMANDS[command], flag, "127.0.0.1:7447"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"carlaverse {command}: bad {flag} endpoint '127.0.0.1:7447'"), err
    assert not any(bit in err for bit in RUST_INTERNALS), err


@pytest.mark.parametrize(
    ("yaml", "says"),
    [
        (
            "fabric:\n  zenoh:\n    transport/nonsense: 1\n",
            "carlaverse join: invalid zenoh setting transport/nonsense = 1: unknown key",
        ),
        (
            "node:\n  pose_digest: true\n",
            "carlaverse join: {config}: pose_digest carries the whole session's poses: set "
            "interest_radius_m: 0 to use it (it is 200)",
        ),
    ],
    ids=["zenoh-entry", "pose-digest-with-interest"],
)
def test_a_bad_config_entry_is_one_line_naming_it(
    yaml: str, says: str, tmp_path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "car.yaml"
    config.write_text(yaml)
    assert main(["join", "scripted", "--id", "c", "--config", str(config)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(says.format(config=config)), err
    assert not any(bit in err for bit in RUST_INTERNALS), err


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--id", "bad/id"], "invalid observer id (--id) 'bad/id'"),
        (["--id", "authority"], "'authority' is the authority's"),
        (["--session", "a b"], "invalid session name 'a b'"),
    ],
)
def test_stats_with_a_bad_id_or_session_is_one_line_and_exit_2(
    args: list[str], says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["stats", *args, "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("carlaverse stats: ") and says in err, err


def _dead_client() -> FabricSettings:
    return FabricSettings(mode="client", connect=[f"tcp/127.0.0.1:{free_port()}"])


def test_a_client_gives_up_at_its_deadline_and_says_what_it_waits_for() -> None:
    said: list[str] = []
    started = time.monotonic()
    with pytest.raises(FabricUnreachable):
        open_session(_dead_client(), deadline=started + 2.5, on_wait=said.append)
    took = time.monotonic() - started
    # the deadline is checked every 50 ms; giving up waits for the attempt in flight (at most
    # CLIENT_ATTEMPT_MS): a process must not exit while a thread is inside zenoh.open
    assert 2.5 <= took < 2.5 + CLIENT_ATTEMPT_MS / 1e3 + 0.5, took
    assert len(said) == 1 and said[0].startswith("waiting for a router at tcp/127.0.0.1:")
    assert CLIENT_ATTEMPT_MS <= 1000  # what keeps the first line within ~1 s


def test_a_waiting_client_stops_within_one_attempt_when_told() -> None:
    stop = threading.Event()
    threading.Timer(0.3, stop.set).start()
    started = time.monotonic()
    with pytest.raises(FabricUnreachable):
        open_session(_dead_client(), stop=stop)
    # at most the rest of the attempt in flight, never a further one
    assert time.monotonic() - started < 0.3 + CLIENT_ATTEMPT_MS / 1e3 + 0.5


def test_a_client_told_nothing_tries_once_and_says_why() -> None:
    """Library callers (and the refusal tests) get one attempt and a readable FabricError."""
    settings = _dead_client()
    started = time.monotonic()
    with pytest.raises(FabricError) as err:
        open_session(settings)
    assert not isinstance(err.value, FabricUnreachable)
    assert time.monotonic() - started < CLIENT_ATTEMPT_MS / 1e3 + 1.0
    assert f"Unable to connect to any of {settings.connect[0]}" in str(err.value)
    assert not any(bit in str(err.value) for bit in RUST_INTERNALS), err.value


@pytest.mark.parametrize(
    ("flag", "value", "says"),
    [
        ("--tick-priority", "120", "120 is out of range: 0 (normal) or 1-99"),
        ("--tick-priority", "high", "'high' is not a whole number"),
        ("--digest-ms", "-1", "-1 is out of range: 0 (off) to 1000 ms"),
        ("--digest-ms", "2ms", "'2ms' is not a number (0 (off) to 1000 ms)"),
    ],
)
def test_a_bad_authority_number_names_the_flag_and_the_range(
    flag: str, value: str, says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["authority", "--scenario", "none", flag, value])
    assert exited.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith(f"carlaverse authority: error: argument {flag}: "), last
    assert says in last, last
