"""Benchmark: the web HMI's node-state-to-browser latency and its telemetry rate, in Chromium.

    python tools/bench/bench_hmi.py [--seconds 20] [--pages 1,4] [--write]

Runs a router, an authority and `carlaverse join drive --backend sim --hmi 0` as processes,
then opens the dashboard in N headless Chromium tabs (Playwright driving Debian's
/usr/bin/chromium) and reads what each page measured.

Latency is one-way, stamp to arrival: the drive loop stamps each state with its tick's time
(session time, turned back into the node host's monotonic clock by the HMI bridge); the page
takes performance.now() when the frame arrives and adds the offset between its clock and the
node's, estimated from ping/pong round trips (the shortest round trip's sample, its half
taken as the one-way delay; its half is given as the offset's uncertainty). So the figure
includes the wait for the HMI's next frame tick (up to 1/rate), JSON encoding, the
WebSocket hop and the page's parsing. Rate: frames received per second of page time.
A measurement, not a test.
"""

from __future__ import annotations

import argparse
import itertools
import re
import statistics
import sys
import time
from typing import Any

from benchdoc import RunInfo, command_line, write_section

from carlaverse.procs import Child, free_port, start, stop_children
from carlaverse.support.stats import percentile
from carlaverse.testing.chromium import launch_chromium

TARGET_RATE_HZ = 30.0  # the dashboard's floor
HMI_URL = re.compile(r"HMI at (http://127\.0\.0\.1:\d+/)")
WARMUP_S = 3.0  # [s] the clock offset settles and the car pulls away before measuring
HMI_TIMEOUT_S = 60.0  # [s] for the node to serve its HMI and print where


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="measuring window per run [s]")
    parser.add_argument("--pages", default="1,4", help="dashboards open at once, per run")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run = RunInfo.start()
    lines = [
        "| pages open | frames/s per page (min) | frame gap p99 ms | latency p50 ms | p99 ms "
        "| max ms | clock offset ± ms | frames measured |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for pages in (int(n) for n in args.pages.split(",")):
        r = measure(pages, args.seconds)
        lines.append(
            f"| {pages} | {r['rate_hz']:.1f} | {r['gap_p99_ms']:.1f} | {r['p50_ms']:.1f} "
            f"| {r['p99_ms']:.1f} | {r['max_ms']:.1f} | {r['offset_ms']:.2f} | {r['frames']} |"
        )
        print(lines[-1], flush=True)
    lines += ["", _intro(args.seconds), "", f"Target: ≥ {TARGET_RATE_HZ:g} frames/s per page."]
    if args.write:
        write_section("Web HMI latency and rate", "\n".join(lines), command_line(argv), run)
    return 0


def measure(pages: int, seconds: float) -> dict[str, Any]:
    """One run: a session, a drive node with its HMI, `pages` dashboards; their figures."""
    from playwright.sync_api import sync_playwright

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    children = [
        start(["router", "--listen", endpoint], name="router"),
        start(["authority", "--scenario", "none", "--session", "bench", "--connect", endpoint],
              name="authority"),
    ]  # fmt: skip
    node = start(
        ["join", "drive", "--id", "car", "--session", "bench", "--connect", endpoint,
         "--backend", "sim", "--hmi", "0"],  # runs until stopped
        name="drive node",
    )  # fmt: skip
    children.append(node)
    try:
        url = _hmi_url(node)
        with sync_playwright() as playwright:
            browser = launch_chromium(playwright)
            tabs = [browser.new_page() for _ in range(pages)]
            for tab in tabs:
                if not node.running:
                    raise RuntimeError(f"the drive node exited ({node.exit_code}): "
                                       f"{node.err.lines()[-20:]}")  # fmt: skip
                tab.goto(url + "dashboard")
            for tab in tabs:
                tab.wait_for_function("window.hmi && hmi.offsetS !== null && hmi.frames > 0",
                                      timeout=60000)  # fmt: skip
            time.sleep(WARMUP_S)
            marks = [tab.evaluate("[hmi.latencies.length, hmi.arrivals.length]") for tab in tabs]
            time.sleep(seconds)
            figures = [_page_figures(tab, mark) for tab, mark in zip(tabs, marks, strict=True)]
            browser.close()
    finally:
        for child in reversed(children):  # the node, then the authority, then the router
            stop_children([child])
    return _combine(figures)


def _page_figures(tab: Any, mark: list[int]) -> dict[str, Any]:
    return tab.evaluate(
        """([fromLatency, fromArrival]) => ({
            latencies: hmi.latencies.slice(fromLatency),
            arrivals: hmi.arrivals.slice(fromArrival),
            bestRttMs: hmi.bestRttMs,
        })""",
        mark,
    )


def _combine(figures: list[dict[str, Any]]) -> dict[str, Any]:
    latencies = sorted(x for f in figures for x in f["latencies"])
    rates, gaps = [], []
    for f in figures:
        arrivals = f["arrivals"]
        span_s = (arrivals[-1] - arrivals[0]) / 1000 if len(arrivals) > 1 else 0.0
        rates.append((len(arrivals) - 1) / span_s if span_s > 0 else 0.0)
        gaps += [b - a for a, b in itertools.pairwise(arrivals)]
    return {
        "rate_hz": min(rates),
        "gap_p99_ms": percentile(gaps, 0.99),
        "p50_ms": statistics.median(latencies),
        "p99_ms": percentile(latencies, 0.99),
        "max_ms": latencies[-1],
        "offset_ms": max(f["bestRttMs"] for f in figures) / 2,
        "frames": len(latencies),
    }


def _hmi_url(node: Child) -> str:
    """The URL the node prints on stderr once its HMI serves."""
    line = node.wait_for_line(lambda text: HMI_URL.search(text) is not None, HMI_TIMEOUT_S)
    found = HMI_URL.search(line or "")
    if found is None:
        raise RuntimeError("stopped before the drive node printed its HMI URL")
    return found.group(1)


def _intro(seconds: float) -> str:
    return (
        f"Each run: a drive node (`--backend sim`, its 1 kHz loop in its own process) serving "
        f"its HMI at the shipped 60 frames/s, a router and an authority, and N dashboards in one "
        f"headless Chromium, measured for {seconds:g} s after a {WARMUP_S:g} s warm-up. "
        "Latency: the loop tick's stamp to the frame's arrival in the page, on the node host's "
        "monotonic clock (page clock + ping/pong offset, ± the figure in its column); it "
        "includes the wait for the HMI's next frame tick (≤ 16.7 ms at 60 Hz)."
    )


if __name__ == "__main__":
    sys.exit(main())
