"""Screenshots of a running view with headless Chromium (Debian's ``chromium``): for the browser test,
the README's pictures and the viewer benchmark. WebGL is drawn in software (SwiftShader)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from .server import ViewerError

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
# software WebGL: the machines have no GPU; ANGLE over SwiftShader is what draws it headless
FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--use-gl=angle", "--use-angle=swiftshader",
         "--enable-unsafe-swiftshader", "--hide-scrollbars", "--no-first-run", "--disable-extensions")


def find_browser() -> str | None:
    """The path of a Chromium-type browser on PATH, or None."""
    return next((p for p in map(shutil.which, BROWSERS) if p), None)


def screenshot(url: str, out, size=(1280, 800), budget_ms: int = 10_000, timeout_s: float = 180) -> Path:
    """Load ``url`` in headless Chromium, let it run ``budget_ms`` of virtual time, and write a PNG of
    ``size`` (width, height) [px] to ``out``. ViewerError if there is no browser or no picture."""
    browser = find_browser()
    if browser is None:
        raise ViewerError(f"no browser for screenshots: none of {', '.join(BROWSERS)} is on PATH "
                          "(apt-get install chromium)")
    out = Path(out)
    out.unlink(missing_ok=True)
    cmd = [browser, *FLAGS, f"--screenshot={out}", f"--window-size={size[0]},{size[1]}",
           f"--virtual-time-budget={budget_ms}", url]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise ViewerError(f"{browser} took more than {timeout_s:.0f} s to take a screenshot of {url}") from None
    if not out.is_file():
        tail = " ".join(r.stderr.split())[-200:]
        raise ViewerError(f"{browser} wrote no screenshot (exit {r.returncode}): {tail}")
    return out
