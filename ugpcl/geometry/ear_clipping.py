"""Triangulation by ear clipping (Unity Graphics Programming vol.4 ch.5; docs/chapters/16-ear-clipping.md), on the
host in float64, following the chapter's ``Triangulation.cs`` step by step:

1. ``build_tree``: the rings sorted by bounding-box area, largest first, are hung into a containment tree under a
   dummy root (CheckInPolygonTree); odd levels (outer boundaries, islands) are made clockwise, even levels (holes)
   counter-clockwise, y up.
2. ``triangulate``: every outer ring is merged with its holes (CombineOuterAndInners: right-most hole first, each
   joined by a zero-width bridge from its right-most vertex M to a visible outer vertex P, CombinePolygon), then
   ``EarClipper`` clips the merged polygon: InitializeVertices fills the FIFO ear list, EarClipping takes its head,
   emits (prev, ear, next), unlinks the ear and re-checks both neighbours (CheckVertex), which are appended at the
   end when they became ears. The ear test reads only the live vertices near the triangle (a z-order grid,
   ``EarClipper``) and answers as the book's scan over all of them does.
3. ``constrained_delaunay`` (not in the book): Lawson edge flips over every edge that is not an input ring edge.

``variant="robust"`` (the default, ``triangulate_robust``; not in the book) puts ``ear_clipping_prepass.prepare`` in
front of step 1-2 (exact nesting and bridges, touching and pinched rings, repeated points, local self-intersections)
and gives the clipper two rules (``EarClipper(robust=True)``: ``corner_blocks``, ``_flat``) and a last-resort stage
(``finish``); docs/chapters/16-ear-clipping.md tabulates what each fixes.

``variant="book"`` sorts the rings by area and the holes by right-most x with the book's comparator
``FloorToInt(b - a)`` (differences below 1 compare equal), in the order .NET's List.Sort leaves such ties;
``variant="fixed"`` sorts both exactly and stably. Holes whose right-most x differ by less than 1 can then
be bridged in the wrong order in the book, and a bridge can cross a hole that is not merged yet.
"""

from __future__ import annotations

import logging
import math
from array import array
from collections import deque
from dataclasses import dataclass, field
from functools import cmp_to_key

import numpy as np

from .ear_clipping_prepass import diagnose, in_cone, inside, prepare, segment_blocked
from .exact import orient, ring_sign

log = logging.getLogger(__name__)

CW, CCW, ERR = "CW", "CCW", "ERR"
"""Polygon.LoopType: the winding of a ring, y up (shoelace area < 0, > 0, = 0)."""
RAY_EXTENSION = 0.1
"""The bridge ray from M ends at the global max x + this (book: maxX + 0.1f)."""
ANGLE_MIN_START = 361.0
"""Start of the search for the reflex vertex R with the smallest angle IMR, degrees (book: angleMin = 361f)."""


# {{{ GeometryUtil.cs: orientation tests in float64 (the book's CheckLine computes in double)


def is_convex(now, prev, nxt) -> bool:
    """IsAngleLessPI: the interior angle at ``now`` of a clockwise ring is below 180 degrees (strict: collinear
    vertices are reflex)."""
    return (prev[0] - now[0]) * (nxt[1] - now[1]) - (prev[1] - now[1]) * (nxt[0] - now[0]) > 0.0


def check_line(o, p1, p2) -> int:
    """CheckLine: sign of (o - p1) x (p2 - p1); +1 when o is right of the line p1 -> p2 (inside a clockwise one)."""
    x0, y0 = o[0] - p1[0], o[1] - p1[1]
    x1, y1 = p2[0] - p1[0], p2[1] - p1[1]
    det = x0 * y1 - x1 * y0
    return 1 if det > 0.0 else (-1 if det < 0.0 else 0)


def in_triangle(o, p1, p2, p3) -> int:
    """IsInTriangle for a clockwise triangle: +1 outside, -1 strictly inside, 0 on an edge."""
    signs = (check_line(o, p2, p3), check_line(o, p3, p1), check_line(o, p1, p2))
    if min(signs) < 0:
        return 1
    return -1 if all(signs) else 0


def segment_intersection(s1, e1, s2, e2):
    """IsIntersectLine: the point where segments s1-e1 and s2-e2 meet (ends included), or None (also if parallel)."""
    d1 = (e1[0] - s1[0], e1[1] - s1[1])
    d2 = (e2[0] - s2[0], e2[1] - s2[1])
    denom = d1[0] * d2[1] - d1[1] * d2[0]
    if denom == 0.0:
        return None
    w = (s2[0] - s1[0], s2[1] - s1[1])
    t = (w[0] * d2[1] - w[1] * d2[0]) / denom
    s = (w[0] * d1[1] - w[1] * d1[0]) / denom
    if not (0.0 <= t <= 1.0 and 0.0 <= s <= 1.0):
        return None
    return (s1[0] + t * d1[0], s1[1] + t * d1[1])


def signed_area(ring: np.ndarray) -> float:
    """Shoelace area: > 0 counter-clockwise (y up)."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def point_in_polygon(ring: np.ndarray, p) -> bool:
    """Non-zero winding of ``ring`` around p: signed crossings of the ray from p towards +x (half-open in y)."""
    winding = 0
    n = len(ring)
    for i in range(n):
        a, b = ring[i], ring[(i + 1) % n]
        if a[1] <= p[1] < b[1] and check_line(p, a, b) < 0:  # upward edge with p on its left
            winding += 1
        elif b[1] <= p[1] < a[1] and check_line(p, a, b) > 0:  # downward edge with p on its right
            winding -= 1
    return winding != 0


# }}}

# {{{ Polygon.cs, TreeNode.cs, CheckInPolygonTree


@dataclass
class Polygon:
    """One input ring: float64 vertices, its winding and bounding box, and its index in the input."""

    vertices: np.ndarray
    index: int

    @property
    def loop(self) -> str:
        area = signed_area(self.vertices)
        return CCW if area > 0 else (CW if area < 0 else ERR)

    @property
    def rect_area(self) -> float:
        w, h = self.vertices.max(axis=0) - self.vertices.min(axis=0)
        return float(w * h)

    def contains(self, other: Polygon) -> bool:
        """IsPointInPolygon(Polygon): every vertex of ``other`` inside this ring."""
        return all(point_in_polygon(self.vertices, p) for p in other.vertices)

    def reverse(self) -> None:
        self.vertices = self.vertices[::-1].copy()


@dataclass
class TreeNode:
    """TreeNode<Polygon>: ``polygon`` None is the dummy root."""

    polygon: Polygon | None = None
    children: list[TreeNode] = field(default_factory=list)
    level: int = 0


def book_sort(items: list, key) -> list:
    """List.Sort with the book's comparator ``FloorToInt(key(b) - key(a))`` (descending; differences below 1 are
    ties), as .NET's ArraySortHelper orders small lists: two or three compare-and-swaps, else an insertion sort."""

    def compare(a, b) -> int:
        return math.floor(key(b) - key(a))

    items = list(items)
    n = len(items)

    def swap_if_greater(i: int, j: int) -> None:
        if compare(items[i], items[j]) > 0:
            items[i], items[j] = items[j], items[i]

    if n == 2:
        swap_if_greater(0, 1)
    elif n == 3:
        swap_if_greater(0, 1)
        swap_if_greater(0, 2)
        swap_if_greater(1, 2)
    else:
        for i in range(1, n):
            t, j = items[i], i - 1
            while j >= 0 and compare(t, items[j]) < 0:
                items[j + 1] = items[j]
                j -= 1
            items[j + 1] = t
    return items


