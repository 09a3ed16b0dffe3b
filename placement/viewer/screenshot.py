"""Screenshots of a running view with headless Chromium (Debian's ``chromium``): for the browser test,
the documentation's pictures and the viewer benchmark. WebGL is drawn in software (SwiftShader)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path

from placement.errors import ViewerError

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
# software WebGL: the machines have no GPU; ANGLE over SwiftShader is what draws it headless
FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--hide-scrollbars",
    "--no-first-run",
    "--disable-extensions",
)


def find_browser() -> str | None:
    """The path of a Chromium-type browser on PATH, or None."""
    return next((p for p in map(shutil.which, BROWSERS) if p), None)


def panel_filled(path: Path | str) -> bool:
    """Whether a screenshot shows a loaded, connected page: a page caught loading has an empty GUI
    panel (top right), one whose connection dropped a red icon and a greyed-out scene."""
    import numpy as np
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB")).astype(int)
    w = img.shape[1]
    icon = img[20:50, w - 330 : w - 290]  # the connection icon: green when connected, red when not
    connected = bool(np.any((icon[..., 1] > icon[..., 0] + 60) & (icon[..., 1] > icon[..., 2] + 20)))
    text = img[60:130, w - 330 : w - 20].min() < 90  # the first lines of the panel, filled in once loaded
    return connected and bool(text)


def screenshot(
    url: str,
    out: Path | str,
    size: tuple[int, int] = (1280, 800),
    budget_ms: int = 10_000,
    timeout_s: float = 45,
    tries: int = 3,
) -> Path:
    """Load ``url`` in headless Chromium, let it run ``budget_ms`` of virtual time, and write a PNG of
    ``size`` (width, height) [px] to ``out``; taken again (up to ``tries`` times) while the page shows
    no GUI yet, which happens when the machine is busy. ViewerError if there is no browser or no picture."""
    for _ in range(tries - 1):
        try:
            if panel_filled(capture(url, out, size, budget_ms, timeout_s)):
                return Path(out)
        except ViewerError as exc:
            if "took more than" not in str(exc):  # a hung browser (a busy machine) is worth another try
                raise
    return capture(url, out, size, budget_ms, timeout_s)


def capture(url: str, out: Path | str, size: tuple[int, int], budget_ms: int, timeout_s: float) -> Path:
    """One headless Chromium screenshot of ``url`` (see :func:`screenshot`)."""
    browser = find_browser()
    if browser is None:
        raise ViewerError(
            f"no browser for screenshots: none of {', '.join(BROWSERS)} is on PATH (apt-get install chromium)"
        )
    png = Path(out).resolve()
    png.unlink(missing_ok=True)
    # a profile of its own: a browser already running on the default profile would take the request over
    with tempfile.TemporaryDirectory(prefix="placement-chromium-", ignore_cleanup_errors=True) as profile:
        cmd = [
            browser,
            *FLAGS,
            f"--user-data-dir={profile}",
            f"--screenshot={png}",
            f"--window-size={size[0]},{size[1]}",
            f"--virtual-time-budget={budget_ms}",
            url,
        ]
        # a session of its own, so that a hung browser is ended with every process it started
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
        try:
            _, err = p.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
            raise ViewerError(f"{browser} took more than {timeout_s:.0f} s to take a screenshot of {url}") from None
    if not png.is_file():
        tail = " ".join(err.split())[-200:]
        raise ViewerError(f"{browser} wrote no screenshot (exit {p.returncode}): {tail}")
    return png
