"""The robust ear clipping pipeline's pre-pass (not in the book): the user's rings turned into simple polygons with
their holes bridged in, whatever real outlines hold. Every decision is an exact orientation sign (``exact.orient``).

1. ``clean``: per ring, repeated consecutive points merged, local self-intersections cured (two edges one apart that
   cross: the two vertices between become the crossing point; the area this changes is measured), zero-width
   spikes dropped (they cover nothing). Collinear points on a straight run are kept: a neighbouring mesh may share
   them.
2. ``split_touching``: a vertex lying on another edge (of any ring) is inserted into that edge, then every ring that
   visits one point twice (pinched, self-tangent) is split there into loops that each visit it once.
3. ``nest``: each loop's parent is the smallest loop containing it, decided by its first vertex strictly inside or
   strictly outside (a loop touching another has others); odd depths are outer boundaries, even ones holes. Outers
   are made counter-clockwise and holes clockwise here, so the region is always on the left.
4. ``merge``: per outer loop, a hole that shares a point with the polygon so far is spliced in at that point (a
   zero-length bridge); the others are bridged, the hole with the right-most (then top-most) vertex M first, to the
   nearest vertex P right of M such that M -> P lies inside the region at both ends and meets no edge of the
   polygon or of any hole but at its ends (Eberly's visible vertex always qualifies: one is found).

The merged polygons are returned clockwise (y up), as the book's clipper takes them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .exact import orient, orient_many, ring_sign

# {{{ 1. clean


def _crosses(a, b, c, d) -> bool:
    """Segments a-b and c-d cross at one point inside both (no end touching)."""
    return orient(a, b, c) * orient(a, b, d) < 0 and orient(c, d, a) * orient(c, d, b) < 0


def _crossing_point(a, b, c, d) -> np.ndarray:
    """Where lines a-b and c-d meet (float64; only called for crossing segments)."""
    r, s = b - a, d - c
    t = ((c[0] - a[0]) * s[1] - (c[1] - a[1]) * s[0]) / (r[0] * s[1] - r[1] * s[0])
    return a + t * r


def _needs_cleaning(ring: np.ndarray) -> bool:
    """Whether ``clean`` would change the ring (all its tests at once, exact signs): a repeated point, a spike, or
    two edges one apart that cross."""
    if len(ring) < 4:
        return True
    a, b, c, d = ring, np.roll(ring, -1, axis=0), np.roll(ring, -2, axis=0), np.roll(ring, -3, axis=0)
    if (a == b).all(axis=1).any():
        return True
    turn = orient_many(a[:, 0], a[:, 1], b[:, 0], b[:, 1], c[:, 0], c[:, 1])
    if ((turn == 0) & (((a - b) * (c - b)).sum(axis=1) >= 0.0)).any():
        return True
    c2 = orient_many(a[:, 0], a[:, 1], b[:, 0], b[:, 1], d[:, 0], d[:, 1])
    may = turn * c2 < 0
    if not may.any():
        return False
    c3 = orient_many(c[may, 0], c[may, 1], d[may, 0], d[may, 1], a[may, 0], a[may, 1])
    c4 = orient_many(c[may, 0], c[may, 1], d[may, 0], d[may, 1], b[may, 0], b[may, 1])
    return bool((c3 * c4 < 0).any())


def clean(ring: np.ndarray, notes: dict) -> np.ndarray:
    """Repeated points merged, local self-intersections cured, spikes dropped (``notes`` counts each); fewer than 3
    points left: an empty ring."""
    ring = np.asarray(ring, np.float64).reshape(-1, 2)
    if not _needs_cleaning(ring):  # the usual case, tested in numpy
        return ring
    pts = [p for p in ring]
    keep = [p for i, p in enumerate(pts) if not np.array_equal(p, pts[i - 1])] if len(pts) > 1 else pts
    notes["duplicate points merged"] = notes.get("duplicate points merged", 0) + len(pts) - len(keep)
    pts = keep
    changed = True
    while changed and len(pts) >= 3:
        changed = False
        i = 0
        while len(pts) >= 4 and i < len(pts):  # a, b, c, d consecutive: a-b crossing c-d is a local self-intersection
            n = len(pts)
            a, b, c, d = pts[i], pts[(i + 1) % n], pts[(i + 2) % n], pts[(i + 3) % n]
            if _crosses(a, b, c, d):
                pts = pts[i:] + pts[:i]
                pts = [pts[0], _crossing_point(a, b, c, d), *pts[3:]]  # b and c become the crossing point
                notes["local self-intersections cured"] = notes.get("local self-intersections cured", 0) + 1
                changed, i = True, 0
            else:
                i += 1
        i = 0
        while len(pts) >= 3 and i < len(pts):  # a spike's tip (the ring turns back on one line): covers nothing
            n = len(pts)
            a, b, c = pts[i - 1], pts[i], pts[(i + 1) % n]
            if np.array_equal(a, b) or (orient(a, b, c) == 0 and np.dot(a - b, c - b) >= 0.0):
                del pts[i]
                notes["zero-width spikes dropped"] = notes.get("zero-width spikes dropped", 0) + 1
                changed = True
                i = max(i - 1, 0)
            else:
                i += 1
    if len(pts) < 3:
        return np.zeros((0, 2))
    return np.asarray(pts, np.float64)


# }}}

# {{{ 2. split_touching


def _on_edges(rings: list[np.ndarray]) -> dict[tuple[int, int], list[np.ndarray]]:
    """Every vertex that lies on an edge of any ring strictly between its ends: {(ring, edge): [points]}.

    Candidates come from a grid of about one vertex per cell: each edge visits the cells it passes through (sampled
    at most a cell apart, the corner-cut cells added), and meets the vertices bucketed there; the sign decides
    exactly. A vertex met twice is found twice (the caller keeps one)."""
    points = np.concatenate(rings)
    ring_of = np.repeat(np.arange(len(rings)), [len(r) for r in rings])
    starts = np.concatenate([[0], np.cumsum([len(r) for r in rings])[:-1]])
    ends_index = np.concatenate([np.roll(np.arange(len(r)), -1) + s for r, s in zip(rings, starts, strict=True)])
    a, b = points, points[ends_index]
    lo, hi = points.min(axis=0), points.max(axis=0)
    extent = float(max(hi - lo)) or 1.0
    cells = int(min(4096, max(1, np.sqrt(len(points)))))
    size = extent / cells

    def cell_of(p):
        return np.clip(((p - lo) / size).astype(np.int64), 0, cells - 1)

    keys = cell_of(points) @ np.array([1, cells])
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    length = np.abs(b - a).max(axis=1)
    steps = np.minimum(np.ceil(length / size).astype(np.int64) + 1, 2 * cells + 1)  # at most a cell apart
    edge = np.repeat(np.arange(len(a)), steps)
    t = (np.arange(len(edge)) - np.repeat(np.cumsum(steps) - steps, steps)) / np.repeat(np.maximum(steps - 1, 1), steps)
    samples = cell_of(a[edge] + t[:, None] * (b[edge] - a[edge]))
    # samples at most a cell apart: the segment between two crosses one column and one row line at most, so the
    # cells it passes are theirs and, on a diagonal move, the two corner cells
    same_edge = np.r_[edge[1:] == edge[:-1], False]
    moved = same_edge.copy()
    moved[same_edge] = (samples[1:][same_edge[:-1]] != samples[:-1][same_edge[:-1]]).any(axis=1)
    keep = np.r_[True, ~same_edge[:-1] | moved[:-1]]  # a sample in the cell of the one before adds nothing
    diagonal = np.flatnonzero(same_edge)
    diagonal = diagonal[(samples[diagonal] != samples[diagonal + 1]).all(axis=1)]
    corner1 = np.column_stack([samples[diagonal, 0], samples[diagonal + 1, 1]])
    corner2 = np.column_stack([samples[diagonal + 1, 0], samples[diagonal, 1]])
    pair_edge = np.concatenate([edge[keep], edge[diagonal], edge[diagonal]])
    pair_key = np.concatenate([samples[keep], corner1, corner2]) @ np.array([1, cells])
    first = np.searchsorted(sorted_keys, pair_key, "left")
    last = np.searchsorted(sorted_keys, pair_key, "right")
    counts = last - first
    e = np.repeat(pair_edge, counts)
    v = order[np.arange(counts.sum()) + np.repeat(first - np.cumsum(counts) + counts, counts)]
    pa, pb, pv = a[e], b[e], points[v]
    box = (
        (np.minimum(pa, pb) <= pv).all(axis=1)
        & (pv <= np.maximum(pa, pb)).all(axis=1)
        & ~(pv == pa).all(axis=1)
        & ~(pv == pb).all(axis=1)
    )
    e, v = e[box], v[box]
    on = orient_many(a[e, 0], a[e, 1], b[e, 0], b[e, 1], points[v, 0], points[v, 1]) == 0
    found: dict[tuple[int, int], list[np.ndarray]] = {}
    for edge_id, vertex in zip(e[on].tolist(), v[on].tolist(), strict=True):
        ring = int(ring_of[edge_id])
        found.setdefault((ring, edge_id - int(starts[ring])), []).append(points[vertex])
    return found


def _insert_touches(rings: list[np.ndarray], notes: dict) -> list[np.ndarray]:
    found = _on_edges(rings) if rings else {}
    if not found:
        return rings
    notes["touching points inserted"] = notes.get("touching points inserted", 0) + sum(map(len, found.values()))
    out = []
    for r, ring in enumerate(rings):
        pts = []
        for i, p in enumerate(ring):
            pts.append(p)
            extra = found.get((r, i))
            if extra:
                q = ring[(i + 1) % len(ring)]
                axis = 0 if abs(q[0] - p[0]) >= abs(q[1] - p[1]) else 1
                unique = {tuple(x): x for x in extra}.values()
                pts += sorted(unique, key=lambda x: (x[axis] - p[axis]) / (q[axis] - p[axis]))
        out.append(np.asarray(pts))
    return out


def intersection(rings: list[np.ndarray], chunk: int = 1 << 18) -> tuple | None:
    """The first pair of edges that cross (at one point inside both, exact signs), as ((ring, edge), (ring, edge)),
    else None. Touching (at an end, along a stretch) is allowed, and so are two edges of one ring one edge apart (a
    local self-intersection, which the robust pipeline cures and reports). The pairs tested are those whose ranges
    overlap along the axis where fewer do (a sweep), ``chunk`` at a time: at most n^2 / 2 pairs."""
    start = np.concatenate(rings)
    end = np.concatenate([np.roll(r, -1, axis=0) for r in rings])
    ring_of = np.repeat(np.arange(len(rings)), [len(r) for r in rings])
    edge_of = np.concatenate([np.arange(len(r)) for r in rings])
    size_of = np.repeat([len(r) for r in rings], [len(r) for r in rings])
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    sweeps = []
    for axis in (0, 1):
        order = np.argsort(lo[:, axis], kind="stable")
        stop = np.searchsorted(lo[order, axis], hi[order, axis], side="right")
        counts = np.maximum(stop - np.arange(len(order)) - 1, 0)  # edges after the i-th that may meet it
        sweeps.append((int(counts.sum()), order, counts))
    _, order, counts = min(sweeps, key=lambda s: s[0])
    start, end, lo, hi, ring_of, edge_of, size_of = (a[order] for a in (start, end, lo, hi, ring_of, edge_of, size_of))
    ends = np.cumsum(counts)
    first = 0
    while first < len(order):
        last = int(np.searchsorted(ends, ends[first] - counts[first] + chunk, side="right"))
        last = min(max(last, first + 1), len(order))  # edges first .. last - 1: about ``chunk`` pairs
        runs = counts[first:last]
        i = np.repeat(np.arange(first, last), runs)
        j = i + 1 + np.arange(len(i)) - np.repeat(np.cumsum(runs) - runs, runs)
        keep = (lo[j] <= hi[i]).all(axis=1) & (lo[i] <= hi[j]).all(axis=1)
        i, j = i[keep], j[keep]
        step = (edge_of[i] - edge_of[j]) % size_of[i]
        size = size_of[i]
        near = (step == 1) | (step == 2) | (step == size - 1) | (step == size - 2)  # neighbours, or one edge apart
        apart = (ring_of[i] != ring_of[j]) | ~near
        i, j = i[apart], j[apart]
        p1, p2, q1, q2 = start[i], end[i], start[j], end[j]
        d1 = orient_many(q1[:, 0], q1[:, 1], q2[:, 0], q2[:, 1], p1[:, 0], p1[:, 1])
        d2 = orient_many(q1[:, 0], q1[:, 1], q2[:, 0], q2[:, 1], p2[:, 0], p2[:, 1])
        cross = d1 * d2 < 0
        d3 = orient_many(p1[cross, 0], p1[cross, 1], p2[cross, 0], p2[cross, 1], q1[cross, 0], q1[cross, 1])
        d4 = orient_many(p1[cross, 0], p1[cross, 1], p2[cross, 0], p2[cross, 1], q2[cross, 0], q2[cross, 1])
        cross[cross] = d3 * d4 < 0
        if cross.any():
            k = int(np.argmax(cross))
            pair = sorted([(int(ring_of[i[k]]), int(edge_of[i[k]])), (int(ring_of[j[k]]), int(edge_of[j[k]]))])
            return pair[0], pair[1]
        first = last
    return None


def _inside_sweep(x, u, w, d) -> bool:
    """Point d, seen from x, lies strictly inside the counter-clockwise sweep from u to w (exact)."""
    if orient(x, u, w) > 0:
        return orient(x, u, d) > 0 and orient(x, d, w) > 0
    return not (orient(x, u, d) <= 0 and orient(x, d, w) <= 0)


def crossing_at_touches(rings: list[np.ndarray]) -> tuple[int, int, np.ndarray] | None:
    """Two rings (or two visits of one ring) that cross where they touch: at a shared point, one passes from one
    side of the other to its other side (its two edges there lie strictly on either side of the other's two). Edges
    that cross in their interiors are ``ear_clipping_input.intersection``'s; this finds the crossings at vertices.
    Returns (ring, ring, point) or None."""
    rings = _insert_touches([np.asarray(r, np.float64) for r in rings], {})
    visits: dict[tuple, list] = {}
    for r, ring in enumerate(rings):
        n = len(ring)
        for i, p in enumerate(map(tuple, ring.tolist())):
            visits.setdefault(p, []).append((r, ring[i - 1], ring[(i + 1) % n]))
    for point, here in visits.items():
        if len(here) < 2:
            continue
        x = np.asarray(point)
        for k, (ra, a1, a2) in enumerate(here):
            for rb, b1, b2 in here[k + 1 :]:
                if any(np.array_equal(b, a) for b in (b1, b2) for a in (a1, a2)):
                    continue  # they share an edge's direction here: touching along it
                if _inside_sweep(x, a1, a2, b1) != _inside_sweep(x, a1, a2, b2):
                    same_line = [orient(x, a, b) == 0 and np.dot(a - x, b - x) > 0 for a in (a1, a2) for b in (b1, b2)]
                    if not any(same_line):
                        return ra, rb, x
    return None


def _split_loops(ring: np.ndarray) -> list[np.ndarray]:
    """A ring that visits a point twice, split there into loops that visit each point once."""
    seen: dict[tuple, int] = {}
    for j, p in enumerate(map(tuple, ring.tolist())):
        i = seen.get(p)
        if i is not None:
            inner = ring[i:j]
            rest = np.concatenate([ring[:i], ring[j:]])
            return _split_loops(inner) + _split_loops(rest)
        seen[p] = j
    return [ring] if len(ring) >= 3 else []


def split_touching(rings: list[np.ndarray], notes: dict) -> tuple[list[np.ndarray], list[int]]:
    """Touching points made shared vertices, rings split at the points they visit twice: (loops, input ring of
    each loop)."""
    kept = [r for r in rings if len(r)]
    index = [i for i, r in enumerate(rings) if len(r)]
    touched = _insert_touches(kept, notes)
    loops, origin = [], []
    for i, ring in zip(index, touched, strict=True):
        parts = _split_loops(ring)
        if len(parts) > 1:
            split = "rings split where they touch themselves"
            notes[split] = notes.get(split, 0) + 1
        for part in parts:
            if ring_sign(part) != 0:
                loops.append(part)
                origin.append(i)
    return loops, origin


# }}}

# {{{ 3. nest


def locate(ring: np.ndarray, p) -> int:
    """+1 when p lies strictly inside ``ring``, -1 strictly outside, 0 on its boundary (exact crossing count)."""
    a, b = ring, np.roll(ring, -1, axis=0)
    x, y = float(p[0]), float(p[1])
    near = (np.minimum(a[:, 1], b[:, 1]) <= y) & (y <= np.maximum(a[:, 1], b[:, 1]))
    near &= np.maximum(a[:, 0], b[:, 0]) >= x  # the ray from p goes towards +x
    idx = np.flatnonzero(near)
    if not len(idx):
        return -1
    a, b = a[idx], b[idx]
    side = orient_many(a[:, 0], a[:, 1], b[:, 0], b[:, 1], x, y)
    within = (np.minimum(a, b) <= (x, y)).all(axis=1) & ((x, y) <= np.maximum(a, b)).all(axis=1)
    if ((side == 0) & within).any():
        return 0
    up = (a[:, 1] <= y) & (y < b[:, 1]) & (side > 0)  # upward edge with p on its left
    down = (b[:, 1] <= y) & (y < a[:, 1]) & (side < 0)
    return 1 if (int(up.sum()) - int(down.sum())) != 0 else -1


def inside(inner: np.ndarray, outer: np.ndarray) -> bool:
    """Loop ``inner`` lies inside loop ``outer`` (they may touch): its first vertex, then edge midpoint, off the
    other's boundary decides."""
    for p in inner:
        where = locate(outer, p)
        if where:
            return where > 0
    for p, q in zip(inner, np.roll(inner, -1, axis=0), strict=True):
        where = locate(outer, 0.5 * (p + q))
        if where:
            return where > 0
    return False  # the same loop twice: siblings


def nest(loops: list[np.ndarray]) -> list[int]:
    """Each loop's parent loop (-1: none): the smallest loop that contains it."""
    area = [abs(_float_area(r)) for r in loops]
    lo = [r.min(axis=0) for r in loops]
    hi = [r.max(axis=0) for r in loops]
    parent = []
    for i, ring in enumerate(loops):
        best, best_area = -1, np.inf
        for j, other in enumerate(loops):
            if j == i or area[j] < area[i] or area[j] >= best_area:
                continue
            if (lo[i] < lo[j]).any() or (hi[i] > hi[j]).any():
                continue
            if inside(ring, other):
                best, best_area = j, area[j]
        parent.append(best)
    return parent


def _float_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def depths(parent: list[int]) -> list[int]:
    out = []
    for i in range(len(parent)):
        d, j = 1, parent[i]
        while j >= 0:
            d, j = d + 1, parent[j]
        out.append(d)
    return out


# }}}

# {{{ 4. merge


def in_cone(prev, at, nxt, target) -> bool:
    """``target`` seen from vertex ``at`` (neighbours ``prev``, ``nxt``, region on the left) lies strictly inside
    the region's angle there."""
    if orient(prev, at, nxt) > 0:  # convex corner
        return orient(at, target, prev) > 0 and orient(target, at, nxt) > 0
    return not (orient(at, target, nxt) >= 0 and orient(target, at, prev) >= 0)


def segment_blocked(m, p, a: np.ndarray, b: np.ndarray) -> bool:
    """The segment m-p meets one of the edges a[i]-b[i] anywhere but at a shared end (exact)."""
    lo, hi = np.minimum(m, p), np.maximum(m, p)
    near = (np.maximum(a, b) >= lo).all(axis=1) & (np.minimum(a, b) <= hi).all(axis=1)
    a, b = a[near], b[near]
    if not len(a):
        return False
    oa = orient_many(m[0], m[1], p[0], p[1], a[:, 0], a[:, 1])
    ob = orient_many(m[0], m[1], p[0], p[1], b[:, 0], b[:, 1])
    om = orient_many(a[:, 0], a[:, 1], b[:, 0], b[:, 1], m[0], m[1])
    op = orient_many(a[:, 0], a[:, 1], b[:, 0], b[:, 1], p[0], p[1])
    if ((oa * ob < 0) & (om * op < 0)).any():
        return True

    def strictly_within(x, s, t):  # x on the segment s-t (collinear known) and none of its ends
        return (
            (np.minimum(s, t) <= x).all(axis=-1)
            & (x <= np.maximum(s, t)).all(axis=-1)
            & ~(x == s).all(axis=-1)
            & ~(x == t).all(axis=-1)
        )

    if ((oa == 0) & strictly_within(a, m, p)).any() or ((ob == 0) & strictly_within(b, m, p)).any():
        return True
    return bool(((om == 0) & strictly_within(m, a, b)).any() or ((op == 0) & strictly_within(p, a, b)).any())


def _splice_at_shared(merged: np.ndarray, bridged: np.ndarray, hole: np.ndarray):
    """The hole spliced in at a point it shares with the polygon (at the copy whose angle holds the hole), or None.
    ``bridged`` flags the polygon's edges (vertex i -> i + 1) that are bridges; a splice adds none."""
    where = {}
    for i, p in enumerate(map(tuple, merged.tolist())):
        where.setdefault(p, []).append(i)
    n = len(merged)
    for j, p in enumerate(map(tuple, hole.tolist())):
        for i in where.get(p, ()):
            direction = hole[(j + 1) % len(hole)]
            if in_cone(merged[i - 1], merged[i], merged[(i + 1) % n], direction):
                turned = np.concatenate([hole[j:], hole[:j]])
                points = np.concatenate([merged[: i + 1], turned[1:], turned[:1], merged[i + 1 :]])
                flags = np.concatenate([bridged[:i], np.zeros(len(hole), bool), bridged[i:]])
                return points, flags
    return None


def _bridge(merged: np.ndarray, bridged: np.ndarray, hole: np.ndarray, others: list[np.ndarray]):
    """The hole bridged from its right-most (then top-most) vertex M to the nearest valid vertex right of it: the
    polygon and its bridge flags, or None."""
    m_index = int(np.lexsort((hole[:, 1], hole[:, 0]))[-1])
    m = hole[m_index]
    right = (merged[:, 0] > m[0]) | ((merged[:, 0] == m[0]) & (merged[:, 1] > m[1]))
    candidates = np.flatnonzero(right)
    if not len(candidates):
        return None
    distance = ((merged[candidates] - m) ** 2).sum(axis=1)
    edges = [merged, hole, *others]
    a = np.concatenate(edges)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in edges])
    n, h = len(merged), len(hole)
    hole_prev, hole_next = hole[m_index - 1], hole[(m_index + 1) % h]
    for i in candidates[np.argsort(distance, kind="stable")].tolist():
        p = merged[i]
        if not in_cone(merged[i - 1], p, merged[(i + 1) % n], m):
            continue
        if not in_cone(hole_prev, m, hole_next, p):
            continue
        if segment_blocked(m, p, a, b):
            continue
        turned = np.concatenate([hole[m_index:], hole[:m_index]])
        points = np.concatenate([merged[: i + 1], turned, turned[:1], merged[i : i + 1], merged[i + 1 :]])
        # P -> M, the hole's h edges, M' -> P', then P' -> the old next (what P -> next was)
        flags = np.concatenate([bridged[:i], [True], np.zeros(h, bool), [True], bridged[i:]])
        return points, flags
    return None