def sort_descending(items: list, key, variant: str) -> list:
    if variant == "book":
        return book_sort(items, key)
    return sorted(items, key=cmp_to_key(lambda a, b: (key(b) > key(a)) - (key(b) < key(a))))  # stable, exact


def build_tree(rings: list[np.ndarray], variant: str = "fixed") -> TreeNode:
    """The containment tree under a dummy root; rings re-oriented as they are adopted (odd level CW, even CCW)."""
    polygons = [Polygon(np.asarray(r, np.float64).copy(), i) for i, r in enumerate(rings)]
    root = TreeNode()
    for polygon in sort_descending(polygons, lambda p: p.rect_area, variant):
        _insert(root, polygon, 1)
    return root


def _insert(node: TreeNode, polygon: Polygon, level: int) -> bool:
    """CheckInPolygonTree: a node with a polygon takes the ring only if it contains it; then a child that contains
    it takes it, else the node adopts it."""
    if node.polygon is not None and not node.polygon.contains(polygon):
        return False
    in_child = False
    for child in node.children:
        in_child |= _insert(child, polygon, level + 1)
    if in_child:
        return True
    if (level % 2 == 0 and polygon.loop == CW) or (level % 2 == 1 and polygon.loop == CCW):
        polygon.reverse()
    node.children.append(TreeNode(polygon, level=level))
    return True


# }}}

# {{{ CombineOuterAndInners, CombinePolygon


def right_most(vertices: np.ndarray) -> int:
    """Index of the first vertex with the largest x (XMaxData.index)."""
    return int(np.argmax(vertices[:, 0]))


def combine_outer_and_inners(outer: np.ndarray, holes: list[np.ndarray], max_x: float, variant: str = "fixed"):
    """Bridge every hole into ``outer``, right-most hole first; returns (merged ring, holes that were dropped)."""
    pairs = [(float(h[right_most(h), 0]), i, right_most(h)) for i, h in enumerate(holes)]
    dropped = []
    for _, number, index in sort_descending(pairs, lambda pair: pair[0], variant):
        merged = combine_polygon(outer, holes[number], index, max_x)
        if merged is None:
            log.warning("ear clipping: the ray from a hole's right-most vertex meets no outer edge; hole dropped")
            dropped.append(number)
        else:
            outer = merged
    return outer, dropped


def bridge_intersection(M, ray_end, outer: np.ndarray):
    """GetIntersectionPoint: the nearest crossing of the ray M -> ray_end with an outer edge that starts at or above
    M and ends at or below it (a downward edge of the clockwise ring; bridges already cut go upward and are never
    chosen); ties go to the later edge. Returns (I, start index, end index) or None."""
    best, hit = math.inf, None
    n = len(outer)
    for index in range(n):
        nxt = (index + 1) % n
        start, end = outer[index], outer[nxt]
        if start[1] - M[1] < 0.0 or end[1] - M[1] > 0.0:
            continue
        point = segment_intersection(M, ray_end, start, end)
        if point is not None:
            distance = math.hypot(point[0] - M[0], point[1] - M[1])
            if best >= distance:
                best, hit = distance, (point, index, nxt)
    return hit


def combine_polygon(outer: np.ndarray, hole: np.ndarray, m: int, max_x: float):
    """Cut a bridge from M = hole[m] to a visible outer vertex and splice the hole in (None if the ray hits nothing).

    P is the right end of the edge the ray meets first. If I != P, the reflex outer vertices right of M inside the
    clockwise triangle M, I, P could hide P: the one with the smallest angle IMR is taken instead."""
    M = hole[m]
    hit = bridge_intersection(M, (max_x + RAY_EXTENSION, M[1]), outer)
    if hit is None:
        return None
    point, i0, i1 = hit
    if outer[i0, 0] > outer[i1, 0]:
        p_index, triangle = i0, (M, outer[i0], point)
    else:
        p_index, triangle = i1, (M, point, outer[i1])
    P = outer[p_index]
    final = p_index
    if math.hypot(point[0] - P[0], point[1] - P[1]) > 0.0:
        angle_min = ANGLE_MIN_START
        n = len(outer)
        for i in range(n):
            if i == p_index:
                continue
            v = outer[i]
            if v[0] < M[0] or (v[0] == P[0] and v[1] == P[1]):  # left of M, or a copy of P made by an earlier bridge
                continue
            reflex = not is_convex(v, outer[i - 1], outer[(i + 1) % n])
            if reflex and in_triangle(v, *triangle) <= 0:
                angle = vector_angle((point[0] - M[0], point[1] - M[1]), (v[0] - M[0], v[1] - M[1]))
                if angle < angle_min:
                    angle_min, final = angle, i
    ring = np.concatenate([outer[: final + 1], hole[m:], hole[:m], [M, outer[final]], outer[final + 1 :]])
    return ring


def vector_angle(a, b) -> float:
    """Unity's Vector3.Angle: the unsigned angle in degrees (0 when either vector is zero)."""
    denominator = math.sqrt((a[0] ** 2 + a[1] ** 2) * (b[0] ** 2 + b[1] ** 2))
    if denominator < 1e-15:
        return 0.0
    cosine = max(-1.0, min(1.0, (a[0] * b[0] + a[1] * b[1]) / denominator))
    return math.degrees(math.acos(cosine))


# }}}

# {{{ InitializeVertices, CheckVertex, EarClipping

WELL_SHAPED = 2.0**-30
"""An ear triangle whose doubled area exceeds this times the square of its bounding box's longer side has no angle
so thin that float64 rounding could let a vertex farther than ``NEAR`` times that side from it pass the ear test
(then the test reads only the vertices of nearby grid cells); a thinner one reads every live vertex."""
NEAR = 2.0**-10
"""How close to a well-shaped ear triangle, relative to its longer side, a vertex must be to be read by the test."""
GRID_BITS_OVER = 2
"""The grid has about 2^this times sqrt(n) cells a side (16 to 64 cells per vertex) ..."""
MAX_GRID_BITS = 11
"""... and at most 2^this (its table of where each cell's vertices start: 4^this int32)."""
BATCH_ABOVE = 64
"""Polygons of at least this many vertices run InitializeVertices' ear tests together in numpy."""
SPLIT_ABOVE = 32
"""A z-order range of more vertices than this is split in two."""
TEST_BOX_ABOVE = 8
"""A z-order range of more vertices than this is dropped when its box is far from the triangle."""
EPSILON = 2.0**-52
"""float64's machine epsilon (rounding error bounds)."""


