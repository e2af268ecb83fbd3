"""Ear clipping (vol.4 ch.5; docs/chapters/16-ear-clipping.md): the presets' numbers, triangulation invariants, the
chapter's worked ear list, random stars with holes, mapbox-earcut, Delaunay flips, the batch kernel, CLI, view."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from helpers import foreground, render_view, run_cli

from ugpcl.geometry import ear_clipping as ec
from ugpcl.geometry.ear_clipping import clip_on_host, merged_polygons
from ugpcl.geometry.ear_clipping_input import PRESETS, glyph_batch, glyph_rings, star
from ugpcl.scenes.ear_clipping import MAX_BATCH_VERTICES, Params, Simulation, ear_clip_batch

# {{{ plain numpy references (never our geometry module)


def signed_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def shoelace(ring) -> float:
    r = np.asarray(ring, float)
    return 0.5 * float(np.sum(r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1]))


def strictly_inside(points: np.ndarray, a, b, c) -> np.ndarray:
    """Points strictly inside triangle abc of either orientation (exact float64 signs)."""

    def side(p, q):
        return (q[0] - p[0]) * (points[:, 1] - p[1]) - (q[1] - p[1]) * (points[:, 0] - p[0])

    s = np.stack([side(a, b), side(b, c), side(c, a)])
    return np.all(s > 0, axis=0) | np.all(s < 0, axis=0)


def vertices_inside_triangles(vertices: np.ndarray, triangles: np.ndarray) -> list:
    return [
        (t, int(k))
        for t, tri in enumerate(triangles)
        for k in np.flatnonzero(strictly_inside(vertices, *vertices[tri]))
    ]


def t_junctions(vertices: np.ndarray, triangles: np.ndarray) -> int:
    """(vertex, triangle) pairs with the vertex strictly inside a triangle edge, at no corner's coordinates."""
    count = 0
    for tri in triangles:
        corners = vertices[tri]
        for k in range(3):
            a, b = corners[k], corners[(k + 1) % 3]
            d, w = b - a, vertices - a
            on = (w[:, 0] * d[1] - w[:, 1] * d[0] == 0) & (np.einsum("ij,j->i", w, d) > 0)
            on &= np.einsum("ij,j->i", vertices - b, -d) > 0
            on &= ~np.any(np.all(vertices[:, None, :] == corners[None, :, :], axis=2), axis=1)
            count += int(on.sum())
    return count


def in_circumcircle(a, b, c, d) -> float:
    """> 0 when d is inside the circumcircle of abc, whatever abc's orientation, relative to the triangle's size."""
    m = np.array([[p[0] - d[0], p[1] - d[1], (p[0] - d[0]) ** 2 + (p[1] - d[1]) ** 2] for p in (a, b, c)])
    orient = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    return float(np.linalg.det(m) * np.sign(orient))


# }}}


def make(runtime, **params) -> Simulation:
    return Simulation(runtime, Params(**params), 0)


# {{{ presets: their triangle counts, areas and vertex counts

SPEC = {  # preset: (triangles, area, output vertices)
    "square": (2, 4.0, 4),
    "collinear": (3, 4.0, 5),
    "star5": (8, 4.702282018, 10),
    "star12": (22, 11.180982748, 24),
    "comb": (22, 23.0, 24),
    "holes": (20, 84.0, 22),
    "notch": (11, 93.0, 13),
    "nested": (20, 21.75, 28),
    "two_squares": (4, 2.0, 8),
    "example": (5, 35.5, 7),
}


@pytest.mark.parametrize("preset", sorted(SPEC))
def test_preset_counts_and_areas(runtime, preset):
    triangles, area, vertices = SPEC[preset]
    state = make(runtime, preset=preset).state()
    assert len(state["triangles"]) == triangles
    assert len(state["vertices"]) == vertices
    assert np.abs(signed_areas(state["vertices"], state["triangles"])).sum() == pytest.approx(area, rel=1e-9)
    assert state["complete"].all()


def test_nested_tree_groups_and_reversed_input(runtime):
    sim = make(runtime, preset="nested")
    state = sim.state()
    # rings A, B, C, D, E, F: root -> A; A -> {B, D}; B -> {C}; D -> {E, F}
    np.testing.assert_array_equal(state["tree_parent"], [-1, 0, 1, 0, 3, 3])
    np.testing.assert_array_equal(state["tree_level"], [1, 2, 3, 2, 3, 3])
    np.testing.assert_array_equal(np.diff(state["group_offsets"]), [16, 4, 4, 4])  # A+B+D with 2 bridges, C, E, F
    assert (signed_areas(state["vertices"], state["triangles"]) < 0).all()  # clockwise, y up
    reversed_rings = [np.asarray(r)[::-1] for r in PRESETS["nested"]()]
    again = ec.triangulate(reversed_rings)
    assert len(again.triangles) == 20
    assert np.abs(signed_areas(again.vertices, again.triangles)).sum() == pytest.approx(21.75, rel=1e-12)


