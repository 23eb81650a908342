"""The drive node's HMI end to end: a real node process, a real router and authority, the
pages in Chromium, and this test watching the fabric as another participant would."""

from __future__ import annotations

import itertools
import math
import socket
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import psutil
import pytest
from playwright.sync_api import Browser, Page

from carlaverse import messages as m
from carlaverse.keys import Keys
from tests.browser import save_screenshot
from tests.hmi.live import node_with_hmi
from tests.support import Cluster, Proc, wait_until

pytestmark = pytest.mark.browser

# The page shows the state of one loop tick (its session time `t` rides in the frame); the
# car's poses carry the same clock at 50 Hz, so the nearest is at most 10 ms away, in which
# the car's speed changes by < 3 m/s² × 10 ms ≈ 0.1 km/h; the page rounds to 1 km/h.
SPEED_TOLERANCE_KMH = 0.5 + 0.2  # [km/h] rounding + the pose's time offset, with margin
SLOW_MPS = 2.0  # [m/s] the scripted drive's slow-down, far below the driver's 12 m/s


class Fabric:
    """What another participant sees of the car: its poses and ego states, as they arrive."""

    _ids = itertools.count(1)

    def __init__(self, cluster: Cluster, node_id: str) -> None:
        # An id of its own: the module's cluster keeps each test's observer until it ends,
        # and a second "obs" would be refused its join.
        self.client = cluster.observer(f"watch-{next(Fabric._ids)}")
        session = self.client.session
        keys = Keys("t")
        self._override_key = keys.override(node_id)
        self._override_seq = 0
        self._lock = threading.Lock()
        self.speeds: list[tuple[float, float]] = []  # (pose t [s] session time, speed [km/h])
        self.states: list[m.EgoState] = []
        self._subs = [
            session.declare_subscriber(keys.poses_of(node_id), self._on_pose),
            session.declare_subscriber(keys.state(node_id), self._on_state),
        ]

    def _on_pose(self, sample) -> None:  # type: ignore[no-untyped-def]
        pose = m.POSE.decode(sample.payload.to_bytes())
        with self._lock:
            self.speeds.append((pose.t, math.hypot(pose.vx, pose.vy) * 3.6))

    def speed_at(self, t: float) -> float:
        """The car's speed [km/h] in the pose nearest session time t (waits for later poses)."""
        wait_until(lambda: self.speeds and max(p[0] for p in self.speeds) >= t, 10,
                   f"a pose after t={t:.3f}")  # fmt: skip
        with self._lock:
            nearest = min(self.speeds, key=lambda p: abs(p[0] - t))
        assert abs(nearest[0] - t) < 0.05, f"no pose near t={t:.3f} (nearest {nearest[0]:.3f})"
        return nearest[1]

    def _on_state(self, sample) -> None:  # type: ignore[no-untyped-def]
        with self._lock:
            self.states.append(m.EGO_STATE.decode(sample.payload.to_bytes()))

    def hold_speed(self, speed_mps: float | None) -> None:
        """Take the car's pedals as an ADAS program would (None: hand them back)."""
        self._override_seq += 1
        now = self.client.now()
        override = m.Override(self._override_seq, now, "hmi-test", active=speed_mps is not None,
                              cruise_speed_mps=speed_mps, expires_t=now + 30)  # fmt: skip
        self.client.session.put(self._override_key, m.OVERRIDE.encode(override))

    def last_state(self) -> m.EgoState | None:
        with self._lock:
            return self.states[-1] if self.states else None

    def state_holds(self, check: Callable[[m.EgoState], bool]) -> bool:
        """Whether the car's newest ego state passes `check` (False before the first)."""
        state = self.last_state()
        return state is not None and check(state)


def open_touch(page: Page, url: str) -> None:
    """The touchscreen page, once its first frame and the car's info are in."""
    page.goto(url + "touch")
    page.wait_for_function("window.hmi && hmi.frames > 0 && hmi.info", timeout=30000)


