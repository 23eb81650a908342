"""The launcher's files: every path the page names stays inside the config dir.

The page may open, save and start nodes with files it names, so each name is confined to the
folder the operator gave (`--config-dir`), the shipped configs excepted (package data, read
only). A name outside is refused before anything is read, and refused without its content:

- the name is made absolute against the config dir and must stay inside it lexically (no `..`
  out, no other absolute path);
- the folders below the config dir are then opened one at a time with O_NOFOLLOW, and the file
  itself too, so no symlink is followed anywhere, however it was planted or swapped;
- a file is read only when it is a regular file under `MAX_BYTES` (no FIFO to block on);
- a save never creates a folder outside; it writes a scratch file of a random name with
  O_CREAT|O_EXCL|O_NOFOLLOW, mode 0600, in the target's folder, and renames it into place, so
  a symlink planted at any name is neither followed nor written through.

    files = ConfigDir(Path("~/lab").expanduser())
    path, text = files.read_source("bike.yaml")   # or a shipped name: "bike-sim"
    with files.scratch("bike.yaml", text) as scratch:
        check(scratch.path)
        scratch.commit()
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import Any

import yaml

from carlaverse.config import SHIPPED_PACKAGES, ConfigError, shipped_dir

MAX_BYTES = 1 << 20  # [B] a config is a few kB; a bigger "config" is not one
MAX_SCANNED_FILES = 500  # configs read when looking for device blocks
CONFIG_SUFFIXES = (".yaml", ".yml")
_DIR_FLAGS = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC
_READ_FLAGS = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
_SCRATCH_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC


class ConfigDir:
    """The folder the launcher's page may read and write; shipped configs are read-only."""

    def __init__(self, root: Path) -> None:
        self.given = Path(os.path.abspath(root.expanduser()))
        self.root = self.given.resolve()
        if not self.root.is_dir():
            raise ConfigError(str(root), "config dir is not a folder")

    def inside(self, name: str | Path) -> PurePosixPath:
        """`name` (absolute, or relative to the config dir) as a path below the config dir."""
        text = str(name)
        if not text or "\0" in text:
            raise ConfigError(repr(text), "not a file name")
        full = Path(os.path.normpath(self.given / Path(text).expanduser()))
        for base in (self.given, self.root):
            if full.is_relative_to(base) and full != base:
                return PurePosixPath(full.relative_to(base))
        raise ConfigError(text, f"outside the config dir {self.given}; the launcher opens and "
                                "saves only files inside it")  # fmt: skip

    def path(self, relative: PurePosixPath) -> Path:
        return self.root / relative

    def shown(self, name: str | Path) -> Path:
        """`name` inside the config dir as the operator spelled the dir, for messages."""
        return self.given / self.inside(name)

    def holds(self, path: Path) -> bool:
        """Whether `path` (its real path) is inside the config dir or a shipped folder."""
        real = path.resolve()
        return any(real.is_relative_to(base) for base in (self.root, *_shipped_roots()))

    def read(self, name: str | Path) -> tuple[Path, str]:
        """The file `name` inside the config dir: its path and text."""
        relative = self.inside(name)
        return self.path(relative), self._read(relative, str(name))

    def read_source(self, name: str) -> tuple[Path, str]:
        """A file to open: inside the config dir, else a shipped config by name."""
        shipped = None if _escapes(name) else _shipped(name)
        if shipped is not None and not self._exists_inside(name):
            return shipped, shipped.read_text(encoding="utf-8")
        return self.read(name)

    def source(self, name: str) -> Path:
        """A file a started process will read: checked as `read_source` checks it."""
        return self.read_source(name)[0]

    @contextlib.contextmanager
    def scratch(self, target: str | Path, text: str) -> Iterator[Scratch]:
        """A new 0600 file beside `target` holding `text`; removed unless committed."""
        relative = self.inside(target)
        folder = self._open_folder(relative.parent.parts, str(target), create=True)
        try:
            mode = _existing_mode(folder, relative.name, str(target))
            name = f".{relative.stem}.launcher-{secrets.token_hex(8)}.yaml"
            fd = os.open(name, _SCRATCH_FLAGS, 0o600, dir_fd=folder)
            with os.fdopen(fd, "w", encoding="utf-8") as out:
                if mode is not None:
                    os.fchmod(out.fileno(), mode)  # a replaced file keeps its permissions
                out.write(text)
            scratch = Scratch(self.path(relative.parent) / name, name, relative.name, folder)
            try:
                yield scratch
            finally:
                if not scratch.committed:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(name, dir_fd=folder)
        finally:
            os.close(folder)

    def device_blocks(self) -> list[dict[str, Any]]:
        """Every device block (`{backend: …}`) the YAML files in the config dir hold."""
        blocks: list[dict[str, Any]] = []
        for relative in self._config_files():
            try:
                data = yaml.safe_load(self._read(relative, str(relative)))
            except (ConfigError, yaml.YAMLError):
                continue  # not a config the launcher can read: it names no device
            blocks.extend(_blocks_in(data))
        return blocks

    def _exists_inside(self, name: str) -> bool:
        try:
            return (self.root / self.inside(name)).exists()
        except ConfigError:
            return False

    def _read(self, relative: PurePosixPath, shown: str) -> str:
        folder = self._open_folder(relative.parent.parts, shown)
        try:
            fd = _open_at(relative.name, _READ_FLAGS, folder, shown)
        finally:
            os.close(folder)
        with os.fdopen(fd, "rb") as source:
            info = os.fstat(source.fileno())
            if not stat.S_ISREG(info.st_mode):
                raise ConfigError(shown, "not a regular file")
            if info.st_size > MAX_BYTES:
                raise ConfigError(shown, f"larger than {MAX_BYTES} bytes: not a config")
            raw = source.read(MAX_BYTES + 1)
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise ConfigError(shown, "not UTF-8 text") from None  # no bytes of it are shown

    def _open_folder(self, parts: tuple[str, ...], shown: str, create: bool = False) -> int:
        """A descriptor of the folder `parts` below the root, no symlink followed on the way."""
        fd = os.open(self.root, _DIR_FLAGS)
        try:
            for part in parts:
                if create:
                    with contextlib.suppress(FileExistsError):
                        os.mkdir(part, 0o777, dir_fd=fd)  # inside the root only, by construction
                child = _open_at(part, _DIR_FLAGS, fd, shown)
                os.close(fd)
                fd = child
        except BaseException:
            os.close(fd)
            raise
        return fd

    def _config_files(self) -> list[PurePosixPath]:
        found: list[PurePosixPath] = []
        for folder, dirs, files in os.walk(self.root):  # symlinked folders are not entered
            base = PurePosixPath(os.path.relpath(folder, self.root))
            for name in sorted(files):
                if name.endswith(CONFIG_SUFFIXES) and not name.startswith("."):
                    found.append(base / name if str(base) != "." else PurePosixPath(name))
            dirs.sort()
            if len(found) >= MAX_SCANNED_FILES:
                break
        return found[:MAX_SCANNED_FILES]