def test_notch_bridge_goes_to_the_later_of_two_tied_edges(runtime):
    vertices = make(runtime, preset="notch", variant="fixed").state()["vertices"]  # the book's CombinePolygon
    # outer up to P = (10, 0), then the hole from M = (4, 4), then the copies of M and P
    np.testing.assert_array_equal(vertices[6:13], [[10, 0], [4, 4], [4, 5.5], [2, 5.5], [2, 4], [4, 4], [10, 0]])


def test_star5_either_orientation(runtime):
    for ring in (star(5, 2.0, 0.8), star(5, 2.0, 0.8)[::-1]):
        result = ec.triangulate([ring])
        assert len(result.triangles) == 8
        assert np.abs(signed_areas(result.vertices, result.triangles)).sum() == pytest.approx(4.702282018, rel=1e-9)


def test_glyph_preset_has_holes(runtime):
    state = make(runtime, preset="glyph", text="ugpcl").state()
    holes = int((state["tree_level"] == 2).sum())
    assert holes == 2  # the counters of g and p
    assert state["complete"].all()
    rings = np.split(state["input_vertices"], state["input_ring_offsets"][1:-1])
    expected = sum((1 if lv == 1 else -1) * abs(shoelace(r)) for r, lv in zip(rings, state["tree_level"], strict=True))
    assert state["area_output"] == pytest.approx(expected, rel=1e-9)


# }}}

# {{{ invariants on every preset


def check_invariants(vertices, triangles, group_offsets, complete, rings, levels):
    areas = signed_areas(vertices, triangles)
    expected_area = sum((1 if lv % 2 else -1) * abs(shoelace(r)) for r, lv in zip(rings, levels, strict=True))
    assert np.abs(areas).sum() == pytest.approx(expected_area, rel=1e-9)
    assert (areas < 0).all(), f"{(areas >= 0).sum()} triangles not clockwise"
    assert not vertices_inside_triangles(vertices, triangles)
    assert complete.all()
    sizes = np.diff(group_offsets)
    owner = np.searchsorted(group_offsets, triangles[:, 0], side="right") - 1
    np.testing.assert_array_equal(np.bincount(owner, minlength=len(sizes)), sizes - 2)  # n_g - 2 per group
    holes = int(np.sum(np.asarray(levels) % 2 == 0))
    assert len(triangles) == sum(len(r) for r in rings) + 2 * holes - 2 * len(sizes)  # n + 2h - 2 per outer ring
    assert np.array_equal(np.unique(triangles), np.arange(len(vertices)))  # every vertex (copies too) used


@pytest.mark.parametrize("preset", [p for p in PRESETS if p != "draw"])
def test_invariants(runtime, preset):
    sim = make(runtime, preset=preset)
    s = sim.state()
    check_invariants(s["vertices"], s["triangles"], s["group_offsets"], s["complete"], sim.rings, s["tree_level"])
    assert (s["uv"] >= 0).all() and (s["uv"] <= 1).all()
    assert s["area_input"] == pytest.approx(s["area_output"], rel=1e-9)


# }}}

# {{{ the chapter's worked example (fig. 5.6 - 5.11) and the FIFO ear list


def test_fifo_ear_list_of_the_chapter_example(runtime):
    sim = make(runtime, preset="example")
    state = sim.state()
    assert state["triangles"].tolist() == [[6, 0, 1], [6, 1, 2], [3, 4, 5], [5, 6, 2], [5, 2, 3]]
    lists = [sim.ear_list(k) for k in range(5)]  # the ear list when each triangle is clipped, head first
    assert lists == [(0, 1, 4, 6), (1, 4, 6), (4, 6, 2), (6, 2, 3, 5), (2, 3, 5)]
    flat = np.split(state["ear_trace"], state["ear_trace_offsets"][1:-1])
    assert [tuple(x) for x in flat] == lists


def test_check_vertex_rules_on_the_example():
    ring = np.asarray(PRESETS["example"]()[0], float)
    clipper = ec.EarClipper(ring)
    assert [clipper.is_ear(v) for v in range(7)] == [
        True,
        True,
        None,
        False,
        True,
        None,
        True,
    ]  # 2, 5 reflex; 5 blocks 3
    assert ec.in_triangle(ring[5], ring[2], ring[3], ring[4]) == -1


def test_replay_steps_reveal_clips(runtime):
    sim = make(runtime, preset="example", clips_per_step=2)
    assert sim.clips == 0
    sim.step()
    assert sim.clips == 2 and sim.ear_list() == (4, 6, 2)
    for _ in range(5):
        sim.step()
    assert sim.clips == 5 and sim.done and sim.ear_list() == ()


