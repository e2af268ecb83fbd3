"""Ear clipping's input (vol.4 ch.5; docs/chapters/16-ear-clipping.md): the preset ring sets (
TriangulationTest.cs for nested; the chapter's fig. 5.6 for example), text outlines (the glyph preset, and the glyph
polygons of the batch kernel's workload) and rings read from and written to JSON (``input=``, the view's drawn rings).
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np

from ..inputs import InputError, file_cached, read_json, shown
from .ear_clipping import merged_polygons
from .ear_clipping_prepass import crossing_at_touches, intersection

MAX_FILE_BYTES = 16 << 20
"""Largest rings file (``input=``): 16 MiB, room for MAX_VERTICES points in compact JSON."""
MAX_VERTICES = 200_000
"""Most points of a rings file, all rings together: a lake with its islands or a country's outline. The host's
robust pipeline takes about a minute at this size (``ugpcl bench ear_clipping``)."""
COORD_LIMIT = 1e9
"""Largest |x| or |y| of a rings file: areas and cross products (2e9 squared) stay far inside float64, vertices
inside float32 (meshes, the view)."""


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
    from matplotlib.textpath import TextPath, text_to_path

    font = FontProperties(fname=str(Path(get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"))
    if not len(text_to_path.get_text_path(font, text)[0]):
        return ()  # spaces, or characters the font draws as nothing: TextPath fails on them
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


def open_ring(points) -> np.ndarray:
    """(n, 2) float64 without the closing repeat of the first vertex (GeoJSON closes its rings so); any other
    repeated point is kept for the triangulator to merge and report."""
    ring = np.asarray(points, np.float64).reshape(-1, 2)
    while len(ring) > 1 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    return ring


@file_cached(maxsize=8)
def load_rings(path, name: str = "input") -> tuple[np.ndarray, ...]:
    """The rings of a JSON file ``{"rings": [[[x, y], ...], ...]}``, each cleaned (``clean_ring``), checked before
    they are used: at most ``MAX_FILE_BYTES`` and ``MAX_VERTICES`` in all, coordinates finite and within
    ``COORD_LIMIT``, each ring with 3 distinct points not on one line, no ring crossing or touching itself or
    another (a bowtie, a hole that touches its outer ring).
    ``InputError`` (naming ``name``, the file and the ring) otherwise. Cached by file version: read-only arrays."""
    where = f"{name} {shown(path)}"
    data = read_json(name, path, MAX_FILE_BYTES)
    if not isinstance(data, dict) or set(data) != {"rings"}:
        got = f"keys {', '.join(map(json.dumps, data))}" if isinstance(data, dict) else _kind(data)
        raise InputError(f'{where}: expected {{"rings": [[[x, y], ...], ...]}}, got {got}')
    rings = data["rings"]
    if not isinstance(rings, list) or not all(isinstance(r, list) for r in rings):
        bad = rings if not isinstance(rings, list) else next(r for r in rings if not isinstance(r, list))
        raise InputError(f"{where}: rings must be a list of rings, each a list of [x, y] points; got {_kind(bad)}")
    if not rings:
        raise InputError(f"{where}: holds no rings")
    total = sum(len(r) for r in rings)
    if total > MAX_VERTICES:
        raise InputError(f"{where}: {total} points is more than the limit of {MAX_VERTICES}")
    cleaned = [open_ring(_points(where, i, ring)) for i, ring in enumerate(rings)]
    for i, ring in enumerate(cleaned):
        distinct = len(np.unique(ring, axis=0))
        if distinct < 3:
            raise InputError(f"{where}: rings[{i}] has {distinct} distinct points; a ring needs 3")
        spread = np.linalg.svd(ring - ring.mean(axis=0), compute_uv=False)  # its extent along and across
        if spread[1] <= len(ring) * np.finfo(np.float64).eps * spread[0]:
            raise InputError(f"{where}: rings[{i}] has zero area: its points lie on one line")
    found = intersection(cleaned)
    if found is not None:
        (a, ea), (b, eb) = found
        what = f"rings[{a}] crosses itself" if a == b else f"rings[{a}] and rings[{b}] cross"
        raise InputError(
            f"{where}: {what} (edge {ea} of rings[{a}] crosses edge {eb} of rings[{b}]); rings may touch, not cross"
        )
    found = crossing_at_touches([clean_ring(r) for r in cleaned])
    if found is not None:
        a, b, point = found
        what = f"rings[{a}] crosses itself" if a == b else f"rings[{a}] and rings[{b}] cross"
        at = ", ".join(f"{v:g}" for v in point)
        raise InputError(f"{where}: {what} where they touch, at ({at}); rings may touch, not cross")
    for ring in cleaned:
        ring.flags.writeable = False
    return tuple(cleaned)


def _kind(value) -> str:
    """A JSON value as a message names it: an object, a list, a string, a number, null, true."""
    kinds = {dict: "an object", list: "a list", str: "a string", bool: "a boolean", type(None): "null"}
    return kinds.get(type(value), f"the number {value!r}")


def _points(where: str, index: int, ring: list) -> np.ndarray:
    """Ring ``index`` of the file as (n, 2) float64: every point a pair of numbers within COORD_LIMIT."""
    for j, point in enumerate(ring):
        if not (isinstance(point, list) and len(point) == 2):
            shape = f"{len(point)} numbers" if isinstance(point, list) else _kind(point)
            raise InputError(f"{where}: rings[{index}][{j}] must be [x, y] (rings are 2-D), got {shape}")
        for v in point:
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise InputError(f"{where}: rings[{index}][{j}] must be two numbers, got {_kind(v)}")
            if not abs(v) <= COORD_LIMIT:
                shown_v = f"{float(v):g}" if abs(v) < 1e308 else "a number beyond float64"
                raise InputError(f"{where}: rings[{index}][{j}] has {shown_v}; coordinates must be within +-1e9")
    return np.asarray(ring, np.float64).reshape(-1, 2)


def save_rings(path, rings) -> None:
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps({"rings": [np.asarray(r, float).tolist() for r in rings]}))


def real_world_outlines(count: int, seed: int = 0) -> list[list[np.ndarray]]:
    """``count`` outlines (each a list of rings) of the kinds real data holds, in equal shares: letters with their
    counters (DejaVu Sans), building footprints (rectilinear, collinear points on the walls, a repeated point, a
    courtyard sharing a stretch of wall), ponds with islands (one touching the shore at a vertex) and plots with
    holes on aligned rows. Each merges to polygons of at most 64 vertices (the batch kernel's limit)."""
    rng = np.random.default_rng(seed)
    letters = [r for c in "aBdegopqADOPQR8&%" if (r := glyph_rings(c, 1.0))]
    letters = [r for r in letters if max(map(len, merged_polygons(r))) <= 64]
    out: list[list[np.ndarray]] = []
    for k in range(count):
        kind = k % 4
        if kind == 0:
            out.append(letters[k // 4 % len(letters)])
        elif kind == 1:
            w, h, d = rng.uniform(6, 12), rng.uniform(6, 12), rng.uniform(2, 4)
            wall = [[0, 0], [0, h / 2], [0, h], [d, h], [d, d], [w / 2, d], [w, d], [w, 0], [w, 0], [w / 2, 0]]
            yard = [[w, d / 4], [w, d / 2], [w - d / 3, d / 2], [w - d / 3, d / 4]]
            out.append([np.asarray(wall, float), np.asarray(yard, float)])
        elif kind == 2:
            angle = np.linspace(0, 2 * np.pi, 24, endpoint=False)
            shore = np.column_stack([np.cos(angle), np.sin(angle)]) * (10 + rng.uniform(-0.5, 0.5, (24, 1)))
            tip = shore[0]
            rings = [shore, np.array([tip, tip * 0.6 + [0, 0.8], tip * 0.6 - [0, 0.8]])]
            a = np.linspace(0, 2 * np.pi, 8, endpoint=False)
            rings.append(np.column_stack([np.cos(a), np.sin(a)]) * 2.0 + [-3.0, 0.0] + rng.uniform(-0.5, 0.5, (8, 2)))
            out.append(rings)
        else:
            plot = [np.array([[0, 0], [0, 6], [12, 6], [12, 0]], float)]
            corners = [(x, y) for x in (2.0, 5.0, 8.0) for y in (1.0, 4.0)]  # holes on aligned rows
            plot += [np.array([[x, y], [x, y + 1], [x + 1, y + 1], [x + 1, y]]) for x, y in corners]
            out.append(plot)
    return out


def glyph_batch(count: int, max_vertices: int) -> list[np.ndarray]:
    """``count`` glyph polygons: the merged outlines of the letters a-z and A-Z (DejaVu Sans, em 1) that have at most
    ``max_vertices`` vertices, repeated (the batch kernel's workload)."""
    letters = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
    shapes = [m for c in letters for m in merged_polygons(glyph_rings(c, 1.0)) if 3 <= len(m) <= max_vertices]
    return [shapes[i % len(shapes)] for i in range(count)]


# }}}