def merge(outer: np.ndarray, holes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """The outer loop (counter-clockwise) with its holes (clockwise) in one polygon; returns it, its bridge flags
    (edge i -> i + 1 a bridge) and the holes that could not be joined (none for valid input)."""
    merged, bridged = outer, np.zeros(len(outer), bool)
    waiting = sorted(range(len(holes)), key=lambda k: tuple(holes[k][np.lexsort((holes[k][:, 1], holes[k][:, 0]))[-1]]))
    lost = []
    points = set(map(tuple, outer.tolist()))  # the polygon's points so far: which holes share one
    hole_points = [set(map(tuple, h.tolist())) for h in holes]
    while waiting:
        spliced = False
        for k in list(waiting):
            if points.isdisjoint(hole_points[k]):
                continue
            joined = _splice_at_shared(merged, bridged, holes[k])
            if joined is not None:
                (merged, bridged), spliced = joined, True
                waiting.remove(k)
                points |= hole_points[k]
        if spliced or not waiting:
            continue
        k = waiting.pop()  # the right-most M
        joined = _bridge(merged, bridged, holes[k], [holes[j] for j in waiting])
        if joined is None:
            lost.append(k)
        else:
            merged, bridged = joined
            points |= hole_points[k]
    return merged, bridged, lost


def weld(polygon: np.ndarray, bridged: np.ndarray) -> list[np.ndarray]:
    """Ring edges the merged polygon runs both ways (a -> b and b -> a: a hole sharing a stretch of boundary with
    its outer ring or with another hole; bridges excepted) bound no area: both are cut out and the ends rejoined,
    which may split the polygon into several. Returns the pieces that still have area, each a cycle of the
    polygon's vertices."""
    n = len(polygon)
    nxt = list(range(1, n)) + [0]
    bridge = bridged.tolist()
    key = [tuple(p) for p in polygon.tolist()]
    edges: dict[tuple, list[int]] = {}
    for i in range(n):
        if not bridge[i] and key[i] != key[nxt[i]]:
            edges.setdefault((key[i], key[nxt[i]]), []).append(i)
    todo = list(range(n))
    while todo:
        i = todo.pop()
        if nxt[i] < 0 or bridge[i] or key[i] == key[nxt[i]]:
            continue
        mates = [j for j in edges.get((key[nxt[i]], key[i]), ()) if nxt[j] >= 0 and key[j] == key[nxt[i]]]
        mates = [j for j in mates if key[nxt[j]] == key[i] and not bridge[j] and j not in (i, nxt[i]) and nxt[j] != i]
        if not mates:
            continue
        j = mates[0]
        ni, nj = nxt[i], nxt[j]  # a_i -> b_ni ... b_j -> a_nj: a_i goes on as a_nj did, b_j as b_ni did
        nxt[i], nxt[j], bridge[i], bridge[j] = nxt[nj], nxt[ni], bridge[nj], bridge[ni]
        nxt[ni] = nxt[nj] = -1
        for k in (i, j):
            if not bridge[k] and key[k] != key[nxt[k]]:
                edges.setdefault((key[k], key[nxt[k]]), []).append(k)
        todo += [i, j]
    pieces, seen = [], set()
    for start in range(n):
        if nxt[start] < 0 or start in seen:
            continue
        cycle, v = [], start
        while v not in seen:
            seen.add(v)
            cycle.append(v)
            v = nxt[v]
        if v == start and len(cycle) >= 3 and ring_sign(polygon[cycle]) != 0:
            pieces.append(polygon[cycle])
    return pieces


# }}}


CROSSING = "rings that cross (invalid input: the result may cover the crossing wrongly)"
"""The note of ``diagnose``."""


def diagnose(rings) -> dict:
    """Why a triangulation fell short, when the input is to blame: {CROSSING: 1} if rings cross (at interior points
    of edges or where they touch), else {}. Run only then: the sweep costs up to n^2 / 2 edge pairs."""
    kept = [c for r in rings if len(c := clean(r, {}))]
    if kept and (intersection(kept) is not None or crossing_at_touches(kept) is not None):
        return {CROSSING: 1}
    return {}


@dataclass
class Prepared:
    polygons: list[np.ndarray] = field(default_factory=list)
    """One simple (or weakly simple: bridge copies, shared points) clockwise polygon per outer loop."""
    group_loops: list[list[int]] = field(default_factory=list)
    """Loop indices of each polygon: the outer first, then its holes."""
    loops: list[np.ndarray] = field(default_factory=list)
    """The cleaned, split loops, outers counter-clockwise and holes clockwise."""
    loop_ring: list[int] = field(default_factory=list)
    """The input ring each loop came from."""
    parent: list[int] = field(default_factory=list)
    depth: list[int] = field(default_factory=list)
    lost: list[int] = field(default_factory=list)
    """Loops (holes) that could not be joined to their outer loop."""
    notes: dict = field(default_factory=dict)
    """What had to be altered: {what: how many}."""


def prepare(rings) -> Prepared:
    """The pre-pass: clean, split where rings touch, nest, orient, merge."""
    out = Prepared()
    cleaned = [clean(r, out.notes) for r in rings]
    out.loops, out.loop_ring = split_touching(cleaned, out.notes)
    out.parent = nest(out.loops)
    out.depth = depths(out.parent)
    for i, (loop, depth) in enumerate(zip(out.loops, out.depth, strict=True)):
        want = 1 if depth % 2 else -1
        if ring_sign(loop) != want:
            out.loops[i] = loop[::-1].copy()
    children: dict[int, list[int]] = {}
    for i, p in enumerate(out.parent):
        children.setdefault(p, []).append(i)
    for i, depth in enumerate(out.depth):
        if depth % 2 == 0:
            continue
        holes = children.get(i, [])
        merged, bridged, lost = merge(out.loops[i], [out.loops[k] for k in holes])
        out.lost += [holes[k] for k in lost]
        for piece in weld(merged, bridged):
            out.polygons.append(piece[::-1].copy())
            out.group_loops.append([i, *holes])
    out.notes = {k: v for k, v in out.notes.items() if v}
    return out