def _spread_bits() -> np.ndarray:
    """Every 16-bit integer with its bits moved to the even positions: a cell's z-order key (Morton code) is
    spread(i) | spread(j) << 1."""
    v = np.arange(1 << 16, dtype=np.int64)
    for shift, mask in ((8, 0x00FF00FF), (4, 0x0F0F0F0F), (2, 0x33333333), (1, 0x55555555)):
        v = (v | (v << shift)) & mask
    return v


SPREAD = _spread_bits()
SPREAD_LIST = SPREAD.tolist()


class EarClipper:
    """The clipping state of one merged polygon: the book's ``vertices``, ``indices`` (a LinkedList<int>, here the
    ``prev``/``next`` lists; clipped vertices leave ``z_live``) and ``earTipList`` (a FIFO list, here linked through
    ``ear_next``/``ear_prev`` so that removing an ear anywhere costs O(1); ``listed`` marks its members).

    The ear test asks whether any live vertex lies in or on the triangle (float64 CheckLine signs). Only vertices
    near the triangle can, so the vertices are bucketed once into a grid of about n cells, sorted by the cells'
    z-order keys: the cells of any box are a range of that order, and ranges that are long are split in two along
    the z-order until they are short or provably far from the triangle. The vertices read are then tested with the
    same expressions as the book's scan over all of them, so the answer is the same."""

    def __init__(self, points: np.ndarray, robust: bool = False):
        self.robust = robust
        self.points = np.asarray(points, np.float64).reshape(-1, 2)
        n = len(self.points)
        self.x, self.y = self.points[:, 0].tolist(), self.points[:, 1].tolist()
        self.prev = [(i - 1) % n for i in range(n)]
        self.next = [(i + 1) % n for i in range(n)]
        self.count = n
        self.finished = False  # the last triangle is out
        self.ear_next, self.ear_prev = [n] * (n + 1), [n] * (n + 1)  # index n (or -1): the head/tail sentinel
        self.listed = [False] * n
        self._bucket()

    def _bucket(self) -> None:
        """The grid (``cells`` a side over the polygon's bounding square): the vertex ids sorted by their cell's
        z-order key (``z_order``, coordinates ``zx``/``zy``) and, for every key, where its cell's vertices start in
        that order (``z_start``). Non-finite or huge coordinates (``gridded`` False) make every test a full scan."""
        n = len(self.points)
        lo, hi = (self.points.min(axis=0), self.points.max(axis=0)) if n else (np.zeros(2), np.ones(2))
        extent = float(max(hi - lo))
        magnitude = float(np.abs(np.concatenate([lo, hi])).max())
        self.gridded = bool(np.isfinite(magnitude)) and magnitude < 1e150 and extent > 0.0
        extent = extent if self.gridded else 1.0
        self.cells = 1 << min(MAX_GRID_BITS, GRID_BITS_OVER + math.ceil(math.log2(max(n, 2)) / 2))
        self.origin, self.scale = (float(lo[0]), float(lo[1])), self.cells / extent
        self.cell_size = extent / self.cells
        self.slop = 16.0 * EPSILON * (magnitude + extent)  # how far rounding can put a vertex outside its cell
        with np.errstate(invalid="ignore"):
            cells = np.nan_to_num((self.points - lo) * self.scale).astype(np.int64).clip(0, self.cells - 1)
        keys = SPREAD[cells[:, 0]] | (SPREAD[cells[:, 1]] << 1)
        order = np.argsort(keys, kind="stable")
        self.z_order = order.tolist()
        self.z_start = array("i", np.searchsorted(keys[order], np.arange(self.cells**2 + 1)).astype(np.int32).tobytes())
        self.z_rank = np.argsort(order).tolist()
        self.z_x, self.z_y = self.points[order, 0], self.points[order, 1]
        self.zx, self.zy = self.z_x.tolist(), self.z_y.tolist()
        self.z_alive = np.ones(n, bool)
        self.z_live = list(range(n + 1))  # union-find: a rank points to itself while its vertex lives (n: the end)

    def live_from(self, rank: int) -> int:
        """The first rank at or after ``rank`` whose vertex is alive (n if none), compressing the path."""
        live = self.z_live
        found = rank
        while live[found] != found:
            found = live[found]
        while live[rank] != found:
            live[rank], rank = found, live[rank]
        return found

    @property
    def ears(self) -> list[int]:
        """The ear list, head first."""
        found, e = [], self.ear_next[-1]
        while e != len(self.listed):
            found.append(e)
            e = self.ear_next[e]
        return found

    def initialize_vertices(self) -> None:
        """InitializeVertices: the first ear list, vertices in ring order. Nothing is clipped yet, so the ear tests
        are independent: they run together (``initial_ears``) on all but small polygons."""
        n = len(self.points)
        if self.robust:
            changed = True
            while changed and self.count > 3:  # passes in index order until none is flat (as the kernel does)
                changed = False
                for v in range(n):
                    if self.count > 3 and self.z_alive[self.z_rank[v]] and self._flat(v):
                        self._remove(v)
                        changed = True
            if self.count == 3 and self._flat(self.live_cycle()[0], straight=True):
                self._finish()  # what is left covers nothing
                return
        ears = self.initial_ears() if n >= BATCH_ABOVE and self.gridded else map(self.is_ear, range(n))
        for v, ear in enumerate(ears):
            if ear and self.z_alive[self.z_rank[v]]:
                self._append(v)

    def initial_ears(self) -> list[bool | None]:
        """``is_ear`` of every vertex at once: is_ear's grid search run breadth first over all well-shaped convex
        corners together in numpy, then its CheckLine expressions on the vertices read; the other convex corners
        go through ``is_ear``."""
        a, b, c = self.points[self.prev], self.points, self.points[self.next]
        ax, ay, bx, by, cx, cy = a[:, 0], a[:, 1], b[:, 0], b[:, 1], c[:, 0], c[:, 1]
        doubled_area = (ax - bx) * (cy - by) - (ay - by) * (cx - bx)
        lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
        side = (hi - lo).max(axis=1)
        convex = doubled_area > 0.0
        batched = convex & (side > 1e-100) & (doubled_area > WELL_SHAPED * side * side)
        t = np.flatnonzero(batched)
        near = side[t, None] * NEAR
        box = np.hstack([lo[t] - near, hi[t] + near]) - np.tile(self.origin, 2)  # lox, loy, hix, hiy
        cell = (box * self.scale).astype(np.int64).clip(0, self.cells - 1)
        i0, j0, i1, j1 = cell.T
        beyond = self.beyond(side[t], near[:, 0])
        edges = [  # (p1, p2 - p1, limit) of the edges (v, next), (next, prev), (prev, v) of every triangle
            (p1[t], d, -beyond * np.abs(d).max(axis=1))
            for p1, d in ((b, c[t] - b[t]), (c, a[t] - c[t]), (a, b[t] - a[t]))
        ]
        start, size, (x0, y0) = np.frombuffer(self.z_start, np.int32), self.cell_size, self.origin
        where, first, last = ([np.zeros(0, np.int64)] for _ in range(3))
        k = np.arange(len(t))  # the triangle of each box
        while len(k):
            z0, z1 = SPREAD[i0] | (SPREAD[j0] << 1), SPREAD[i1] | (SPREAD[j1] << 1)
            lo_rank, hi_rank = start[z0], start[z1 + 1]
            far = np.zeros(len(k), bool)
            for p1, d, limit in edges:
                dx, dy = d[k, 0], d[k, 1]
                ox = x0 + np.where(dy > 0.0, i1 + 1, i0) * size
                oy = y0 + np.where(dx > 0.0, j0, j1 + 1) * size
                far |= (ox - p1[k, 0]) * dy - dx * (oy - p1[k, 1]) < limit[k]
            keep = (hi_rank > lo_rank) & ~far
            split = keep & (hi_rank - lo_rank > SPLIT_ABOVE) & (z0 != z1)
            read = keep & ~split
            where.append(k[read])
            first.append(lo_rank[read])
            last.append(hi_rank[read])
            bit = np.frexp((z0 ^ z1)[split].astype(float))[1] - 1
            half, in_y = bit >> 1, (bit & 1).astype(bool)
            i0, i1, j0, j1, k = i0[split], i1[split], j0[split], j1[split], k[split]
            mid_i, mid_j = (i1 >> half) << half, (j1 >> half) << half
            i0, i1 = (
                np.concatenate([i0, np.where(in_y, i0, mid_i)]),
                np.concatenate([np.where(in_y, i1, mid_i - 1), i1]),
            )
            j0, j1 = (
                np.concatenate([j0, np.where(in_y, mid_j, j0)]),
                np.concatenate([np.where(in_y, mid_j - 1, j1), j1]),
            )
            k = np.concatenate([k, k])
        where, first, last = np.concatenate(where), np.concatenate(first), np.concatenate(last)
        counts = last - first
        pair = np.repeat(where, counts)
        rank = np.arange(counts.sum()) + np.repeat(first - np.cumsum(counts) + counts, counts)
        ox, oy, tri = self.z_x[rank], self.z_y[rank], t[pair]
        inside = self.z_alive[rank].copy()  # the robust clipper may have dropped flat vertices already
        corner = np.zeros(len(rank), bool)
        for p1, p2 in ((b, c), (c, a), (a, b)):
            (px, py), (qx, qy) = p1[tri].T, p2[tri].T
            inside &= (ox - px) * (qy - py) - (qx - px) * (oy - py) >= 0.0
            corner |= (ox == px) & (oy == py)
        blocked = np.zeros(len(self.points), bool)
        blocked[tri[inside & ~corner]] = True
        if self.robust:  # a vertex at a corner may block (corner_blocks): those triangles take the scalar test
            batched = batched.copy()
            batched[tri[inside & corner]] = False
        ears: list[bool | None] = [None] * len(self.points)
        for v in np.flatnonzero(convex).tolist():
            ears[v] = not blocked[v] if batched[v] else self.is_ear(v)
        return ears

    def beyond(self, side, near):
        """A grid box is farther than ``near`` from a triangle whose bounding box's longer side is ``side`` when
        all its corners lie beyond one edge's line by more than this times the edge's longer coordinate difference
        (1.5 > sqrt 2 turns that into the edge's length; rounding of the cell bounds and of CheckLine included)."""
        return 1.5 * near + 2.0 * self.slop + 16.0 * EPSILON * (side + 2.0 * (near + self.cell_size + self.slop))

    def is_ear(self, v: int) -> bool | None:
        """None for a reflex vertex; else whether no other live vertex lies in or on the triangle (prev, v, next).
        Vertices at the same coordinates as a corner (bridge copies) are ignored, as the book does."""
        p, q = self.prev[v], self.next[v]
        x, y = self.x, self.y
        ax, ay, bx, by, cx, cy = x[p], y[p], x[v], y[v], x[q], y[q]
        doubled_area = (ax - bx) * (cy - by) - (ay - by) * (cx - bx)
        if not doubled_area > 0.0:
            return None
        lox, hix, loy, hiy = min(ax, bx, cx), max(ax, bx, cx), min(ay, by, cy), max(ay, by, cy)
        side = max(hix - lox, hiy - loy)
        if not (self.gridded and side > 1e-100 and doubled_area > WELL_SHAPED * side * side):
            return self._scan_all(p, v, q)
        near = side * NEAR
        lox, hix, loy, hiy = lox - near, hix + near, loy - near, hiy + near
        # CheckLine(o, p1, p2) >= 0 for the edges (v, next), (next, prev), (prev, v): o in or on the triangle
        bcx, bcy, cax, cay, abx, aby = cx - bx, cy - by, ax - cx, ay - cy, bx - ax, by - ay
        corners = ((ax, ay), (bx, by), (cx, cy))
        beyond, size = self.beyond(side, near), self.cell_size
        lim_bc = -beyond * max(abs(bcx), abs(bcy))
        lim_ca = -beyond * max(abs(cax), abs(cay))
        lim_ab = -beyond * max(abs(abx), abs(aby))
        x0, y0, scale, top = self.origin[0], self.origin[1], self.scale, self.cells - 1
        spread, start, zx, zy, live, live_from = (
            SPREAD_LIST,
            self.z_start,
            self.zx,
            self.zy,
            self.z_live,
            self.live_from,
        )
        i0, i1, j0, j1 = (
            int((lox - x0) * scale),
            int((hix - x0) * scale),
            int((loy - y0) * scale),
            int((hiy - y0) * scale),
        )
        i0, i1, j0, j1 = max(i0, 0), min(i1, top), max(j0, 0), min(j1, top)  # the cells of the grown bounding box
        z0, z1 = spread[i0] | (spread[j0] << 1), spread[i1] | (spread[j1] << 1)
        boxes = [(i0, i1, j0, j1, z0, z1, start[z0], start[z1 + 1])]
        while boxes:
            i0, i1, j0, j1, z0, z1, first, last = boxes.pop()
            rank = first if live[first] == first else live_from(first)
            if rank >= last:
                continue
            if last - first > TEST_BOX_ABOVE:
                left, right, bottom, upper = x0 + i0 * size, x0 + (i1 + 1) * size, y0 + j0 * size, y0 + (j1 + 1) * size
                # each edge's CheckLine at the box corner deepest inside its half-plane
                if (
                    ((right if bcy > 0.0 else left) - bx) * bcy - bcx * ((bottom if bcx > 0.0 else upper) - by) < lim_bc
                    or ((right if cay > 0.0 else left) - cx) * cay - cax * ((bottom if cax > 0.0 else upper) - cy)
                    < lim_ca
                    or ((right if aby > 0.0 else left) - ax) * aby - abx * ((bottom if abx > 0.0 else upper) - ay)
                    < lim_ab
                ):
                    continue
                if last - first > SPLIT_ABOVE and z0 != z1:
                    bit = (z0 ^ z1).bit_length() - 1  # split where the box's z-order range jumps
                    half = bit >> 1
                    if bit & 1:
                        mid = (j1 >> half) << half
                        low, high = (i0, i1, j0, mid - 1), (i0, i1, mid, j1)
                    else:
                        mid = (i1 >> half) << half
                        low, high = (i0, mid - 1, j0, j1), (mid, i1, j0, j1)
                    z_low, z_high = spread[low[1]] | (spread[low[3]] << 1), spread[high[0]] | (spread[high[2]] << 1)
                    if start[z_low + 1] > first:  # halves without vertices are not kept
                        boxes.append((*low, z0, z_low, first, start[z_low + 1]))
                    if last > start[z_high]:
                        boxes.append((*high, z_high, z1, start[z_high], last))
                    continue
            while rank < last:  # p, v, q themselves are skipped as corners
                ox, oy = zx[rank], zy[rank]
                here = rank
                rank = rank + 1 if live[rank + 1] == rank + 1 else live_from(rank + 1)
                if (
                    lox <= ox <= hix
                    and loy <= oy <= hiy
                    and (ox - bx) * bcy - bcx * (oy - by) >= 0.0
                    and (ox - cx) * cay - cax * (oy - cy) >= 0.0
                    and (ox - ax) * aby - abx * (oy - ay) >= 0.0
                ):
                    if (ox, oy) not in corners:
                        return False
                    if self.robust and self.corner_blocks(self.z_order[here], p, v, q):
                        return False
        return True

    def corner_blocks(self, k: int, p: int, v: int, q: int) -> bool:
        """The robust rule for a live vertex k at the coordinates of a corner of the ear (prev p, v, next q) and
        not one of them (a bridge copy, a point the polygon visits twice): it blocks the ear when one of its edges
        leaves that corner into the triangle's open angle there, that is, when the polygon's boundary enters the
        triangle. The book lets every such vertex pass."""
        if k in (p, v, q):
            return False
        x, y = self.x, self.y
        triangle = ((p, v, q), (v, q, p), (q, p, v))  # clockwise: each corner with the one after and before it
        for corner, after, before in triangle:
            if x[corner] != x[k] or y[corner] != y[k]:
                continue
            if corner != v and not self._diagonal_inside(corner, q if corner == p else p):
                return True
            kx, ky = x[k], y[k]
            ux, uy = x[after] - kx, y[after] - ky  # the triangle's angle at the corner: from `after` clockwise...
            wx, wy = kx - x[before], ky - y[before]  # ... to `before` (the edge into the corner)
            for n in (self.prev[k], self.next[k]):
                dx, dy = x[n] - kx, y[n] - ky
                if ux * dy - uy * dx < 0.0 and wx * dy - wy * dx < 0.0:  # right of both: inside the angle
                    return True
        return False

    def _diagonal_inside(self, corner: int, target: int) -> bool:
        """Where the polygon visits a point more than once, the new edge corner -> target must leave the corner
        inside the region's own angle at that visit (exact signs; the region is on the right of this clockwise
        ring, so the ring is read backwards for ``in_cone``)."""
        pts = self.points
        before, after = self.prev[corner], self.next[corner]
        if any(np.array_equal(pts[n], pts[corner]) for n in (before, after)):
            return False  # a zero-length edge: no angle to be inside of (the last-resort stage removes it)
        return in_cone(pts[after], pts[corner], pts[before], pts[target])

    def _scan_all(self, p: int, v: int, q: int) -> bool:
        """The ear test over every live vertex (for sliver triangles and non-finite or huge coordinates)."""
        x, y = self.x, self.y
        ax, ay, bx, by, cx, cy = x[p], y[p], x[v], y[v], x[q], y[q]
        ox, oy = self.z_x, self.z_y
        inside = (
            self.z_alive
            & ((ox - bx) * (cy - by) - (cx - bx) * (oy - by) >= 0.0)
            & ((ox - cx) * (ay - cy) - (ax - cx) * (oy - cy) >= 0.0)
            & ((ox - ax) * (by - ay) - (bx - ax) * (oy - ay) >= 0.0)
        )
        for k in np.flatnonzero(inside).tolist():
            k = self.z_order[k]
            if k in (p, v, q):
                continue
            if (x[k], y[k]) not in ((ax, ay), (bx, by), (cx, cy)):
                return False
            if self.robust and self.corner_blocks(k, p, v, q):
                return False
        return True

    def check_vertex(self, v: int) -> None:
        """CheckVertex: a convex vertex becomes an ear (appended at the end) or stops being one (removed in place);
        a reflex vertex leaves the list as it is (the book's CheckVertex only acts on convex vertices)."""
        ear = self.is_ear(v)
        if ear is None and self.robust:
            ear = False  # no longer convex: it leaves the list (the book keeps it there, to be clipped flat)
        if ear is None or ear == self.listed[v]:
            return
        if ear:
            self._append(v)
        else:
            self._unlist(v)

    def _append(self, v: int) -> None:
        tail = self.ear_prev[-1]
        self.ear_next[tail], self.ear_prev[v], self.ear_next[v], self.ear_prev[-1] = v, tail, len(self.listed), v
        self.listed[v] = True

    def _unlist(self, v: int) -> None:
        before, after = self.ear_prev[v], self.ear_next[v]
        self.ear_next[before], self.ear_prev[after] = after, before
        self.listed[v] = False

    def live_cycle(self) -> list[int]:
        """The vertices not clipped yet, in ring order (empty once the last triangle is out)."""
        if self.finished or self.count < 3:
            return []
        start = self.z_order[int(np.flatnonzero(self.z_alive)[0])]
        cycle, v = [start], self.next[start]
        while v != start:
            cycle.append(v)
            v = self.next[v]
        return cycle

    def clip(self) -> tuple[int, int, int] | None:
        """One pass of EarClipping's loop: the head ear's triangle (prev, ear, next), or None when the list is empty.
        After the last triangle (3 vertices left) the ear list is cleared."""
        e = self.ear_next[-1]
        if e == len(self.listed):
            return None
        p, q = self.prev[e], self.next[e]
        if self.count == 3:
            self._finish()
            return p, e, q
        self._remove(e)
        triangle = p, e, q
        if self.robust:
            while self.count > 3:  # the robust filter: the ring turning back on itself at p or q is dropped
                if self._flat(p):
                    p, gone = self.prev[p], p
                elif self._flat(q):
                    q, gone = self.next[q], q
                else:
                    break
                self._remove(gone)
            if self.count == 3 and self._flat(p, straight=True):
                self._finish()  # what is left covers nothing
                return triangle
        self.check_vertex(p)
        self.check_vertex(q)
        return triangle

    def _remove(self, v: int) -> None:
        """Unlink v from the ring (and the ear list) and the grid's live vertices."""
        if self.listed[v]:
            self._unlist(v)
        p, q = self.prev[v], self.next[v]
        self.next[p], self.prev[q] = q, p
        rank = self.z_rank[v]
        self.z_alive[rank] = False
        self.z_live[rank] = rank + 1
        self.count -= 1

    def _flat(self, v: int, straight: bool = False) -> bool:
        """The robust clipper's filter (not in the book): the ring turns back on itself at v (the tip of a zero-width
        spike, a repeated point), so v covers nothing and is unlinked without a triangle. A part retraced both ways
        once the area around it is clipped would otherwise pass ear tests it must not. A vertex on a straight run
        is not flat (``straight``: it is, for the last three) and is clipped later, with a neighbour."""
        a, b, c = self.points[self.prev[v]], self.points[v], self.points[self.next[v]]
        return orient(a, b, c) == 0 and (straight or float(np.dot(a - b, c - b)) >= 0.0)

    def _finish(self) -> None:
        """The last triangle is out (or what is left covers nothing): the ear list is cleared."""
        self.finished = True
        self.ear_next[-1] = self.ear_prev[-1] = len(self.listed)
        self.listed = [False] * len(self.listed)