# }}}

# {{{ geometry predicates


def test_in_triangle_and_is_convex():
    a, b, c = (0.0, 0.0), (0.0, 1.0), (1.0, 0.0)  # clockwise, y up
    assert ec.in_triangle((0.2, 0.2), a, b, c) == -1
    assert ec.in_triangle((0.5, 0.5), a, b, c) == 0  # on the hypotenuse
    assert ec.in_triangle((0.0, 0.5), a, b, c) == 0
    assert ec.in_triangle((1.0, 1.0), a, b, c) == 1
    square = [(0, 0), (0, 1), (1, 1), (1, 0)]
    assert all(ec.is_convex(square[i], square[i - 1], square[(i + 1) % 4]) for i in range(4))
    assert not ec.is_convex((0, 1), (0, 0), (0, 2))  # collinear is reflex


def test_point_in_polygon_matches_winding_number(seed):
    rng = np.random.default_rng(seed)
    ring = np.asarray(star(7, 2.0, 0.7))
    points = rng.uniform(-2.2, 2.2, (1000, 2))
    angles = np.arctan2(ring[:, 1][None] - points[:, 1:2], ring[:, 0][None] - points[:, 0:1])
    turns = np.diff(np.concatenate([angles, angles[:, :1]], axis=1), axis=1)
    winding = np.round(((turns + np.pi) % (2 * np.pi) - np.pi).sum(axis=1) / (2 * np.pi))
    ours = np.array([ec.point_in_polygon(ring, p) for p in points])
    np.testing.assert_array_equal(ours, winding != 0)


# }}}

# {{{ random stars with holes


def random_star(rng, radius: float) -> np.ndarray:
    n = int(rng.integers(3, 81))
    while True:
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        gaps = np.diff(np.concatenate([angles, angles[:1] + 2 * np.pi]))
        if gaps.max() < 0.95 * np.pi:
            break
    r = rng.uniform(0.3, 1.0, n) * radius
    return np.column_stack([r * np.cos(angles), r * np.sin(angles)])


def rings_cross(a: np.ndarray, b: np.ndarray) -> bool:
    """Some edge of ring a properly crosses some edge of ring b (orientation signs, all pairs at once)."""
    p1, p2 = a[:, None, :], np.roll(a, -1, axis=0)[:, None, :]
    q1, q2 = b[None, :, :], np.roll(b, -1, axis=0)[None, :, :]

    def orient(u, v, w):
        return np.sign(
            (v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0])
        )

    return bool(np.any((orient(p1, p2, q1) != orient(p1, p2, q2)) & (orient(q1, q2, p1) != orient(q1, q2, p2))))


def test_random_stars_with_holes(seed):
    rng = np.random.default_rng(seed)
    done = 0
    while done < 300:
        outer = random_star(rng, 10.0)
        holes = []
        for _ in range(int(rng.integers(0, 4))):
            centre, half = rng.uniform(-3, 3, 2), rng.uniform(0.1, 0.6)
            square = np.array([[-1, -1], [-1, 1], [1, 1], [1, -1]]) * half + centre
            # well inside: every corner inside the star with room to spare and clear of the other holes
            grown = np.array([[-1, -1], [-1, 1], [1, 1], [1, -1]]) * (half + 0.3) + centre
            inside = all(ec.point_in_polygon(outer, p) for p in grown) and not rings_cross(outer, grown)
            apart = all(
                np.abs(centre - h.mean(axis=0)).max() > half + np.abs(h - h.mean(axis=0)).max() + 0.2 for h in holes
            )
            if inside and apart:
                holes.append(square)
        rings = [outer, *holes]
        r = ec.triangulate(rings)
        check_invariants(r.vertices, r.triangles, r.group_offsets, r.complete, rings, r.tree_level)
        done += 1


# }}}

# {{{ the host clipper's grid search equals the book's scan over every live vertex


