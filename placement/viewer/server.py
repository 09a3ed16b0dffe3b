"""The viser server behind every view: loopback only, its URL, and how a view is kept alive or stopped."""

from __future__ import annotations

import contextlib
import io
import logging
import threading
import time
from types import ModuleType
from typing import TYPE_CHECKING, cast

from placement.errors import ViewerError

if TYPE_CHECKING:
    import viser
    from viser import ViserServer

    from placement.planning import Planner
    from placement.viewer.map_view import MapView
    from placement.viewer.plan_view import PlanView

HOST = "127.0.0.1"  # never another interface: the viewer has no authentication


def require_viser() -> ModuleType:
    """The viser module (ViewerError with the install command if it is missing)."""
    try:
        import viser
    except ImportError:
        raise ViewerError("the viewer needs the 'viser' package: pip install 'placement[view]'") from None
    return viser


def check_port(port: int) -> int:
    """``port`` if it is 0 (any free port) to 65535, else ViewerError."""
    if not isinstance(port, int) or isinstance(port, bool) or not 0 <= port <= 65535:
        raise ViewerError(f"--port: {port!r} is not a whole number from 0 (any free port) to 65535")
    return port


def start_server(port: int = 0, label: str = "placement") -> viser.ViserServer:
    """A running viser server on 127.0.0.1 (``port`` 0: a free one; a busy port: the next free one)."""
    viser = require_viser()
    check_port(port)
    # the websocket library logs every connection at INFO: noise next to the planner's own log
    logging.getLogger("websockets").setLevel(logging.WARNING)
    # viser prints a banner on stdout, which is the JSON-lines channel of --stream: the caller prints the URL
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host=HOST, port=port, label=label, verbose=False)
    server.gui.configure_theme(control_width="medium", show_share_button=False)
    return cast("ViserServer", server)  # (require_viser gives a plain ModuleType)


class View:
    """A running view: ``url`` to open, ``server`` (the viser server), ``content`` (what it shows),
    ``planner`` (for a planned scene), ``timings`` [s]; ``stop()``; ``wait()`` serves until Ctrl-C (or
    ``timeout`` [s])."""

    def __init__(
        self,
        server: viser.ViserServer,
        content: PlanView | MapView | None = None,
        planner: Planner | None = None,
        timings: dict[str, float] | None = None,
    ) -> None:
        self.server = server
        self.content = content
        self.planner = planner
        self.timings = dict(timings or {})
        self.url = f"http://{HOST}:{server.get_port()}"
        self._stopped = threading.Event()

    def __repr__(self) -> str:
        return f"View({self.url!r})"

    def wait(self, timeout: float | None = None) -> None:
        end = None if timeout is None else time.monotonic() + timeout
        try:
            while not self._stopped.is_set() and (end is None or time.monotonic() < end):
                time.sleep(0.1)
        except KeyboardInterrupt:
            pass

    def stop(self) -> None:
        if not self._stopped.is_set():
            self._stopped.set()
            with contextlib.redirect_stdout(io.StringIO()):
                self.server.stop()