# }}}


# {{{ Triangulate


@dataclass
class Triangulation:
    """What ``triangulate`` returns (the arrays of the scene's .npz)."""

    vertices: np.ndarray
    """(V, 2) float64: every merged polygon's vertices in processing order, bridge copies included."""
    triangles: np.ndarray
    """(T, 3) int32 into ``vertices``: (prev, ear, next), clockwise."""
    uv: np.ndarray
    """(V, 2) float32: planar UVs over the bounding box of all input rings (CalcUV)."""
    group_offsets: np.ndarray
    """(G + 1,) int32 into ``vertices``: one group per merged polygon (outer ring + its holes)."""
    complete: np.ndarray
    """(G,) bool: the group's ear list lasted to its last triangle."""
    group_rings: list[list[int]]
    """Input ring indices of each group: the outer first, then its holes."""
    tree_parent: np.ndarray
    """(R,) int32: the input ring that contains each ring directly (-1: top level)."""
    tree_level: np.ndarray
    """(R,) int32: depth in the containment tree (1 = outer boundary, 2 = hole, 3 = island ...)."""
    oriented: list[np.ndarray]
    """The input rings after build_tree's re-orientation (odd levels CW, even CCW)."""
    dropped: list[int]
    """Input rings (holes) that no bridge reached."""
    ear_trace: list[tuple[int, ...]] | None = None
    """Per triangle: the ear list (global vertex indices) when it was clipped, its head first (record=True)."""
    altered: dict = field(default_factory=dict)
    """What the robust pre-pass had to change in the input: {what: how many} (empty for the book's pipeline)."""