class ScanClipper:
    """The book's InitializeVertices / CheckVertex / EarClipping with the plain ear test: every live vertex is
    checked against the triangle with CheckLine in float64 (numpy), the ear list is a Python list in FIFO order."""

    def __init__(self, points):
        self.x, self.y = np.asarray(points, float)[:, 0].copy(), np.asarray(points, float)[:, 1].copy()
        n = len(self.x)
        self.prev, self.next = np.roll(np.arange(n), 1), np.roll(np.arange(n), -1)
        self.alive, self.count, self.ears = np.ones(n, bool), n, []

    def is_ear(self, v):
        p, q, x, y = self.prev[v], self.next[v], self.x, self.y
        ax, ay, bx, by, cx, cy = x[p], y[p], x[v], y[v], x[q], y[q]
        if not (ax - bx) * (cy - by) - (ay - by) * (cx - bx) > 0.0:
            return None

        def right_of(p1x, p1y, p2x, p2y):
            return (x - p1x) * (p2y - p1y) - (p2x - p1x) * (y - p1y) >= 0.0

        inside = right_of(bx, by, cx, cy) & right_of(cx, cy, ax, ay) & right_of(ax, ay, bx, by) & self.alive
        corners = ((ax, ay), (bx, by), (cx, cy))
        return not any(k not in (p, v, q) and (x[k], y[k]) not in corners for k in np.flatnonzero(inside))

    def check_vertex(self, v):
        ear = self.is_ear(v)
        if ear and v not in self.ears:
            self.ears.append(v)
        elif ear is False and v in self.ears:
            self.ears.remove(v)

    def run(self):
        """(triangles, the ear list before each clip)."""
        for v in range(len(self.x)):
            self.check_vertex(v)
        triangles, lists = [], []
        while self.ears:
            lists.append(tuple(self.ears))
            e = self.ears.pop(0)
            p, q = int(self.prev[e]), int(self.next[e])
            triangles.append((p, e, q))
            if self.count == 3:
                break
            self.next[p], self.prev[q], self.alive[e], self.count = q, p, False, self.count - 1
            self.check_vertex(p)
            self.check_vertex(q)
        return triangles, lists


def fast_run(points):
    clipper = ec.EarClipper(points)
    clipper.initialize_vertices()
    triangles, lists = [], []
    while clipper.ears:
        lists.append(tuple(clipper.ears))
        triangles.append(clipper.clip())
    return triangles, lists


def hard_polygons(rng) -> list[np.ndarray]:
    """Large and awkward inputs: a many-vertex star; star-shaped rings of 200-1500 vertices merged with holes
    (bridge copies); coordinates snapped to a coarse lattice (collinear runs, repeated points); edges subdivided
    with rounding noise (needle triangles); a self-intersecting random ring; far-off, tiny coordinates."""
    polygons = [star(int(rng.integers(200, 1000)), 1.0, float(rng.uniform(0.2, 0.9)))]
    n = int(rng.integers(200, 1500))
    angles = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = rng.uniform(0.5, 1.0, n) * 10.0
    outer = np.column_stack([r * np.cos(angles), r * np.sin(angles)])
    holes = [np.array([[-1, -1], [-1, 1], [1, 1], [1, -1]]) * 0.8 + c for c in ([0.0, 0.0], [2.5, 0.3])]
    polygons += merged_polygons([outer, *holes])
    polygons.append(np.round(outer / 3.0))
    t = np.linspace(0.0, 1.0, 40)[:-1, None]
    corners = np.array([[0.0, 0.0], [0.0, 3.0], [4.0, 3.0], [4.0, 0.0]])
    sides = [a + t * (b - a) for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True)]
    polygons.append(np.concatenate(sides) * rng.uniform(0.1, 10.0) + rng.normal(0.0, 1e-14, (156, 2)))
    polygons.append(rng.uniform(-1.0, 1.0, (int(rng.integers(30, 300)), 2)))
    polygons.append(star(50, 1.0, 0.5) * 1e-7 + 1e5)
    return polygons


@pytest.mark.parametrize("draw", range(3))
def test_grid_search_equals_the_scan_over_every_vertex(seed, draw):
    rng = np.random.default_rng([seed, draw])
    for i, polygon in enumerate(hard_polygons(rng)):
        expected, lists = ScanClipper(polygon).run()
        found, found_lists = fast_run(polygon)
        assert found == expected, (
            f"polygon {i} ({len(polygon)} vertices): first mismatch at {first_diff(found, expected)}"
        )
        assert found_lists == lists


def first_diff(a, b) -> int:
    return next((k for k, (u, w) in enumerate(zip(a, b, strict=False)) if u != w), min(len(a), len(b)))


def test_grid_search_on_the_bench_star():
    ring = star(1000, 1.0, 0.5)
    expected, _ = ScanClipper(ring).run()
    assert fast_run(ring)[0] == expected
    assert len(expected) == len(ring) - 2


# }}}

# {{{ mapbox-earcut


@pytest.mark.parametrize("preset", [p for p in PRESETS if p != "draw"])
def test_same_area_and_count_as_earcut(runtime, preset):
    state = make(runtime, preset=preset, compare_earcut=True).state()
    assert state["earcut_area"] == pytest.approx(state["area_output"], rel=1e-9)
    # earcut drops collinear vertices of a bridged ring, leaving a vertex on another triangle's edge (a T-junction):
    # each one saves a triangle (nested and holes have two). Without T-junctions the counts are equal.
    deficit = t_junctions(state["input_vertices"], state["earcut_triangles"])
    assert len(state["earcut_triangles"]) + deficit == len(state["triangles"])
    assert t_junctions(state["vertices"], state["triangles"]) == 0


