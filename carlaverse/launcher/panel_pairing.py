"""Cabin tablets: each running node's HMI pairing URL as a QR code, for a tablet to scan.

The URL holds the node's pairing token, so it is shown here on purpose (the page itself is
behind the launcher's token) and nowhere else: the live log shows `?token=…`. It lives in the
lab's memory (`Lab.hmi_pairings`) and in the page's widgets only, and goes when the node does.
"""

from __future__ import annotations

import segno
from nicegui import ui

from carlaverse.launcher.lab import Lab

REFRESH_S = 0.5  # [s] a new node's code appears this soon after it prints its URL
QR_SCALE = 5  # [px per module]: ~225 px for a pairing URL, read by a tablet at arm's length
QR_ERROR = "m"  # error correction M (15 %): a smudged or glaring screen still scans


def qr_data_uri(url: str) -> str:
    """`url` as a QR code in an inline SVG `data:` URI (nothing fetched, nothing on disk)."""
    code = segno.make(url, error=QR_ERROR)
    return code.svg_data_uri(scale=QR_SCALE, border=4, dark="#000", light="#fff")  # any theme


def pairing_panel(lab: Lab) -> None:
    with ui.card().classes("w-full") as card:
        ui.label("Cabin tablets").classes("text-lg font-medium")
        ui.label(
            "scan a node's code on the tablet once: it opens that node's HMI and keeps its "
            "pairing token; whoever sees the code can drive that node's buttons"
        ).classes("text-xs text-gray-500")
        codes = ui.row().classes("w-full gap-6")
    card.set_visibility(False)
    shown: list[tuple[str, str]] = []

    def refresh() -> None:
        pairings = lab.hmi_pairings()
        if pairings == shown:
            return
        shown[:] = pairings
        card.set_visibility(bool(pairings))
        codes.clear()
        with codes:
            for node, url in pairings:
                _code(node, url)

    ui.timer(REFRESH_S, refresh)


def _code(node: str, url: str) -> None:
    with ui.column().classes("items-center gap-1").props(f"data-testid=hmi-pairing-{node}"):
        ui.label(f"node {node}").classes("font-medium")
        image = ui.element("img").props(f"data-testid=hmi-qr-{node}")
        image.props["src"] = qr_data_uri(url)
        image.props["alt"] = f"QR code: the pairing URL of {node}'s HMI"
        image.style("image-rendering: pixelated")
        link = ui.label(url).classes("font-mono text-xs break-all max-w-xs")
        link.props(f"data-testid=hmi-url-{node}")
