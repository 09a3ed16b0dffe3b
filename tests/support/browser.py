"""One headless Chromium for a browser test file, driven over the DevTools protocol.

``placement.viewer.screenshot`` starts a browser per picture and takes it after a fixed budget of
virtual time; a test that needs several pictures of pages that take long to draw in software WebGL
(SwiftShader) paid a launch, a fresh profile (no shader or HTTP cache) and a whole page load for every
picture and every retry. Here one browser serves every page of a test file, and a page is
photographed again and again until it shows what the test waits for (or a deadline passes), so a
test waits as long as the drawing takes and no longer.
"""

from __future__ import annotations

import base64
import itertools
import json
import os
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from placement.viewer.screenshot import FLAGS, find_browser


class Browser:
    """A headless Chromium with pages of ``size`` (width, height) [px]; ``close()`` ends it with every
    process it started."""

    def __init__(self, size: tuple[int, int] = (1280, 800), start_s: float = 60) -> None:
        from websockets.sync.client import connect

        browser = find_browser()
        if browser is None:
            raise RuntimeError("no chromium on PATH")
        self.size = size
        self._ids = itertools.count(1)
        self._profile = tempfile.TemporaryDirectory(prefix="placement-chromium-", ignore_cleanup_errors=True)
        cmd = [
            browser,
            *FLAGS,
            f"--user-data-dir={self._profile.name}",
            "--remote-debugging-port=0",  # Chromium picks a free port and writes it to DevToolsActivePort
            f"--window-size={size[0]},{size[1]}",
            "about:blank",
        ]
        # a session of its own, so that close() ends the browser with every process it started
        self._proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            port_file = Path(self._profile.name) / "DevToolsActivePort"
            deadline = time.monotonic() + start_s
            while not (port_file.is_file() and len(port_file.read_text().split()) == 2):
                if time.monotonic() > deadline or self._proc.poll() is not None:
                    raise RuntimeError(f"{browser} opened no DevTools port within {start_s:.0f} s")
                time.sleep(0.05)
            port, path = port_file.read_text().split()
            self._ws = connect(f"ws://127.0.0.1:{port}{path}", max_size=None, proxy=None, open_timeout=start_s)
        except BaseException:
            self._kill()
            raise

    def call(self, method: str, session: str | None = None, timeout_s: float = 120, **params: Any) -> dict:
        """The result of the DevTools command ``method`` (in the page ``session``); events are skipped."""
        key = next(self._ids)
        self._ws.send(
            json.dumps({"id": key, "method": method, "params": params} | ({"sessionId": session} if session else {}))
        )
        deadline = time.monotonic() + timeout_s
        while True:
            reply = json.loads(self._ws.recv(timeout=max(0.01, deadline - time.monotonic())))
            if reply.get("id") == key:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    @contextmanager
    def page(self, url: str) -> Iterator[Page]:
        """A new tab showing ``url``, closed on exit (a page left open keeps drawing and takes CPU)."""
        target = self.call("Target.createTarget", url=url)["targetId"]
        try:
            session = self.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
            yield Page(self, session)
        finally:
            self.call("Target.closeTarget", targetId=target)

    def _kill(self) -> None:
        try:
            os.killpg(self._proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self._proc.wait()
        self._profile.cleanup()

    def close(self) -> None:
        try:
            self._ws.close()
        finally:
            self._kill()


class Page:
    """A tab of a :class:`Browser`."""

    def __init__(self, browser: Browser, session: str) -> None:
        self.browser, self.session = browser, session

    def shot(self, out: Path) -> Path:
        """A PNG of the page as it is drawn now, written to ``out``."""
        data = self.browser.call("Page.captureScreenshot", session=self.session, format="png")["data"]
        out.write_bytes(base64.b64decode(data))
        return out

    def wait_for(self, out: Path, ok: Callable[[Path], bool], timeout_s: float, every_s: float = 0.5) -> Path:
        """Screenshots to ``out`` every ``every_s`` [s] until ``ok(out)`` or ``timeout_s`` [s] passed;
        ``out`` then holds the last one, which the caller checks (so a page that never gets there fails
        the test with what it showed)."""
        deadline = time.monotonic() + timeout_s
        while not ok(self.shot(out)) and time.monotonic() < deadline:
            time.sleep(every_s)
        return out


def image(path: Path) -> np.ndarray:
    """(h, w, 3) uint8 RGB pixels of the PNG at ``path``."""
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"))