def triangulate(rings, variant: str = "robust", record: bool = False) -> Triangulation:
    """Triangulate: build the tree, merge each outer ring with its holes, clip; grandchildren become new outers.
    ``variant="robust"`` (the default) runs the pre-pass and the last-resort stage around the same clipper
    (``triangulate_robust``); "fixed" and "book" are the chapter's pipeline."""
    if variant == "robust":
        return triangulate_robust(rings, record)
    rings = [np.asarray(r, np.float64).reshape(-1, 2) for r in rings]
    every = np.concatenate(rings) if rings else np.zeros((0, 2))
    lo, hi = (every.min(axis=0), every.max(axis=0)) if len(every) else (np.zeros(2), np.ones(2))
    span = np.where(hi > lo, hi - lo, 1.0)  # a flat input would divide by zero in CalcUV
    root = build_tree(rings, variant)
    parent = np.full(len(rings), -1, np.int32)
    level = np.zeros(len(rings), np.int32)
    oriented: list[np.ndarray] = [np.zeros((0, 2))] * len(rings)
    vertices, triangles, offsets, complete, groups, dropped = [], [], [0], [], [], []
    trace: list[tuple[int, ...]] | None = [] if record else None
    queue = deque(root.children)
    while queue:
        node = queue.popleft()
        for child in node.children:
            parent[child.polygon.index] = node.polygon.index
        holes = [child.polygon for child in node.children]
        for polygon, depth in [(node.polygon, node.level)] + [(h, node.level + 1) for h in holes]:
            level[polygon.index], oriented[polygon.index] = depth, polygon.vertices
        for child in node.children:
            for grandchild in child.children:  # islands in the holes: outers of their own groups, later
                parent[grandchild.polygon.index] = child.polygon.index
            queue.extend(child.children)
        merged, lost = combine_outer_and_inners(node.polygon.vertices, [h.vertices for h in holes], hi[0], variant)
        dropped += [holes[i].index for i in lost]
        groups.append([node.polygon.index] + [h.index for h in holes])
        offset = offsets[-1]
        clipper = EarClipper(merged)
        clipper.initialize_vertices()
        first = len(triangles)
        while True:
            if trace is not None and (ears := clipper.ears):
                trace.append(tuple(offset + e for e in ears))
            triangle = clipper.clip()
            if triangle is None:
                break
            triangles.append([offset + v for v in triangle])
        vertices.append(merged)
        offsets.append(offset + len(merged))
        complete.append(len(triangles) - first == len(merged) - 2)
    points = np.concatenate(vertices) if vertices else np.zeros((0, 2))
    return Triangulation(
        vertices=points,
        triangles=np.asarray(triangles, np.int32).reshape(-1, 3),
        uv=((points - lo) / span).astype(np.float32),
        group_offsets=np.asarray(offsets, np.int32),
        complete=np.asarray(complete, bool),
        group_rings=groups,
        tree_parent=parent,
        tree_level=level,
        oriented=oriented,
        dropped=dropped,
        ear_trace=trace,
    )