# }}}

# {{{ Delaunay flips


def local_delaunay_violations(vertices, triangles, constraints, rel=1e-9) -> list:
    edges: dict = {}
    for t, tri in enumerate(triangles):
        for k in range(3):
            edges.setdefault(frozenset((tri[k], tri[(k + 1) % 3])), []).append(t)
    bad = []
    for edge, owners in edges.items():
        if len(owners) != 2 or edge in constraints:
            continue
        t1, t2 = (triangles[t] for t in owners)
        d = next(v for v in t2 if v not in edge)
        scale = np.ptp(vertices[list(t1) + [d]], axis=0).max() ** 4
        if in_circumcircle(*vertices[t1], vertices[d]) > rel * scale:
            bad.append(edge)
    return bad


@pytest.mark.parametrize("preset", ["star12", "comb", "holes", "notch", "nested", "glyph"])
def test_delaunay_flips_give_a_constrained_delaunay_triangulation(runtime, preset):
    sim = make(runtime, preset=preset, delaunay=True)
    s = sim.state()
    v, t = s["vertices"], s["triangles"]
    assert len(t) == len(s["ear_triangles"])
    assert np.abs(signed_areas(v, t)).sum() == pytest.approx(s["area_input"], rel=1e-9)
    assert (signed_areas(v, t) < 0).all()
    assert not vertices_inside_triangles(v, t)
    first = {}
    for i, p in enumerate(map(tuple, v)):
        first.setdefault(p, i)
    constraints = {
        frozenset((first[tuple(r[i])], first[tuple(r[(i + 1) % len(r)])])) for r in sim.rings for i in range(len(r))
    }
    assert not local_delaunay_violations(v, t, constraints)
    if preset in ("comb", "glyph"):  # ear clipping's fans are not Delaunay there: the flips did something
        assert local_delaunay_violations(v, s["ear_triangles"], constraints)


def test_delaunay_of_a_convex_polygon_matches_scipy(seed):
    from scipy.spatial import ConvexHull, Delaunay

    rng = np.random.default_rng(seed)
    for _ in range(5):
        cloud = rng.normal(size=(400, 2))
        hull = cloud[ConvexHull(cloud).vertices][::-1]  # clockwise
        result = ec.triangulate([hull])
        ours = ec.delaunay_flip(result)
        theirs = Delaunay(result.vertices).simplices
        assert {tuple(sorted(t)) for t in ours} == {tuple(sorted(t)) for t in theirs}


# }}}

# {{{ the book's sorts (variant=book)


def test_book_sort_truncates_differences_below_one():
    assert ec.book_sort([0.5, 1.2], key=float) == [0.5, 1.2]  # 1.2 - 0.5 < 1: a tie, left as it is
    assert ec.book_sort([0.5, 1.7], key=float) == [1.7, 0.5]
    assert ec.sort_descending([0.5, 1.2], float, "fixed") == [1.2, 0.5]


def test_book_variant_bridges_holes_in_the_wrong_order():
    # two holes whose right-most x differ by 0.5, the left one first: the book bridges it first, and its bridge
    # runs right through the second hole, which is not merged yet
    outer = [(0, 0), (0, 10), (10, 10), (10, 0)]
    left = [(2, 4), (2, 6), (4, 6), (4, 4)]
    right = [(4.2, 3), (4.2, 7), (4.5, 7), (4.5, 3)]
    rings = [outer, left, right]
    fixed = ec.triangulate(rings, "fixed")
    check_invariants(fixed.vertices, fixed.triangles, fixed.group_offsets, fixed.complete, rings, fixed.tree_level)
    book = ec.triangulate(rings, "book")
    area = np.abs(signed_areas(book.vertices, book.triangles)).sum()
    broken = (
        not book.complete.all()
        or abs(area - (100 - 4 - 1.2)) > 1e-9
        or vertices_inside_triangles(book.vertices, book.triangles)
    )
    assert broken


# }}}

# {{{ the batch kernel


def batch_polygons(seed, count: int) -> list:
    rng = np.random.default_rng(seed)
    stars = []
    while len(stars) < count // 2:
        ring = random_star(rng, 1.0)[::-1]  # clockwise
        if len(ring) <= MAX_BATCH_VERTICES:
            stars.append(ring)
    return stars + glyph_batch(count - len(stars), MAX_BATCH_VERTICES)


