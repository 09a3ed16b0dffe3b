"""Colouring of 2D layers and value arrays for the viewer, and the colour scale shown beside them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from matplotlib.colors import Colormap


def colormap(name: str) -> Colormap:
    """A matplotlib colour map by name (matplotlib is a core dependency; no pyplot, no backend)."""
    import matplotlib

    return matplotlib.colormaps[name]


@dataclass(frozen=True)
class Scale:
    """A colour scale: ``lo`` .. ``hi`` in ``unit`` mapped through the colour map ``cmap``."""

    label: str
    unit: str
    lo: float
    hi: float
    cmap: str = "viridis"

    def normalise(self, values: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """``values`` -> [0, 1] (a flat scale maps everything to 0.5, so it is still visible)."""
        span = self.hi - self.lo
        if not span > 0:
            return np.full(np.shape(values), 0.5)
        return np.clip((np.asarray(values, dtype=float) - self.lo) / span, 0.0, 1.0)

    def rgb(self, values: npt.ArrayLike) -> npt.NDArray[np.uint8]:
        """(..., 3) uint8 colours of ``values``."""
        return (np.asarray(colormap(self.cmap)(self.normalise(values)))[..., :3] * 255).astype(np.uint8)

    def html(self) -> str:
        """The scale as a small HTML block: a CSS gradient between its end values and the unit."""
        stops = ", ".join(f"rgb({r},{g},{b})" for r, g, b in self.rgb(np.linspace(self.lo, self.hi, 9)))
        return (
            f"<div style='font-size:0.8em;margin:2px 0'><b>{self.label}</b> [{self.unit}]"
            f"<div style='height:10px;border-radius:2px;background:linear-gradient(to right, {stops})'></div>"
            f"<div style='display:flex;justify-content:space-between'><span>{self.lo:.3g}</span>"
            f"<span>{self.hi:.3g}</span></div></div>"
        )


def scale_of(
    values: npt.ArrayLike, label: str, unit: str, cmap: str = "viridis", valid: npt.NDArray[np.bool_] | None = None
) -> Scale:
    """The scale spanning the finite (and ``valid``) entries of ``values`` (0 .. 1 if there are none)."""
    v = np.asarray(values, dtype=float)
    ok = np.isfinite(v) if valid is None else np.isfinite(v) & valid
    if not ok.any():
        return Scale(label, unit, 0.0, 1.0, cmap)
    return Scale(label, unit, float(v[ok].min()), float(v[ok].max()), cmap)


def layer_image(
    layer: npt.ArrayLike, scale: Scale, valid: npt.NDArray[np.bool_] | None = None, alpha: int = 230
) -> npt.NDArray[np.uint8]:
    """(ny, nx, 4) uint8 RGBA image of a (ny, nx) layer whose row 0 is the lowest y; transparent where
    the layer is not finite (or not ``valid``). Rows are kept: viser draws an image's row 0 at its
    lowest y (checked in a browser, tests/test_viewer_browser.py)."""
    v = np.asarray(layer, dtype=float)
    ok = np.isfinite(v) if valid is None else np.isfinite(v) & valid
    out = np.zeros((*v.shape, 4), dtype=np.uint8)
    out[..., :3] = scale.rgb(np.where(ok, v, scale.lo))
    out[..., 3] = np.where(ok, alpha, 0)
    return out
