"""Triangulation by ear clipping (Unity Graphics Programming vol.4 ch.5; docs/chapters/16-ear-clipping.md), on the
host in float64, following the chapter's ``Triangulation.cs`` step by step:

1. ``build_tree``: the rings sorted by bounding-box area, largest first, are hung into a containment tree under a
   dummy root (CheckInPolygonTree); odd levels (outer boundaries, islands) are made clockwise, even levels (holes)
   counter-clockwise, y up.
2. ``triangulate``: every outer ring is merged with its holes (CombineOuterAndInners: right-most hole first, each
   joined by a zero-width bridge from its right-most vertex M to a visible outer vertex P, CombinePolygon), then
   ``EarClipper`` clips the merged polygon: InitializeVertices fills the FIFO ear list, EarClipping takes its head,
   emits (prev, ear, next), unlinks the ear and re-checks both neighbours (CheckVertex), which are appended at the
   end when they became ears.
3. ``constrained_delaunay`` (not in the book): Lawson edge flips over every edge that is not an input ring edge.

``variant="book"`` sorts the rings by area and the holes by right-most x with the book's comparator
``FloorToInt(b - a)`` (differences below 1 compare equal), in the order .NET's List.Sort leaves such ties;
``variant="fixed"`` (default) sorts both exactly and stably. Holes whose right-most x differ by less than 1 can then
be bridged in the wrong order in the book, and a bridge can cross a hole that is not merged yet.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import dataclass, field
from functools import cmp_to_key

import numpy as np

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


class EarClipper:
    """The clipping state of one merged polygon: the book's ``vertices``, ``indices`` (a LinkedList<int>, here the
    ``prev``/``next`` arrays and ``alive``) and ``earTipList`` (a list in FIFO order plus a set for membership)."""

    def __init__(self, points: np.ndarray):
        self.points = np.asarray(points, np.float64)
        n = len(self.points)
        self.x, self.y = self.points[:, 0].copy(), self.points[:, 1].copy()
        self.prev = np.roll(np.arange(n), 1)
        self.next = np.roll(np.arange(n), -1)
        self.alive = np.ones(n, bool)
        self.count = n
        self.ears: list[int] = []
        self.listed: set[int] = set()

    def initialize_vertices(self) -> None:
        """InitializeVertices: the first ear list, vertices in ring order."""
        for v in range(len(self.points)):
            self.check_vertex(v)

    def is_ear(self, v: int) -> bool | None:
        """None for a reflex vertex; else whether no other live vertex lies in or on the triangle (prev, v, next).
        Vertices at the same coordinates as a corner (bridge copies) are ignored, as the book does."""
        p, q = self.prev[v], self.next[v]
        x, y = self.x, self.y
        ax, ay, bx, by, cx, cy = x[p], y[p], x[v], y[v], x[q], y[q]
        if not (ax - bx) * (cy - by) - (ay - by) * (cx - bx) > 0.0:
            return None

        def right_of(p1x, p1y, p2x, p2y):  # CheckLine(o, p1, p2) >= 0 for every vertex o
            return (x - p1x) * (p2y - p1y) - (p2x - p1x) * (y - p1y) >= 0.0

        inside = right_of(bx, by, cx, cy) & right_of(cx, cy, ax, ay) & right_of(ax, ay, bx, by) & self.alive
        for k in np.flatnonzero(inside):
            if k in (p, v, q) or (x[k], y[k]) in ((ax, ay), (bx, by), (cx, cy)):
                continue
            return False
        return True

    def check_vertex(self, v: int) -> None:
        """CheckVertex: a convex vertex becomes an ear (appended at the end) or stops being one (removed in place);
        a reflex vertex leaves the list as it is (the book's CheckVertex only acts on convex vertices)."""
        ear = self.is_ear(v)
        if ear is None:
            return
        if ear and v not in self.listed:
            self.ears.append(v)
            self.listed.add(v)
        elif not ear and v in self.listed:
            self.ears.remove(v)
            self.listed.discard(v)

    def clip(self) -> tuple[int, int, int] | None:
        """One pass of EarClipping's loop: the head ear's triangle (prev, ear, next), or None when the list is empty.
        After the last triangle (3 vertices left) the ear list is cleared."""
        if not self.ears:
            return None
        e = self.ears[0]
        p, q = int(self.prev[e]), int(self.next[e])
        if self.count == 3:
            self.ears.clear()
            self.listed.clear()
            return p, e, q
        self.ears.pop(0)
        self.listed.discard(e)
        self.next[p], self.prev[q] = q, p
        self.alive[e] = False
        self.count -= 1
        self.check_vertex(p)
        self.check_vertex(q)
        return p, e, q


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


def triangulate(rings, variant: str = "fixed", record: bool = False) -> Triangulation:
    """Triangulate: build the tree, merge each outer ring with its holes, clip; grandchildren become new outers."""
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
            if trace is not None and clipper.ears:
                trace.append(tuple(offset + e for e in clipper.ears))
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


def input_area(rings, levels) -> float:
    """|outer| - |holes| + |islands| ...: the area the triangles must cover."""
    return float(
        sum((1 if lv % 2 else -1) * abs(signed_area(np.asarray(r, float))) for r, lv in zip(rings, levels, strict=True))
    )


def triangle_signed_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Signed area per triangle (< 0: clockwise, y up)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


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