def test_batch_kernel_equals_the_host(runtime, seed):
    polygons = batch_polygons(seed, 300)
    triangles, counts, _ = ear_clip_batch(runtime, polygons, robust=False)
    sizes = np.array([len(p) for p in polygons])
    np.testing.assert_array_equal(counts, sizes - 2)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    for i, polygon in enumerate(polygons):
        rows = triangles[offsets[i] - 2 * i : offsets[i] - 2 * i + counts[i]]
        expected = clip_on_host(polygon) + offsets[i]
        assert np.array_equal(rows, expected), f"polygon {i} ({len(polygon)} vertices): {rows[:3]} vs {expected[:3]}"


def test_batch_kernel_on_bridged_glyphs_equals_the_scene(runtime):
    for variant in ("robust", "fixed"):
        sim = make(runtime, preset="glyph", text="aB%", variant=variant)
        polygons = merged_polygons(sim.rings, variant)
        triangles, counts, finished = ear_clip_batch(runtime, polygons, robust=variant == "robust")
        assert finished.all()
        np.testing.assert_array_equal(triangles, sim.state()["triangles"])


def test_batch_rejects_large_polygons(runtime):
    with pytest.raises(ValueError, match="3 to 64 vertices"):
        ear_clip_batch(runtime, [star(40, 1.0, 0.5)])


# }}}

# {{{ parameters, CLI, mesh


def test_params_are_checked():
    """The rules of check() and an unknown choice (test_params tries the ranges of every field)."""
    with pytest.raises(ValueError, match="text"):
        Params(text="")
    with pytest.raises(ValueError, match="input"):
        Params(input="/no/such/rings.json")
    with pytest.raises(ValueError, match="preset"):
        Params(preset="hexagon")


BAD_RINGS = [
    ('{"foo":1}', 'expected {"rings": [[[x, y], ...], ...]}, got keys "foo"'),
    ("5", 'expected {"rings": [[[x, y], ...], ...]}, got the number 5'),
    ("null", 'expected {"rings": [[[x, y], ...], ...]}, got null'),
    ('{"rings":5}', "rings must be a list of rings, each a list of [x, y] points; got the number 5"),
    ('{"rings":[]}', "holds no rings"),
    ('{"rings": [[[0, 0],\n  [1, 0] [1, 1]]]}', "invalid JSON at line 2, column 10: Expecting ',' delimiter"),
    ('{"rings":[[[0,0],[1,0],[NaN,1]]]}', "invalid JSON number (NaN is not a finite number)"),
    ('{"rings":[[[0,0],[1,0],[1e400,1]]]}', "invalid JSON number (1e400 is beyond float64)"),
    ('{"rings":[[[0,0],[1e39,0],[1e39,1e39]]]}', "rings[0][1] has 1e+39; coordinates must be within +-1e9"),
    ('{"rings":[[[0,0,0],[1,0,0],[1,1,0]]]}', "rings[0][0] must be [x, y] (rings are 2-D), got 3 numbers"),
    ('{"rings":[[[0,0],["a",0],[1,1]]]}', "rings[0][1] must be two numbers, got a string"),
    ('{"rings":[[[0,0],[0,0],[1,1],[0,0]]]}', "rings[0] has 2 distinct points; a ring needs 3"),
    ('{"rings":[[[0,0],[1,1],[2,2]]]}', "rings[0] has zero area: its points lie on one line"),
    (
        '{"rings":[[[0,0],[0,4],[4,4],[4,0],[2,-1],[5,2],[2,3],[-1,2]]]}',  # edges 2 and 5: not a local crossing
        "rings[0] crosses itself (edge 2 of rings[0] crosses edge 5 of rings[0]); rings may touch, not cross",
    ),
    (
        '{"rings":[[[0,0],[0,4],[4,4],[4,0]],[[1,1],[5,2],[2,3]]]}',
        "rings[0] and rings[1] cross (edge 2 of rings[0] crosses edge 0 of rings[1]); rings may touch, not cross",
    ),
    (
        json.dumps({"rings": [[[i, i % 2] for i in range(200_001)]]}, separators=(",", ":")),
        "200001 points is more than the limit of 200000",
    ),
    ("", "is empty"),
    (" " * (16 << 20) + "{}", "16777218 bytes is more than the limit of 16 MiB"),
]


@pytest.mark.parametrize("text, message", BAD_RINGS)
def test_bad_rings_files_are_refused_in_one_line(tmp_path, text, message):
    path = tmp_path / "rings.json"
    path.write_text(text)
    with pytest.raises(ValueError) as err:
        Params(input=str(path))
    assert str(err.value) == f"input {path}: {message}"


def test_rings_files_that_are_not_files(tmp_path):
    with pytest.raises(ValueError, match=f"^input {tmp_path}: is a folder, not a file$"):
        Params(input=str(tmp_path))
    with pytest.raises(ValueError, match=f"^input {tmp_path}/none.json: no such file$"):
        Params(input=str(tmp_path / "none.json"))