def triangulate_robust(rings, record: bool = False) -> Triangulation:
    """The robust default: ``ear_clipping_prepass.prepare`` (cleaned rings, touching points shared, rings split where
    they touch themselves, exact nesting and bridges), then the chapter's clipper with the robust corner rule
    (``EarClipper.corner_blocks``) and, should the ear list run dry, ``finish`` (the last-resort stage)."""
    rings = [np.asarray(r, np.float64).reshape(-1, 2) for r in rings]
    prepared = prepare(rings)
    every = np.concatenate(rings) if rings else np.zeros((0, 2))
    lo, hi = (every.min(axis=0), every.max(axis=0)) if len(every) else (np.zeros(2), np.ones(2))
    span = np.where(hi > lo, hi - lo, 1.0)
    vertices, triangles, offsets, complete = [], [], [0], []
    trace: list[tuple[int, ...]] | None = [] if record else None
    for polygon in prepared.polygons:
        offset = offsets[-1]
        ears = [] if trace is not None else None
        found, done = clip_robust(polygon, ears)
        if trace is not None:
            trace += [tuple(offset + e for e in listed) for listed in ears]
        triangles += [[offset + v for v in t] for t in found]
        vertices.append(polygon)
        offsets.append(offset + len(polygon))
        complete.append(done)
    points = np.concatenate(vertices) if vertices else np.zeros((0, 2))
    triangles_array = np.asarray(triangles, np.int32).reshape(-1, 3)
    wanted = input_area(rings, [level + 1 for level in nesting_levels(rings)]) if rings else 0.0
    covered = float(np.abs(triangle_signed_areas(points, triangles_array)).sum()) if len(points) else 0.0
    if not all(complete) or abs(covered - wanted) > 1e-9 * abs(wanted):
        prepared.notes.update(diagnose(rings))  # fell short: say so if the input is to blame
    first_loop = {}
    for k, ring in enumerate(prepared.loop_ring):
        first_loop.setdefault(ring, k)
    parent = np.full(len(rings), -1, np.int32)
    level = np.zeros(len(rings), np.int32)
    oriented = [np.zeros((0, 2))] * len(rings)
    for ring, k in first_loop.items():
        up = prepared.parent[k]
        parent[ring] = prepared.loop_ring[up] if up >= 0 else -1
        level[ring] = prepared.depth[k]
        oriented[ring] = prepared.loops[k][::-1] if prepared.depth[k] % 2 else prepared.loops[k]
    return Triangulation(
        vertices=points,
        triangles=triangles_array,
        uv=((points - lo) / span).astype(np.float32),
        group_offsets=np.asarray(offsets, np.int32),
        complete=np.asarray(complete, bool),
        group_rings=[[prepared.loop_ring[k] for k in group] for group in prepared.group_loops],
        tree_parent=parent,
        tree_level=level,
        oriented=oriented,
        dropped=sorted({prepared.loop_ring[k] for k in prepared.lost}),
        ear_trace=trace,
        altered=prepared.notes,
    )


