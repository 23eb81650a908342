"""The launcher's study tab in a real browser: a study file from the config dir started as a
run inside it, its trials followed from the log, a note and a pause written by the buttons to
the same control file the command line writes, and the run ending as the log says."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from tests.launcher.served import ServedLauncher
from tests.support import wait_until

if TYPE_CHECKING:
    from playwright.sync_api import Page

pytestmark = [pytest.mark.browser, pytest.mark.timeout(300)]
playwright_api = pytest.importorskip("playwright.sync_api")
expect = playwright_api.expect

STUDY = """
name: tab
participants:
  - {id: P05, role: cyclist, kind: bike}
conditions:
  - {id: calm}
  - {id: lagged, link: {delay_ms: 60}}
design: {order: fixed}
trial: {duration_s: 1, start_timeout_s: 150}
"""
UI_TIMEOUT_MS = 150_000  # [ms] a trial starts nodes and an authority: slow on a loaded host


@pytest.fixture
def launcher(tmp_path: Path) -> Iterator[ServedLauncher]:
    config = tmp_path / "lab"
    (config / "studies").mkdir(parents=True)
    (config / "studies" / "tab.yaml").write_text(STUDY)
    served = ServedLauncher(config)
    try:
        served.wait_ready()
        yield served
    finally:
        try:
            served.terminate()
        except subprocess.TimeoutExpired:
            served.kill()


def _events(out: Path) -> list[dict]:
    path = out / "study-log.jsonl"
    text = path.read_text() if path.exists() else ""
    return [json.loads(line) for line in text.splitlines() if line.endswith("}")]


def test_study_tab_starts_follows_and_steers_a_run(launcher: ServedLauncher, page: Page) -> None:
    page.goto(launcher.url)
    page.get_by_role("tab", name="Study").click()
    page.get_by_test_id("study-file").fill("studies/tab.yaml")
    page.get_by_test_id("study-out").fill("study-runs/first")
    page.get_by_test_id("study-start").click()
    out = launcher.config_dir / "study-runs" / "first"
    trials = page.get_by_test_id("study-trials")
    expect(trials).to_contain_text("t01", timeout=UI_TIMEOUT_MS)
    page.get_by_test_id("study-note-text").fill("helmet adjusted")
    page.get_by_test_id("study-note").click()
    page.get_by_test_id("study-pause").click()
    wait_until(lambda: any(e["event"] == "paused" for e in _events(out)), 60, "the pause logged")
    expect(page.get_by_test_id("study-state")).to_contain_text("paused", timeout=UI_TIMEOUT_MS)
    page.get_by_test_id("study-resume").click()
    expect(page.get_by_test_id("study-state")).to_contain_text(
        "2 trials completed", timeout=UI_TIMEOUT_MS
    )
    text = trials.inner_text()
    assert "t02" in text and "P05: lagged" in text and "completed" in text
    notes = [e["text"] for e in _events(out) if e["event"] == "note"]
    assert notes == ["helmet adjusted"]
    assert (out / "trials" / "t01.mcap").is_file() and (out / "trials" / "t02.mcap").is_file()
    assert page.errors == []  # type: ignore[attr-defined]