def test_every_preset_passes_the_file_checks(tmp_path):
    """What the checks refuse is what the triangulation cannot take: the book's scenes and the glyphs pass."""
    from ugpcl.geometry.ear_clipping_input import load_rings, save_rings

    for name, make_rings in {**PRESETS, "glyph": lambda: glyph_rings("ugpcl@%", 4.0)}.items():
        if name == "draw":
            continue
        save_rings(tmp_path / f"{name}.json", make_rings())
        assert len(load_rings(tmp_path / f"{name}.json")) == len(make_rings()), name


def test_glyph_text_without_outlines_is_refused():
    for text in (" ", "\u200b"):
        with pytest.raises(ValueError, match=f"^text {re.escape(repr(text))} has no glyph outlines to triangulate"):
            Params(preset="glyph", text=text)


def test_a_rings_file_edited_after_its_check_is_read_again(runtime, tmp_path):
    path = tmp_path / "rings.json"
    path.write_text(json.dumps({"rings": [PRESETS["square"]()[0]]}))
    params = Params(input=str(path))
    path.write_text(json.dumps({"rings": PRESETS["holes"]()}) + " ")  # another size: another version
    assert len(Simulation(runtime, params).rings) == 4


def test_input_json_and_drawn_rings(runtime, tmp_path):
    path = tmp_path / "rings.json"
    path.write_text(json.dumps({"rings": [PRESETS["holes"]()[0], PRESETS["holes"]()[1]]}))
    sim = make(runtime, input=str(path))
    assert len(sim.state()["triangles"]) == 8 + 2 * 1 - 2  # n + 2h - 2
    sim.add_ring([(6, 6), (6, 8), (8, 8), (8, 6)])
    assert len(sim.state()["triangles"]) == 12 + 2 * 2 - 2
    sim.undo_ring()
    sim.clear_rings()
    sim.undo_ring()  # nothing left: no error
    assert len(sim.state()["triangles"]) == 0


def test_cli_run_writes_npz_png_and_glb(capsys, tmp_path):
    import trimesh

    out, png, mesh = tmp_path / "x.npz", tmp_path / "x.png", tmp_path / "x.glb"
    code, text = run_cli(
        capsys, "run", "ear_clipping", "--steps", "3", "--out", str(out), "--png", str(png), "--mesh", str(mesh),
        "--png-size", "64x48", "--set", "preset=holes",
    )  # fmt: skip
    assert code == 0, text
    data = np.load(out)
    assert len(data["triangles"]) == 20 and int(data["clips"]) == 3
    loaded = trimesh.load(mesh, force="mesh", process=False)
    assert len(loaded.vertices) == 22 and len(loaded.faces) == 20
    assert loaded.area == pytest.approx(84.0, rel=1e-6)
    assert (loaded.face_normals[:, 2] > 0.999).all()  # counter-clockwise seen from +z after the handedness change
    assert png.stat().st_size > 0


def test_mesh_normals_agree_with_winding(runtime):
    from ugpcl.geometry.mesh import normals_agree_with_winding, triangle_areas

    mesh = make(runtime, preset="nested").mesh()
    assert normals_agree_with_winding(mesh) == 1.0
    assert triangle_areas(mesh.vertices, mesh.faces).sum() == pytest.approx(21.75, rel=1e-6)


# }}}

# {{{ view


@pytest.mark.gl
def test_view_fills_triangles_and_leaves_holes_empty(runtime, gl):
    sim = make(runtime, preset="nested", clips_per_step=1000)
    sim.step()
    size = (96, 64)
    off = {"show_wire": False, "show_outline": False, "show_ears": False}
    pixels, _, view, camera = render_view(gl, "ear_clipping", sim, size, **off)
    mask = foreground(pixels, view.background)
    matrix = camera.projection() @ camera.view()

    def pixel(x, y):
        ndc = matrix @ np.array([x, y, 0.0, 1.0])
        return int((1 - ndc[1]) / 2 * size[1]), int((ndc[0] + 1) / 2 * size[0])

    for x, y in [(-1.5, 1.5), (4.5, -1.5), (0.0, 0.0), (2.6, -0.5), (3.4, 0.5)]:  # A's ring, island C, islands E, F
        assert mask[pixel(x, y)], f"({x}, {y}) should be filled"
    for x, y in [(-0.75, 0.0), (2.5, 0.5), (3.5, -0.5), (5.5, 0.0)]:  # hole B, hole D, outside
        assert not mask[pixel(x, y)], f"({x}, {y}) should be background"