def clip_robust(polygon: np.ndarray, trace: list | None = None) -> tuple[list[tuple[int, int, int]], bool]:
    """One merged polygon (clockwise, as ``prepare`` gives it) clipped by the robust clipper, ``finish`` taking over
    where its ear list runs dry: (triangles as local indices, whether all of its area is covered). ``trace`` gets
    the ear list before each clip."""
    clipper = EarClipper(polygon, robust=True)
    clipper.initialize_vertices()
    found = []
    while True:
        if trace is not None and (ears := clipper.ears):
            trace.append(tuple(ears))
        triangle = clipper.clip()
        if triangle is None:
            break
        found.append(triangle)
    if clipper.finished:
        return found, True
    more, done = finish(polygon, clipper.live_cycle())
    return found + more, done


MAX_FINISH_DEPTH = 64
"""How deep the last-resort stage may split a polygon that keeps running out of ears."""


def finish(points: np.ndarray, cycle: list[int], depth: int = 0) -> tuple[list[tuple[int, int, int]], bool]:
    """The last-resort stage, for the vertices ``cycle`` (ids into ``points``, clockwise) that the ear list left:
    vertices where the ring turns back on itself are dropped (they cover nothing), then the rest is split along a
    diagonal that lies inside it and meets no edge (one exists in every simple polygon, exact signs find it) and
    each half is clipped again; a polygon that visits a point twice with both loops winding its way (pieces that
    only touch) is first split there. Returns (triangles, whether all of the area was covered)."""
    cycle = list(cycle)
    changed = True
    while changed and len(cycle) > 3:
        changed = False
        for i in range(len(cycle)):
            a, b, c = points[cycle[i - 1]], points[cycle[i]], points[cycle[(i + 1) % len(cycle)]]
            if orient(a, b, c) == 0 and float(np.dot(a - b, c - b)) >= 0.0:  # turns back: a spike, a repeat
                del cycle[i]
                changed = True
                break
    if len(cycle) < 3:
        return [], True
    if len(cycle) == 3:
        a, b, c = (points[k] for k in cycle)
        return ([tuple(cycle)] if orient(a, b, c) < 0 else []), orient(a, b, c) <= 0
    seen: dict[tuple, int] = {}
    for j, k in enumerate(cycle):  # a point visited twice: split there if both loops wind as the polygon does
        i = seen.setdefault(tuple(points[k].tolist()), j)
        if i != j:
            first, second = cycle[i:j], cycle[j:] + cycle[:i]
            if ring_sign(points[first]) < 0 and ring_sign(points[second]) < 0 and depth < MAX_FINISH_DEPTH:
                found, done = finish(points, first, depth + 1)
                more, also = finish(points, second, depth + 1)
                return found + more, done and also
    # clockwise cycle: reversed, the region is on the left (the pre-pass's convention for in_cone)
    ccw = cycle[::-1]
    pts = points[ccw]
    n = len(ccw)
    a_edges, b_edges = pts, np.roll(pts, -1, axis=0)
    if depth < MAX_FINISH_DEPTH:
        for i in range(n):
            others = sorted(range(n), key=lambda j: float(((pts[j] - pts[i]) ** 2).sum()))
            for j in others:
                if (j - i) % n in (0, 1, n - 1) or np.array_equal(pts[i], pts[j]):
                    continue
                if not in_cone(pts[i - 1], pts[i], pts[(i + 1) % n], pts[j]):
                    continue
                if not in_cone(pts[j - 1], pts[j], pts[(j + 1) % n], pts[i]):
                    continue
                if segment_blocked(pts[i], pts[j], a_edges, b_edges):
                    continue
                lo, hi = min(i, j), max(i, j)
                first, second = ccw[lo : hi + 1], ccw[hi:] + ccw[: lo + 1]
                found, done = [], True
                for half in (first, second):
                    clipper = EarClipper(points[half[::-1]], robust=True)
                    clipper.initialize_vertices()
                    ids = half[::-1]
                    while (t := clipper.clip()) is not None:
                        found.append(tuple(ids[k] for k in t))
                    if not clipper.finished:
                        more, ok = finish(points, [ids[k] for k in clipper.live_cycle()], depth + 1)
                        found += more
                        done &= ok
                return found, done
    return [], False


def nesting_levels(rings) -> list[int]:
    """How many other rings enclose each ring, from the rings alone (each tested against every other by its first
    vertex strictly inside or outside it, exact signs; ``ear_clipping_prepass.inside``): the input's own nesting,
    independent of the clipper's tree. Rings may touch, not cross."""
    arrays = [np.asarray(r, float).reshape(-1, 2) for r in rings]
    lo, hi = [a.min(axis=0) for a in arrays], [a.max(axis=0) for a in arrays]

    def holds(j: int, i: int) -> bool:  # ring j encloses ring i (its bounding box first)
        return bool((lo[j] <= lo[i]).all() and (hi[i] <= hi[j]).all()) and inside(arrays[i], arrays[j])

    return [sum(holds(j, i) for j in range(len(arrays)) if j != i) for i in range(len(arrays))]


