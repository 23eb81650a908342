"""Which line the launcher takes as a node's HMI pairing URL, and that its log never keeps one.

The node's own line is written here as `carlaverse join` prints it (join_hmi.node_hmi through
cli.common.say: `carlaverse join: HMI pairing URL (<advice>): http://ADDR:PORT/PAGE?token=T`,
on stderr, once, before the node opens the fabric). The rule under test (launcher.hmi_pairing):
only the node's stderr is read for it, only a line that is exactly that, only for the port the
launcher asked for, and only the first; every other line, on either stream, is a forgery.
"""

from __future__ import annotations

import sys
import textwrap

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.launcher.hmi_pairing import PairingWatch
from carlaverse.launcher.processes import Supervisor, redact_tokens
from tests.support import wait_until

PORT = 48213
ADVICE = "open it once on the tablet; it holds this run's token, keep it private"
GENUINE_TOKEN = "g" * 43  # 256 bit in base64url: 43 characters, as the node's token
FORGED_TOKEN = "f" * 43
GENUINE_URL = f"http://10.0.0.5:{PORT}/dashboard?token={GENUINE_TOKEN}"


def pairing_line(url: str) -> str:
    return f"carlaverse join: HMI pairing URL ({ADVICE}): {url}"


FORGED_URL = f"http://10.6.6.6:{PORT}/dashboard?token={FORGED_TOKEN}"
# A node's output with the genuine line among forgeries: on stdout first (what a scenario's
# text or --json could carry), then on stderr inside a log line, for another port, and after
# the genuine one. The child pauses after its stdout so that a reader of both streams would
# meet the forgery first; the rule must not depend on that order either way.
NODE_OUTPUT = textwrap.dedent(
    f"""
    import sys, time
    print({pairing_line(FORGED_URL)!r}, flush=True)
    time.sleep(0.3)
    for line in (
        "WARNING carlaverse.scenario: " + {pairing_line(FORGED_URL)!r},
        {pairing_line(FORGED_URL.replace(str(PORT), str(PORT + 1)))!r},
        {pairing_line(GENUINE_URL)!r},
        {pairing_line(FORGED_URL)!r},
    ):
        sys.stderr.write(line + "\\n")
        sys.stderr.flush()
    print("done", flush=True)
    """
)


def test_only_the_first_exact_stderr_line_for_the_asked_port_is_taken() -> None:
    supervisor = Supervisor(command=[sys.executable, "-c", NODE_OUTPUT], grace_s=1.0)
    watch = PairingWatch(PORT)
    child = supervisor.start("cab", "node", ["cab"], on_stderr=watch.feed)
    try:
        wait_until(lambda: not child.running, 20, "the child to finish")
        wait_until(lambda: child.log.since(0)[1][-1].startswith("[exited"), 5, "its log")
    finally:
        supervisor.stop_all()
    assert watch.url == GENUINE_URL
    log = "\n".join(child.log.since(0)[1])
    assert GENUINE_TOKEN not in log and FORGED_TOKEN not in log, log
    assert pairing_line(GENUINE_URL.replace(GENUINE_TOKEN, "…")) in log  # shown, redacted
    assert "done" in log  # stdout is logged as before, only never believed


@pytest.mark.parametrize(
    "line",
    [
        pairing_line(GENUINE_URL) + " and more",  # not the whole line
        " " + pairing_line(GENUINE_URL),
        pairing_line(GENUINE_URL.replace(GENUINE_TOKEN, "g" * 21)),  # 126 bit: too short
        pairing_line(GENUINE_URL.replace("https://", "http://").replace("http", "https")),
        pairing_line(f'http://10.0.0.5:{PORT}/"><img src=x>?token={GENUINE_TOKEN}'),  # markup
        pairing_line(f"http://evil.example/x?a=:{PORT}/?token={GENUINE_TOKEN}"),
        pairing_line(GENUINE_URL).replace("carlaverse join", "carlaverse authority"),
    ],
)
def test_lines_that_are_not_exactly_the_nodes_own_are_refused(line: str) -> None:
    watch = PairingWatch(PORT)
    watch.feed(line + "\n")
    assert watch.url is None


def test_the_first_url_stays_and_the_newline_is_not_part_of_it() -> None:
    watch = PairingWatch(PORT)
    watch.feed(pairing_line(GENUINE_URL) + "\r\n")
    watch.feed(pairing_line(FORGED_URL) + "\n")
    assert watch.url == GENUINE_URL


@given(st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-",
               min_size=1, max_size=64),
       st.sampled_from(["?", "&"]),
       st.text(st.characters(blacklist_characters="="), max_size=20))  # fmt: skip
def test_no_logged_line_keeps_a_urls_token(token: str, separator: str, after: str) -> None:
    line = f"open http://h:1/p{separator}token={token} {after}"
    assert redact_tokens(line) == f"open http://h:1/p{separator}token=… {after}"
