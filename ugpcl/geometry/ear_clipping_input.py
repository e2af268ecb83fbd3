"""Ear clipping's input (vol.4 ch.5; docs/chapters/16-ear-clipping.md): the preset ring sets (
TriangulationTest.cs for nested; the chapter's fig. 5.6 for example), text outlines (the glyph preset, and the glyph
polygons of the batch kernel's workload) and rings read from and written to JSON (``input=``, the view's drawn rings).
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np

from .ear_clipping import merged_polygons


def star(points: int, outer: float, inner: float) -> np.ndarray:
    """A star of ``points`` tips, clockwise from the top: 2 * points vertices alternating between the radii."""
    angle = np.pi / 2 - np.arange(2 * points) * np.pi / points
    radius = np.where(np.arange(2 * points) % 2 == 0, outer, inner)
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])


def rect(x0: float, y0: float, x1: float, y1: float) -> list:
    """An axis-aligned rectangle, clockwise (y up), as the TriangulationTest rings are given."""
    return [(x0, y0), (x0, y1), (x1, y1), (x1, y0)]


def comb() -> list:
    ring = [(0, 0), (0, 3)]
    for i in range(5):
        ring += [(2 * i + 1, 3), (2 * i + 1, 1), (2 * i + 2, 1), (2 * i + 2, 3)]
    return ring + [(11, 3), (11, 0)]


PRESETS = {
    "nested": lambda: [
        rect(-2, -2, 5, 2),
        rect(-1, -1, 1, 1),
        rect(-0.5, -0.5, 0.5, 0.5),
        rect(2, -1, 4, 1),
        rect(2.25, -0.75, 3, -0.25),
        rect(3, 0.25, 3.75, 0.75),
    ],
    "example": lambda: [[(-2, -5), (-3, -2), (-1, 3), (-2, 6), (4, 4), (3, 4), (4, 3)]],
    "star5": lambda: [star(5, 2.0, 0.8)],
    "star12": lambda: [star(12, 3.0, 1.2)],
    "comb": lambda: [comb()],
    "holes": lambda: [rect(0, 0, 10, 10), rect(1, 1, 3, 3), rect(5, 5, 8, 8), rect(6, 1, 9, 2)],
    "notch": lambda: [[(0, 0), (0, 10), (10, 10), (10, 6), (6, 5), (10, 4), (10, 0)], rect(2, 4, 4, 5.5)],
    "square": lambda: [rect(0, 0, 2, 2)],
    "collinear": lambda: [[(0, 0), (0, 1), (0, 2), (2, 2), (2, 0)]],
    "two_squares": lambda: [rect(0, 0, 1, 1), rect(2, 0, 3, 1)],
    "glyph": None,  # glyph_rings(params.text, params.text_size)
    "draw": lambda: [],
}
"""Ring sets by name: the book's TriangulationTest (nested), its worked example of the ear list (example, fig. 5.6),
the test shapes, text outlines (glyph) and nothing (draw: the DrawTest scene, rings come from the mouse)."""


# {{{ text outlines and JSON rings


@cache
def _glyph_rings(text: str, size: float) -> tuple:
    from matplotlib import get_data_path
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    font = FontProperties(fname=str(Path(get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"))
    path = TextPath((0.0, 0.0), text, size=size, prop=font)
    return tuple(clean_ring(p) for p in path.to_polygons(closed_only=True))


def glyph_rings(text: str, size: float = 4.0) -> list[np.ndarray]:
    """Outlines of ``text`` in matplotlib's bundled DejaVu Sans, ``size`` units per em: the curves flattened by
    TextPath, letters with their holes (o, p, g ...) as separate rings."""
    return [r.copy() for r in _glyph_rings(text, float(size)) if len(r) >= 3]


def clean_ring(points) -> np.ndarray:
    """(n, 2) float64 without the closing repeat of the first vertex and without consecutive duplicates."""
    ring = np.asarray(points, np.float64).reshape(-1, 2)
    keep = np.any(ring != np.roll(ring, 1, axis=0), axis=1)
    return ring[keep] if keep.any() else ring[:1]


def load_rings(path: str) -> list[np.ndarray]:
    """``{"rings": [[[x, y], ...], ...]}`` (a bare list of rings is accepted too)."""
    data = json.loads(Path(path).read_text())
    rings = data["rings"] if isinstance(data, dict) else data
    return [clean_ring(r) for r in rings]


def save_rings(path, rings) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps({"rings": [np.asarray(r, float).tolist() for r in rings]}))


def glyph_batch(count: int, max_vertices: int) -> list[np.ndarray]:
    """``count`` glyph polygons: the merged outlines of the letters a-z and A-Z (DejaVu Sans, em 1) that have at most
    ``max_vertices`` vertices, repeated (the batch kernel's workload)."""
    letters = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
    shapes = [m for c in letters for m in merged_polygons(glyph_rings(c, 1.0)) if 3 <= len(m) <= max_vertices]
    return [shapes[i % len(shapes)] for i in range(count)]


# }}}
