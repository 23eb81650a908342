"""A real `carlaverse launcher` process for tests, and a census of everything it started.

Each launcher gets a private runtime dir of its own ($XDG_RUNTIME_DIR), where it leaves its
launch token; `url` carries that token, as the URL the launcher prints does."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import psutil

from tests.support import free_port, wait_until

START_TIMEOUT_S = 30.0  # [s] NiceGUI imports and binds in ~3 s; a loaded host takes longer


class ServedLauncher:
    """`carlaverse launcher --no-browser` on a free port, its output in a file."""

    def __init__(self, config_dir: Path, session: str = "lab", extra: tuple[str, ...] = ()) -> None:
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}/"
        self.url = self.base  # with `?token=` once ready
        self.token: str | None = None
        self.config_dir = config_dir
        # the log beside, not inside, the config dir: the page may open only what is inside
        self.log_path = config_dir.with_name(config_dir.name + "-launcher.log")
        self.runtime_dir = config_dir.with_name(config_dir.name + "-run")
        self.runtime_dir.mkdir(mode=0o700)  # private, as a login's runtime dir is
        self.token_path = self.runtime_dir / "carlaverse" / f"launcher-{self.port}.token"
        argv = ["launcher", "--no-browser", "--port", str(self.port), "--session", session]
        argv += ["--config-dir", str(config_dir), *extra]
        self._log = self.log_path.open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "carlaverse", *argv],
            stdout=self._log,
            stderr=subprocess.STDOUT,
            env=dict(_launcher_env(), XDG_RUNTIME_DIR=str(self.runtime_dir)),
        )
        self.seen: dict[int, psutil.Process] = {}  # every descendant ever counted

    def wait_ready(self) -> None:
        wait_until(self._answers, START_TIMEOUT_S, f"the launcher at {self.base} ({self.output()})")
        if self.token_path.exists():  # a launcher without tokens (older code) leaves none
            self.token = self.token_path.read_text().strip()
            self.url = f"{self.base}?token={self.token}"

    def _answers(self) -> bool:
        """It printed its URL and its port answers HTTP (401 without a token is an answer)."""
        if self.proc.poll() is not None:
            raise AssertionError(f"launcher exited {self.proc.returncode}: {self.output()}")
        if "launcher at " not in self.output():
            return False
        try:
            with urllib.request.urlopen(self.base, timeout=1.0) as reply:
                return reply.status == 200
        except urllib.error.HTTPError:
            return True
        except OSError:
            return False

    def census(self) -> list[psutil.Process]:
        """The launcher's descendants now; each is remembered for `left_running`."""
        found = psutil.Process(self.proc.pid).children(recursive=True)
        self.seen.update({p.pid: p for p in found})
        return found

    def left_running(self) -> list[str]:
        """Descendants ever counted that still run (zombies do not)."""
        alive = []
        for process in self.seen.values():
            try:
                if process.is_running() and process.status() != psutil.STATUS_ZOMBIE:
                    alive.append(f"{process.pid} {' '.join(process.cmdline()[:8])}")
            except psutil.NoSuchProcess:
                continue
        return alive

    def terminate(self, timeout: float = 30.0) -> int:
        """SIGTERM, as a window manager or systemd would close it; its exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(timeout=timeout)
        finally:
            self._log.close()

    def kill(self) -> None:
        """Last resort for a failed test: the launcher and everything counted, by pid."""
        for process in [psutil.Process(self.proc.pid), *self.seen.values()]:
            try:
                process.kill()
            except psutil.NoSuchProcess:
                pass
        self.proc.wait()
        self._log.close()

    def output(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text()[-2000:]


def _launcher_env() -> dict[str, str]:
    # NiceGUI takes PYTEST_CURRENT_TEST to mean "inside NiceGUI's own test harness" and then
    # ignores --port; the launcher here is a program under test, not a test.
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    return dict(env, PYTHONUNBUFFERED="1")
