"""The HMI's pages over HTTP: shipped pages, pages dropped into `hmi.pages_dir`, layouts.

    /                      an index of every page
    /<page>                <page>.html, from pages_dir first, then the shipped pages
    /<file>.js|.css|...    a page's assets, looked up the same way
    /api/layout/<page>     the page's layout from the HMI config (JSON), units filled in

A new page is an HTML file (plus any JS/CSS) in pages_dir: it is listed and served as it is,
without any Python change; it can load the shipped `hmi.js` to get the WebSocket feed.
Only regular files whose real path lies inside their folder are served: a symlink may point
within the folder, never out of it (such a name is neither listed nor served).
"""

from __future__ import annotations

import html
from pathlib import Path

import msgspec
from starlette.requests import Request
from starlette.responses import FileResponse, HTMLResponse, JSONResponse, Response
from starlette.routing import Route

from carlaverse.hmi.config import PAGE_NAME, Layout, LoadedHmiConfig
from carlaverse.patterns import whole_ascii

SHIPPED_PAGES = Path(__file__).parent / "pages"
QUESTIONNAIRE_PAGE = "questionnaire"  # a study's questionnaires only (questionnaire.js)
ASSET = whole_ascii(r"[A-Za-z0-9][A-Za-z0-9_-]*\.(js|mjs|css|svg|png|json|woff2)")


class Site:
    """Finds pages and assets in the pages folder and the shipped pages; builds layouts."""

    def __init__(self, loaded: LoadedHmiConfig) -> None:
        self.loaded = loaded
        self.folders = [f for f in (loaded.pages_dir, SHIPPED_PAGES) if f is not None]

    def pages(self) -> list[str]:
        """The pages folder's pages (looked up now: a file dropped in later is listed too),
        the shipped pages this config lays out (a drive node has no bike page) and the
        questionnaire page."""
        names = {p.stem for p in SHIPPED_PAGES.glob("*.html")} & set(self.loaded.config.layouts)
        names.add(QUESTIONNAIRE_PAGE)  # every participant's kind can be asked one
        if self.loaded.pages_dir is not None:
            pages_dir = self.loaded.pages_dir
            names |= {p.stem for p in pages_dir.glob("*.html") if _inside(p, pages_dir)}
        return sorted(n for n in names if PAGE_NAME.match(n))

    def find(self, filename: str) -> Path | None:
        """The real path of `filename` in the first folder that has it as a regular file."""
        for folder in self.folders:
            found = _inside(folder / filename, folder)
            if found is not None:
                return found
        return None

    def layout(self, page: str) -> dict[str, object]:
        config = self.loaded.config
        layout = config.layouts.get(page, Layout())  # a page of its own: no widgets
        units = layout.units or config.hmi.units
        return {**msgspec.to_builtins(layout), "units": units, "page": page}

    def routes(self) -> list[Route]:
        return [
            Route("/", self._index),
            Route("/api/layout/{page}", self._layout),
            Route("/{name}", self._file),
        ]

    async def _index(self, request: Request) -> Response:
        links = "".join(
            f'<li><a href="/{name}">{html.escape(name)}</a></li>' for name in self.pages()
        )
        return HTMLResponse(
            "<!doctype html><meta charset='utf-8'><link rel='icon' href='data:,'>"
            "<link rel='stylesheet' href='/hmi.css'><title>CARLAverse HMI</title>"
            f"<body class='index'><h1>CARLAverse HMI</h1><ul id='pages'>{links}</ul></body>"
        )

    async def _layout(self, request: Request) -> Response:
        page = request.path_params["page"]
        if not PAGE_NAME.match(page):
            return JSONResponse({"error": f"bad page name {page!r}"}, status_code=404)
        return JSONResponse(self.layout(page))

    async def _file(self, request: Request) -> Response:
        name = request.path_params["name"]
        if PAGE_NAME.match(name):
            filename = f"{name}.html"
        elif ASSET.match(name):
            filename = name
        else:
            return Response(f"no such page {name!r}", status_code=404)
        found = self.find(filename)
        if found is None:
            return Response(f"no such page {name!r} (pages: {self.pages()})", status_code=404)
        # Pages change while a lab edits them: never let the browser keep a stale copy.
        return FileResponse(found, headers={"Cache-Control": "no-store"})


def _inside(candidate: Path, folder: Path) -> Path | None:
    """`candidate`'s real path if it is a regular file inside `folder`'s real path.
    The caller serves this real path, not the name it came by: the name checked is the
    name opened, with no link in it left to follow."""
    try:
        real = candidate.resolve(strict=True)
    except (OSError, RuntimeError):  # missing, a dangling or looping link
        return None
    inside = real.is_relative_to(folder.resolve()) and real.is_file()
    return real if inside else None