def input_area(rings, levels) -> float:
    """|outer| - |holes| + |islands| ...: the area the triangles must cover (``ring_area`` for each ring)."""
    return float(sum((1 if lv % 2 else -1) * ring_area(r) for r, lv in zip(rings, levels, strict=True)))


def ring_area(ring) -> float:
    """The area a ring encloses: |shoelace area|, or for a ring with local self-intersections (edges one apart that
    cross) the sum over the loops they cut it into, each counted once whichever way it winds (a bowtie's two
    lobes)."""
    pts = [p for p in np.asarray(ring, np.float64).reshape(-1, 2)]
    total, i = 0.0, 0
    while len(pts) >= 4 and i < len(pts):
        n = len(pts)
        a, b, c, d = pts[i], pts[(i + 1) % n], pts[(i + 2) % n], pts[(i + 3) % n]
        if orient(a, b, c) * orient(a, b, d) < 0 and orient(c, d, a) * orient(c, d, b) < 0:
            r, q = b - a, d - c
            x = a + ((c[0] - a[0]) * q[1] - (c[1] - a[1]) * q[0]) / (r[0] * q[1] - r[1] * q[0]) * r
            total += abs(signed_area(np.array([x, b, c]) - x))
            pts = pts[i:] + pts[:i]
            pts = [pts[0], x, *pts[3:]]
            i = 0
        else:
            i += 1
    return total + (abs(signed_area(np.array(pts) - pts[0])) if len(pts) >= 3 else 0.0)  # moved: far-off rings


def triangle_signed_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Signed area per triangle (< 0: clockwise, y up)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def merged_polygons(rings, variant: str = "robust") -> list[np.ndarray]:
    """The host's bridging without the clipping: one simple clockwise polygon per group (the batch kernel's input)."""
    if variant == "robust":
        return prepare(rings).polygons
    result = triangulate(rings, variant)
    o = result.group_offsets
    return [result.vertices[o[g] : o[g + 1]] for g in range(len(o) - 1)]


def clip_on_host(polygon: np.ndarray) -> np.ndarray:
    """The host's InitializeVertices + EarClipping on one merged polygon: its triangles, local indices."""
    clipper = EarClipper(polygon)
    clipper.initialize_vertices()
    found = []
    while (triangle := clipper.clip()) is not None:
        found.append(triangle)
    return np.asarray(found, np.int32).reshape(-1, 3)


# }}}

# {{{ Lawson flips (not in the book): the constrained Delaunay triangulation


def incircle(a, b, c, d) -> float:
    """> 0 when d is inside the circle through a, b, c given counter-clockwise (sign flips for clockwise)."""
    rows = [(p[0] - d[0], p[1] - d[1]) for p in (a, b, c)]
    m = [(x, y, x * x + y * y) for x, y in rows]
    return (
        m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2])
        - m[0][1] * (m[1][0] * m[2][2] - m[2][0] * m[1][2])
        + m[0][2] * (m[1][0] * m[2][1] - m[2][0] * m[1][1])
    )


def violates_delaunay(a, b, c, d, rel: float = 1e-12) -> bool:
    """d lies inside the circumcircle of the clockwise triangle (a, b, c), beyond a relative rounding margin, so
    cocircular points (a square, a regular star) never flip back and forth."""
    scale = max(abs(v) for p in (a, b, c) for v in (p[0] - d[0], p[1] - d[1])) or 1.0
    return -incircle(a, b, c, d) > rel * scale**4


def constrained_delaunay(vertices: np.ndarray, triangles: np.ndarray, constraints) -> np.ndarray:
    """Lawson's flips: while an edge shared by two triangles is not a constraint and the opposite vertex of one lies
    in the other's circumcircle, replace it by the other diagonal. ``vertices`` must hold no two points at the same
    coordinates within a triangle's neighbourhood (weld bridge copies first); triangles stay clockwise."""
    tris = [list(map(int, t)) for t in triangles]
    constrained = {frozenset(e) for e in constraints}
    edge_tris: dict[frozenset, list[int]] = {}
    for t, tri in enumerate(tris):
        for k in range(3):
            edge_tris.setdefault(frozenset((tri[k], tri[(k + 1) % 3])), []).append(t)
    stack = [e for e, ts in edge_tris.items() if len(ts) == 2 and e not in constrained]
    while stack:
        edge = stack.pop()
        owners = edge_tris.get(edge, [])
        if len(owners) != 2 or edge in constrained:
            continue
        t1, t2 = owners
        a, b, c = _rotate_to_edge(tris[t1], edge)  # t1 = (a, b, c) with the edge a -> b
        _, _, d = _rotate_to_edge(tris[t2], edge)  # t2 = (b, a, d)
        if not violates_delaunay(*(vertices[v] for v in (a, b, c, d))):
            continue
        ca, bc, ad, db = (frozenset(pair) for pair in ((c, a), (b, c), (a, d), (d, b)))
        for e, old, new in ((bc, t1, t2), (ad, t2, t1)):  # the two outer edges that change triangle
            edge_tris[e][edge_tris[e].index(old)] = new
        del edge_tris[edge]
        tris[t1], tris[t2] = [c, a, d], [d, b, c]  # both clockwise: the quad a, d, b, c runs clockwise
        edge_tris[frozenset((c, d))] = [t1, t2]
        stack += [ad, db, bc, ca]
    return np.asarray(tris, np.int32).reshape(-1, 3)


def _rotate_to_edge(tri: list[int], edge: frozenset) -> tuple[int, int, int]:
    for k in range(3):
        if frozenset((tri[k], tri[(k + 1) % 3])) == edge:
            return tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
    raise ValueError("edge not in triangle")


def weld_exact(vertices: np.ndarray) -> np.ndarray:
    """For every vertex, the first vertex at exactly the same coordinates (bridge copies map to their original)."""
    _, first, inverse = np.unique(vertices, axis=0, return_index=True, return_inverse=True)
    return first[inverse.ravel()]


def delaunay_flip(result: Triangulation) -> np.ndarray:
    """The constrained Delaunay triangulation of the input rings from the ear-clipped one: bridge copies welded to
    their first occurrence (bridges become ordinary, flippable edges), input ring edges kept."""
    rep = weld_exact(result.vertices)
    triangles = rep[result.triangles]
    index = {tuple(p): int(i) for i, p in zip(rep, result.vertices, strict=True)}
    constraints = []
    for ring in result.oriented:
        ids = [index[tuple(p)] for p in ring if tuple(p) in index]
        constraints += [(ids[i], ids[(i + 1) % len(ids)]) for i in range(len(ids))] if len(ids) == len(ring) else []
    return constrained_delaunay(result.vertices, triangles, constraints)


# }}}