class Scratch:
    """A scratch file written by `ConfigDir.scratch`; `commit()` renames it onto its target."""

    def __init__(self, path: Path, name: str, target: str, folder: int) -> None:
        self.path = path
        self.committed = False
        self._name, self._target, self._folder = name, target, folder

    def commit(self) -> None:
        # rename(2) replaces the name itself: a symlink planted at the target since the check
        # is replaced, never written through.
        _existing_mode(self._folder, self._target, self._target)
        os.replace(self._name, self._target, src_dir_fd=self._folder, dst_dir_fd=self._folder)
        self.committed = True


def _open_at(name: str, flags: int, folder: int, shown: str) -> int:
    try:
        return os.open(name, flags, dir_fd=folder)
    except FileNotFoundError:
        raise ConfigError(shown, "no such file inside the config dir") from None
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.ENOTDIR, errno.EMLINK):
            raise ConfigError(shown, "through a symlink or not a folder; the launcher follows "
                                     "no symlink in the config dir") from None  # fmt: skip
        raise ConfigError(shown, f"cannot open: {exc.strerror}") from None


def _existing_mode(folder: int, name: str, shown: str) -> int | None:
    """The permissions of the file at `name`, None if there is none; a symlink is refused."""
    try:
        info = os.stat(name, dir_fd=folder, follow_symlinks=False)
    except FileNotFoundError:
        return None
    if stat.S_ISLNK(info.st_mode):
        raise ConfigError(shown, "is a symlink; the launcher writes through no symlink")
    if not stat.S_ISREG(info.st_mode):
        raise ConfigError(shown, "not a regular file")
    return stat.S_IMODE(info.st_mode)


def _escapes(name: str) -> bool:
    path = PurePosixPath(name)
    return path.is_absolute() or ".." in path.parts or name.startswith("~")


def _shipped_roots() -> list[Path]:
    return [shipped_dir(package).resolve() for package in SHIPPED_PACKAGES]


def _shipped(name: str) -> Path | None:
    """A shipped config by name (`bike-sim`, `town.yaml`), or None."""
    for root in _shipped_roots():
        for option in (name, f"{name}.yaml"):
            candidate = (root / option).resolve()
            if candidate.is_relative_to(root) and candidate.is_file():
                return candidate
    return None


def _blocks_in(data: Any) -> Iterator[dict[str, Any]]:
    """Mappings with a `backend` key, anywhere in parsed YAML (aliases visited once)."""
    seen: set[int] = set()
    stack = [data]
    while stack:
        node = stack.pop()
        if id(node) in seen or not isinstance(node, (dict, list)):
            continue
        seen.add(id(node))
        if isinstance(node, dict):
            if "backend" in node:
                yield node
            stack.extend(node.values())
        else:
            stack.extend(node)