@pytest.fixture(scope="module")
def drive(
    chromium: Browser, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[tuple[Cluster, Proc, str]]:
    """The car, started after the browser so the first page sees it pull away."""
    with node_with_hmi(tmp_path_factory.mktemp("drive-hmi"), "drive", "car") as running:
        yield running


@pytest.fixture
def car(drive: tuple[Cluster, Proc, str]) -> tuple[Cluster, Proc, str]:
    """The module's car, checked before each test: alive and its HMI accepting connections, or
    the test fails with the car's exit code and last output, not a refused connection."""
    _, node, url = drive
    port = int(url.rsplit(":", 1)[1].strip("/"))
    with socket.socket() as probe:
        probe.settimeout(2.0)
        serving = probe.connect_ex(("127.0.0.1", port)) == 0
    state = "running" if node.alive() else f"exited ({node.proc.returncode})"
    assert serving, f"the car's HMI is gone, the car {state}: {node.output()[-3000:]}"
    return drive


def test_the_dashboard_follows_the_scripted_drive(
    car: tuple[Cluster, Proc, str], page: Page, screenshot_dir: Path
) -> None:
    cluster, _, url = car
    fabric = Fabric(cluster, "car")
    page.goto(url + "dashboard")
    page.wait_for_function("window.hmi && hmi.frames > 0", timeout=30000)
    shown: list[float] = []
    slowed = False
    deadline = time.monotonic() + 40
    while time.monotonic() < deadline and (len(shown) < 12 or max(shown) - min(shown) < 15):
        text, t = page.evaluate("""() => [document.querySelector('[data-readout="speed"]')
                                    .textContent, hmi.drawn && hmi.drawn.t]""")
        if t is not None:  # the car's own speed at the instant the page shows
            kmh = float(text)
            assert abs(kmh - fabric.speed_at(t)) <= SPEED_TOLERANCE_KMH, (kmh, fabric.speed_at(t))
            shown.append(kmh)
        if len(shown) >= 8 and not slowed:  # then the script slows the car to walking pace
            fabric.hold_speed(SLOW_MPS)
            slowed = True
        page.wait_for_timeout(250)
    fabric.hold_speed(None)
    assert max(shown) - min(shown) >= 15, f"the speed shown hardly changed: {shown}"
    wait_until(lambda: fabric.state_holds(lambda s: s.adas == ""), 10,
               "the car's pedals back with its driver")  # fmt: skip
    state = wait_until(fabric.last_state, 10, "the car's ego state")
    gear = page.locator('[data-readout="gear"]')
    what = f"the gear shown ({gear.text_content()}) to match the ego state's ({state.gear})"
    wait_until(lambda: gear.text_content() == _gear_name(fabric.last_state()), 5, what)
    save_screenshot(page, screenshot_dir, "hmi-drive-dashboard")
    assert page.errors == []


def test_tapping_low_beam_turns_the_lights_on_the_fabric(
    car: tuple[Cluster, Proc, str], page: Page, screenshot_dir: Path
) -> None:
    cluster, _, url = car
    fabric = Fabric(cluster, "car")
    open_touch(page, url)
    button = page.locator('button[data-action="low_beam"]')
    assert not page.evaluate("hmi.last.lights") & m.LIGHT_LOW_BEAM
    button.click()

    def low_beam_on_fabric() -> bool:
        return fabric.state_holds(lambda s: bool(s.lights & m.LIGHT_LOW_BEAM))

    wait_until(low_beam_on_fabric, 10, "EgoState.lights with the low beam on the fabric")
    page.wait_for_function(
        "document.querySelector('[data-action=low_beam]').classList.contains('on')"
    )
    save_screenshot(page, screenshot_dir, "hmi-drive-touch")
    button.click()  # and off again
    wait_until(lambda: not low_beam_on_fabric(), 10, "the low beam off on the fabric")
    assert page.errors == []


def test_cruise_set_and_cancel_from_the_touchscreen(
    car: tuple[Cluster, Proc, str], page: Page, screenshot_dir: Path
) -> None:
    cluster, _, url = car
    fabric = Fabric(cluster, "car")
    open_touch(page, url)
    page.locator('button[data-action="set"]').click()  # hold the speed it has now

    def adas_on_fabric() -> bool:
        return fabric.state_holds(lambda s: s.adas != "")

    wait_until(adas_on_fabric, 10, "the cruise override in the car's EgoState.adas")
    # `hmi.drawn`, not `hmi.last`: widgets draw the newest values at the next display frame,
    # so right after `last` changes the readout can still show the frame before (it did once)
    page.wait_for_function("hmi.drawn?.cruise_active && hmi.drawn.cruise_speed_mps > 5")
    readout = page.locator('.cruise_panel [data-readout="cruise"]')
    assert readout.text_content().startswith("holding ")
    save_screenshot(page, screenshot_dir, "hmi-drive-cruise")
    page.locator('button[data-action="cancel"]').click()
    wait_until(lambda: not adas_on_fabric(), 10, "EgoState.adas empty again after cancel")
    page.wait_for_function("!hmi.last.cruise_active")
    assert page.errors == []


def test_the_hmi_listens_on_loopback_only(car: tuple[Cluster, Proc, str]) -> None:
    _, node, url = car
    port = int(url.rsplit(":", 1)[1].strip("/"))
    listening = [c.laddr for c in psutil.Process(node.proc.pid).net_connections("tcp")
                 if c.status == psutil.CONN_LISTEN and c.laddr.port == port]  # fmt: skip
    assert [a.ip for a in listening] == ["127.0.0.1"]


def _gear_name(state: m.EgoState | None) -> str:
    assert state is not None
    return "R" if state.gear < 0 else "N" if state.gear == 0 else f"D{state.gear}"
