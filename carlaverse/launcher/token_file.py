"""Where a running launcher leaves its token for scripts: a file only its user can read.

`$XDG_RUNTIME_DIR/carlaverse/launcher-<port>.token` (the runtime dir is the user's own, 0700,
emptied at logout), else `~/.local/share/carlaverse/runtime/`; the folder is made 0700 and
refused if it is a symlink, another user's, or open to others. The file is created 0600 with
O_EXCL|O_NOFOLLOW, so nothing planted at its name is followed, and removed when the launcher
stops. Another local account reads neither the file nor the folder, so it has no token.

The browser is opened on a 0600 page in the same folder that forwards to the token URL:
a URL handed to `webbrowser.open` sits on a command line (`xdg-open URL`, a browser started
with it), which every local account can read in /proc.
"""

from __future__ import annotations

import contextlib
import html
import os
import stat
from pathlib import Path

FOLDER_MODE = 0o700
FILE_MODE = 0o600


class TokenFileError(OSError):
    """The runtime folder cannot hold a secret: a symlink, another user's, or open to others."""


def runtime_dir() -> Path:
    """The folder for this user's launcher tokens (not created here)."""
    xdg = os.environ.get("XDG_RUNTIME_DIR", "")
    if xdg and os.path.isabs(xdg) and _private_dir(Path(xdg)):
        return Path(xdg) / "carlaverse"
    return Path.home() / ".local" / "share" / "carlaverse" / "runtime"


def token_path(port: int, folder: Path | None = None) -> Path:
    return (folder or runtime_dir()) / f"launcher-{port}.token"


def write_token(port: int, token: str, folder: Path | None = None) -> Path:
    """Write the token 0600 for scripts; the file's path."""
    path = token_path(port, folder)
    _write_private(path, token + "\n")
    return path


def write_opener(port: int, url: str, folder: Path | None = None) -> Path:
    """A 0600 page that forwards the browser to `url`; open it as file://, not the URL."""
    path = token_path(port, folder).with_suffix(".html")
    quoted = html.escape(url, quote=True)
    _write_private(
        path,
        f'<!doctype html><meta charset="utf-8"><meta http-equiv="refresh" content="0;url={quoted}">'
        f'<title>CARLAverse launcher</title><a href="{quoted}">open the launcher</a>\n',
    )
    return path


def remove(path: Path) -> None:
    """Remove a file written here (gone already is fine)."""
    with contextlib.suppress(FileNotFoundError):
        path.unlink()


def _write_private(path: Path, text: str) -> None:
    _make_private_dir(path.parent)
    with contextlib.suppress(FileNotFoundError):
        path.unlink()  # a stale file of a launcher that was killed; the folder is ours alone
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
    fd = os.open(path, flags, FILE_MODE)
    with os.fdopen(fd, "w", encoding="utf-8") as out:
        out.write(text)


def _make_private_dir(folder: Path) -> None:
    folder.parent.mkdir(parents=True, exist_ok=True)
    with contextlib.suppress(FileExistsError):
        folder.mkdir(FOLDER_MODE)
    if not _private_dir(folder):
        raise TokenFileError(
            f"{folder}: not a private folder (a symlink, another user's, or readable by "
            f"others); make it yours with mode 0700 or set XDG_RUNTIME_DIR"
        )


def _private_dir(folder: Path) -> bool:
    try:
        info = folder.lstat()
    except OSError:
        return False
    return (
        stat.S_ISDIR(info.st_mode)
        and info.st_uid == os.geteuid()
        and stat.S_IMODE(info.st_mode) & 0o077 == 0
    )
