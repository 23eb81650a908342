"""Drive headless Chromium over the DevTools pipe (no websocket library needed).

`--remote-debugging-pipe` makes Chromium read DevTools commands from fd 3 and write replies
to fd 4, each a JSON object terminated by a NUL byte.
"""

from __future__ import annotations

import base64
import itertools
import json
import os
import subprocess
import tempfile
import threading
from typing import Any

from carlaverse.testing.chromium import CHROMIUM, CHROMIUM_FLAGS

FLAGS = [
    *CHROMIUM_FLAGS,
    "--enable-unsafe-swiftshader",  # software WebGL for the rerun web viewer
    "--remote-debugging-pipe",
]


class Chromium:
    """One headless browser; `screenshot(url)` style helpers over CDP."""

    def __init__(self, width: int = 1280, height: int = 800) -> None:
        self._profile = tempfile.TemporaryDirectory(prefix="carlaverse-chromium-")
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()
        args = [str(CHROMIUM), *FLAGS, f"--user-data-dir={self._profile.name}",
                f"--window-size={width},{height}", "about:blank"]  # fmt: skip
        # Chromium expects the pipe at fds 3 (its input) and 4 (its output); bash places them
        # (dash only redirects one-digit fds).
        script = f'exec "$@" 3<&{to_chrome_r} 4>&{from_chrome_w}'
        self._proc = subprocess.Popen(
            ["/bin/bash", "-c", script, "chromium", *args],
            pass_fds=(to_chrome_r, from_chrome_w),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._ids = itertools.count(1)
        self._buffer = b""
        self._lock = threading.Lock()
        self._session = ""

    def call(self, method: str, timeout: float = 30.0, **params: Any) -> dict[str, Any]:
        with self._lock:
            msg_id = next(self._ids)
            msg: dict[str, Any] = {"id": msg_id, "method": method, "params": params}
            if self._session and not method.startswith("Target."):
                msg["sessionId"] = self._session
            os.write(self._to_chrome, json.dumps(msg).encode() + b"\0")
            while True:
                reply = self._read_message()
                if reply.get("id") == msg_id:
                    if "error" in reply:
                        raise RuntimeError(f"{method}: {reply['error']}")
                    return reply.get("result", {})

    def _read_message(self) -> dict[str, Any]:
        while b"\0" not in self._buffer:
            chunk = os.read(self._from_chrome, 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed the DevTools pipe")
            self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(raw)

    def open(self, url: str) -> None:
        target = self.call("Target.createTarget", url=url)["targetId"]
        self._session = self.call("Target.attachToTarget", targetId=target, flatten=True)[
            "sessionId"
        ]

    def screenshot(self) -> bytes:
        return base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])

    def close(self) -> None:
        try:
            self.call("Browser.close", timeout=5)
        except (RuntimeError, OSError):
            pass
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        for fd in (self._to_chrome, self._from_chrome):
            os.close(fd)
        self._profile.cleanup()
