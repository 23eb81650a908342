"""A real `carlaverse launcher` process for tests, and a census of everything it started."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import psutil

from tests.support import free_port, wait_until

START_TIMEOUT_S = 30.0  # [s] NiceGUI imports and binds in ~3 s; a loaded host takes longer


class ServedLauncher:
    """`carlaverse launcher --no-browser` on a free port, its output in a file."""

    def __init__(self, config_dir: Path, session: str = "lab") -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}/"
        self.log_path = config_dir / "launcher.log"
        argv = ["launcher", "--no-browser", "--port", str(self.port), "--session", session]
        argv += ["--config-dir", str(config_dir)]
        self._log = self.log_path.open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "carlaverse", *argv],
            stdout=self._log,
            stderr=subprocess.STDOUT,
            env=_launcher_env(),
        )
        self.seen: dict[int, psutil.Process] = {}  # every descendant ever counted

    def wait_ready(self) -> None:
        wait_until(self._answers, START_TIMEOUT_S, f"the launcher at {self.url} ({self.output()})")

    def _answers(self) -> bool:
        if self.proc.poll() is not None:
            raise AssertionError(f"launcher exited {self.proc.returncode}: {self.output()}")
        try:
            with urllib.request.urlopen(self.url, timeout=1.0) as reply:
                return reply.status == 200
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