@pytest.mark.gl
def test_view_replay_shows_only_clipped_ears(runtime, gl):
    sim = make(runtime, preset="example")
    off = {"show_wire": False, "show_outline": False, "show_ears": False}
    empty, _, view, _ = render_view(gl, "ear_clipping", sim, (64, 64), **off)
    assert not foreground(empty, view.background).any()
    sim.seek(2)
    two, *_ = render_view(gl, "ear_clipping", sim, (64, 64), **off)
    sim.seek(5)
    full, *_ = render_view(gl, "ear_clipping", sim, (64, 64), **off)
    shown, total = foreground(two, view.background).sum(), foreground(full, view.background).sum()
    assert 0 < shown < total
    area = np.abs(signed_areas(sim.result.vertices, sim.ear_triangles))
    assert shown / total == pytest.approx(area[:2].sum() / area.sum(), abs=0.08)


# }}}


@pytest.mark.oclgrind
def test_batch_kernel_on_oclgrind(oclgrind, seed):
    polygons = batch_polygons(seed, 6)
    triangles, counts, _ = ear_clip_batch(oclgrind, polygons, robust=False)
    np.testing.assert_array_equal(counts, [len(p) - 2 for p in polygons])
    offsets = np.concatenate([[0], np.cumsum([len(p) for p in polygons])])
    expected = np.concatenate([clip_on_host(p) + offsets[i] for i, p in enumerate(polygons)])
    np.testing.assert_array_equal(triangles, expected)


def test_the_declared_file_limits_are_the_ones_checked():
    """``ugpcl params`` shows the limits of input: the numbers its help gives are the reader's constants."""
    from ugpcl.geometry import ear_clipping_input as eci
    from ugpcl.scene import field_docs

    doc = field_docs(Params)["input"]
    assert f"At most {eci.MAX_FILE_BYTES >> 20} MiB and {eci.MAX_VERTICES} points" in doc, doc
    assert f"<= 1e{round(math.log10(eci.COORD_LIMIT))}" in doc, doc


# {{{ a result that falls short is never silent


THREE_HOLES = {  # the outline: the book's bridging runs out of ears on it
    "rings": [
        [[0, 0], [0, 3], [8, 3], [8, 0]],
        [[0.3, 1], [0.3, 1.5], [1.8, 1.5], [1.8, 1]],
        [[3.6, 1], [3.6, 1.5], [4.1, 1.5], [4.1, 1]],
        [[4.2, 1], [4.2, 1.5], [4.6, 1.5], [4.6, 1]],
    ]
}


def test_nesting_levels_come_from_the_rings_alone():
    outer = [[0, 0], [0, 10], [10, 10], [10, 0]]
    hole = [[2, 2], [2, 8], [8, 8], [8, 2]]
    island = [[4, 4], [4, 6], [6, 6], [6, 4]]
    beside = [[20, 0], [20, 1], [21, 1], [21, 0]]
    assert ec.nesting_levels([island, outer, beside, hole]) == [2, 0, 0, 1]


@pytest.mark.parametrize("strict", [False, True])
def test_an_incomplete_triangulation_says_so_in_one_line(runtime, capsys, tmp_path, strict):
    from ugpcl.cli import main

    rings = tmp_path / "h3.json"
    rings.write_text(json.dumps(THREE_HOLES))
    out = tmp_path / "h3.npz"
    # variant=book: the book's bridging, which runs out of ears on this outline (the first example)
    argv = ["run", "ear_clipping", "--steps", "1", "--quiet", "--set", f"input={rings}", "variant=book"]
    argv += ["--out", str(out)]
    code = main(argv + (["--strict"] if strict else []))
    err = capsys.readouterr().err.strip().splitlines()
    with np.load(out) as data:
        area_input, area_output, deviation = (float(data[k]) for k in ("area_input", "area_output", "deviation"))
    expected = 8 * 3 - 1.5 * 0.5 - 0.5 * 0.5 - 0.4 * 0.5  # the outer rectangle less its three holes: 22.8
    assert area_input == pytest.approx(expected, rel=1e-12)
    assert deviation == pytest.approx((expected - area_output) / expected, rel=1e-9) and deviation > 0.01
    kind = "error" if strict else "warning"
    assert code == (1 if strict else 0) and len(err) == 2, err  # the device line, then the one line
    assert (
        err[1].startswith(f"ugpcl: {kind}: ear_clipping: triangulation incomplete") and "of the input's 22.8" in err[1]
    )


def test_a_complete_triangulation_is_silent_with_no_deviation(runtime, capsys, tmp_path):
    from ugpcl.cli import main

    code = main(["run", "ear_clipping", "--steps", "1", "--quiet", "--strict", "--out", str(tmp_path / "n.npz")])
    err = capsys.readouterr().err.strip().splitlines()
    with np.load(tmp_path / "n.npz") as data:
        assert bool(data["complete"].all()) and abs(float(data["deviation"])) < 1e-9
    assert code == 0 and len(err) == 1, err


# }}}
