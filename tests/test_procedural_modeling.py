"""Procedural modeling (vol.1 ch.1; docs/chapters/01-procedural-modeling.md): every generator's counts from the
book's formulas, winding, the closed cylinder's volume, curves and parallel-transported frames, the tree and its
growth clip, the L-system, the kernels against numpy, the CLI with mesh export, the views and Oclgrind."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import (
    dilate,
    first_mismatch,
    foreground,
    rasterize_segments,
    rasterize_triangles,
    render_view,
    run_cli,
    to_pixels,
)

from ugpcl.geometry import procedural as pm
from ugpcl.geometry.mesh import (
    drop_degenerate,
    is_watertight,
    normals_agree_with_winding,
    signed_volume,
    triangle_areas,
    weld,
)
from ugpcl.registry import get, scenes
from ugpcl.scenes.procedural_modeling import CURVES, PlaneParams, PlaneSimulation, TreeParams, TreeSimulation

SCENE_NAMES = [name for name in scenes() if name.startswith("procedural_modeling")]
SMALL = {  # sizes for the CLI and view tests (PoCL on 2 cores); the trees grow from _T = 0 there
    "procedural_modeling": {"generations": 3, "grow_t": 0.0},
    "procedural_modeling_forest": {"trees": 4, "generations": 3, "grow_t": 0.0},
}


def winding_dots(mesh) -> np.ndarray:
    """dot((b - a) x (c - a), n_a + n_b + n_c) of every triangle of non-zero area."""
    v, f = mesh.vertices.astype(np.float64), mesh.faces
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    real = np.linalg.norm(cross, axis=1) > 1e-12
    return np.einsum("ij,ij->i", cross, mesh.normals[f].sum(axis=1))[real]


# {{{ counts and winding


@pytest.mark.parametrize("w, h", [(2, 2), (8, 8), (3, 17), (30, 5)])
def test_plane_counts_bbox_and_uv_corners(w, h):
    mesh = pm.plane(w, h, 2.5, 1.5)
    assert len(mesh.vertices) == w * h and len(mesh.faces) == 2 * (w - 1) * (h - 1)
    np.testing.assert_allclose(mesh.vertices.min(axis=0), [-1.25, 0, -0.75])
    np.testing.assert_allclose(mesh.vertices.max(axis=0), [1.25, 0, 0.75])
    corner = np.flatnonzero((mesh.uvs == 0).all(axis=1))
    np.testing.assert_allclose(mesh.vertices[corner], [[-1.25, 0, 0.75]])  # uv (0, 0) at (-w/2, +h/2)
    assert (winding_dots(mesh) > 0).all()


def test_quad_is_the_books():
    mesh = pm.quad(2.0)
    np.testing.assert_array_equal(mesh.vertices, [[-1, 1, 0], [1, 1, 0], [1, -1, 0], [-1, -1, 0]])
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [2, 3, 0]])
    np.testing.assert_array_equal(mesh.uvs, [[0, 0], [1, 0], [1, 1], [0, 1]])
    assert (winding_dots(mesh) > 0).all() and normals_agree_with_winding(mesh) == 1.0


@pytest.mark.parametrize("segments", [3, 7, 16, 32])
@pytest.mark.parametrize("caps", [True, False])
def test_cylinder_counts(segments, caps):
    s1 = segments + 1
    good = pm.cylinder(3.0, 1.0, segments, caps)
    bad = pm.cylinder(3.0, 1.0, segments, caps, bad=True)
    assert (len(good.vertices), len(good.faces)) == ((4 * s1 + 2, 4 * s1) if caps else (2 * s1, 2 * s1))
    assert (len(bad.vertices), len(bad.faces)) == ((2 * s1 + 2, 4 * s1) if caps else (2 * s1, 2 * s1))
    assert (winding_dots(good) > 0).all()
    side = good.vertices[: 2 * s1]
    np.testing.assert_allclose(np.hypot(side[:, 0], side[:, 2]), 1.0, atol=1e-6)
    assert set(np.round(good.vertices[:, 1], 6)) == {-1.5, 1.5}
    if caps:
        np.testing.assert_array_equal(good.normals[-2:], [[0, 1, 0], [0, -1, 0]])


@pytest.mark.parametrize("segments", [3, 16, 32])
def test_closed_cylinder_welds_watertight_with_the_prism_volume(segments):
    height, radius = 3.0, 1.0
    mesh = pm.cylinder(height, radius, segments, open_ended=True)
    kept = drop_degenerate(mesh)
    assert len(mesh.faces) - len(kept.faces) == 4  # the seam quad's two and the last triangle of each cap fan
    welded = weld(kept)
    assert is_watertight(welded)
    volume = segments / 2 * radius**2 * math.sin(2 * math.pi / segments) * height
    assert signed_volume(welded) == pytest.approx(volume, rel=1e-6)
    if segments == 16:
        assert volume == pytest.approx(9.18440, abs=1e-5)


def test_bad_cylinder_shares_the_side_normals_on_its_caps():
    bad, good = pm.cylinder(3.0, 1.0, 16, bad=True), pm.cylinder(3.0, 1.0, 16)
    top_bad = bad.faces[2 * 17 :][:, 1:]  # cap fan corners on the ring
    assert np.abs(bad.normals[top_bad][..., 1]).max() == 0  # horizontal: lit like the side
    top_good = good.faces[2 * 17 :][:, 1:]
    assert np.abs(good.normals[top_good][..., 1]).min() == 1  # the cap's own +-y


def test_mountain_scene_values():
    p = get("procedural_modeling_mountain").params()
    mesh = pm.plane(p.width_segments, p.height_segments, p.width, p.height, pm.mountain_depth(p.power, p.depth))
    y = mesh.vertices[:, 1].reshape(p.height_segments, p.width_segments)
    np.testing.assert_allclose(y, y[::-1], atol=1e-6)
    np.testing.assert_allclose(y, y[:, ::-1], atol=1e-6)
    assert y.max() == pytest.approx(0.75179, abs=1e-4)
    assert np.abs(np.concatenate([y[0], y[-1], y[:, 0], y[:, -1]])).max() == 0
    assert normals_agree_with_winding(mesh) == 1.0


def test_terrain_heights_are_in_range_deterministic_and_seeded(runtime):
    scene = get("procedural_modeling_terrain")
    a, b, c = (scene.create(runtime, seed, width_segments=64, height_segments=64) for seed in (0, 0, 1))
    y = a.mesh().vertices[:, 1]
    assert -0.05 <= y.min() and y.max() <= 1.05 and np.ptp(y) > 0.2
    np.testing.assert_array_equal(y, b.mesh().vertices[:, 1])
    assert not np.allclose(y, c.mesh().vertices[:, 1])
    assert normals_agree_with_winding(a.mesh()) == 1.0


def test_perlin_noise_is_continuous_and_zero_on_the_lattice():
    perm = pm.perlin_permutation(3)
    k = np.arange(-3, 4, dtype=float)
    np.testing.assert_allclose(pm.perlin(k[:, None], k[None, :], perm), 0.5)  # gradient noise vanishes at corners
    x = np.linspace(-2, 2, 4001)
    values = pm.perlin(x, 0.37 * np.ones_like(x), perm)
    assert np.abs(np.diff(values)).max() < 5e-3 and 0 <= values.min() and values.max() <= 1


def test_tubular_counts_rings_and_winding():
    curve = pm.CatmullRomCurve(CURVES["scene"])
    for s, r in [(25, 10), (2, 3), (7, 3)]:  # R = 2 would be a flat ribbon
        tube = pm.tubular(curve, s, r, 0.25)
        assert (len(tube.mesh.vertices), len(tube.mesh.faces)) == ((s + 1) * (r + 1), 2 * s * r)
        assert (winding_dots(tube.mesh) > 0).all()
        rings = tube.mesh.vertices.reshape(s + 1, r + 1, 3)
        np.testing.assert_allclose(np.linalg.norm(rings - tube.centers[:, None], axis=-1), 0.25, atol=1e-5)
        np.testing.assert_allclose(
            tube.mesh.uvs.reshape(s + 1, r + 1, 2)[:, :, 1],
            np.repeat(np.arange(s + 1)[:, None] / s, r + 1, 1),
            rtol=1e-6,
        )
    knot = pm.tubular(pm.CatmullRomCurve(CURVES["knot"], closed=True), 60, 8, 0.2, closed=True)
    assert (winding_dots(knot.mesh) > 0).all()
    np.testing.assert_array_equal(knot.mesh.vertices[:9], knot.mesh.vertices[-9:])  # the last ring repeats ring 0


# }}}

# {{{ curves and frames


def test_catmull_rom_passes_its_points_and_is_arc_length_parametrised():
    points = np.array(CURVES["scene"])
    curve = pm.CatmullRomCurve(points)
    np.testing.assert_allclose(curve.point_at([0.0, 1.0]), points[[0, -1]], atol=1e-5)
    np.testing.assert_allclose(curve.point(np.arange(4) / 3), points, atol=1e-12)
    steps = np.linalg.norm(np.diff(curve.point_at(np.arange(201) / 200), axis=0), axis=1)
    assert steps.max() / steps.min() < 1.02
    # the book's cubic: p1 + t0 w + c2 w^2 + c3 w^3 on the middle piece at w = 0.5
    p0, p1, p2, p3 = points
    t0, t1 = 0.5 * (p2 - p0), 0.5 * (p3 - p1)
    mid = p1 + t0 * 0.5 + (-3 * p1 + 3 * p2 - 2 * t0 - t1) * 0.25 + (2 * p1 - 2 * p2 + t0 + t1) * 0.125
    np.testing.assert_allclose(curve.point([0.5]), [mid])


def minimal_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation about a x b taking unit a to unit b (no Rodrigues: I + [v]x + [v]x^2 / (1 + c))."""
    v, c = np.cross(a, b), float(a @ b)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.identity(3) + vx + vx @ vx / (1 + c)


@pytest.mark.parametrize("curve, closed", [("scene", False), ("script", False), ("knot", False), ("knot", True)])
def test_frames_are_orthonormal_and_parallel_transported(curve, closed):
    frames = pm.compute_frames(pm.CatmullRomCurve(CURVES[curve], closed=closed), 50, closed)
    T, N, B = frames.tangent, frames.normal, frames.binormal
    for v in (T, N, B):
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-5)
    for u, v in ((T, N), (T, B), (N, B)):
        assert np.abs(np.sum(u * v, axis=1)).max() < 1e-5
    np.testing.assert_allclose(np.cross(T, N), B, atol=1e-5)  # right-handed as the book's Cross(T, N)
    if not closed:  # consecutive normals differ by the minimal rotation between the tangents
        for i in range(1, len(T)):
            np.testing.assert_allclose(minimal_rotation(T[i - 1], T[i]) @ N[i - 1], N[i], atol=1e-9)
    if curve == "scene":  # a planar curve in z = 0: no twist, every normal is -z
        np.testing.assert_allclose(N, np.tile([0, 0, -1], (len(N), 1)), atol=1e-5)


def test_closed_frames_close_the_twist_and_the_books_do_not():
    curve = pm.CatmullRomCurve(CURVES["knot"], closed=True)

    def end_angle(variant):
        f = pm.compute_frames(curve, 40, closed=True, variant=variant)
        tangent_gap = math.degrees(math.acos(np.clip(f.tangent[0] @ f.tangent[-1], -1, 1)))
        return math.degrees(math.acos(np.clip(f.normal[0] @ f.normal[-1], -1, 1))), tangent_gap

    fixed, gap = end_angle("fixed")
    book, _ = end_angle("book")
    # what is left is the gap between the book's one-sided end tangents (GetTangent clamps t to [0, 1])
    assert fixed <= 1.01 * gap < 1.0
    assert book > 90.0  # Deg2Rad twice: the correction turns by (pi / 180)^2 of the angle


# }}}

# {{{ the tree


def book_tree_mesh(branches: pm.TreeBranches, radial: int) -> dict[int, np.ndarray]:
    """ProceduralTree.Build as the book writes it: Traverse (children first, then the branch), per ring i and
    vertex j: normal = normalize(cos N + sin B), position + radius normal, uv (j / R, vOffset + vLength i / (n - 1)).
    Rows (x, y, z, nx, ny, nz, u, v) per tree."""
    children = {b: [] for b in range(len(branches))}
    for b, parent in enumerate(branches.parent):
        if parent >= 0:
            children[int(parent)].append(b)
    rows: dict[int, list] = {}

    def traverse(b):
        for child in children[b]:
            traverse(child)
        tree = int(branches.tree[b])
        max_length = branches.max_length[tree]
        n = branches.positions.shape[1]
        for i in range(n):
            v = branches.offset[b] / max_length + branches.length[b] / max_length * i / (n - 1)
            N, B = branches.frames.normal[b, i], branches.frames.binormal[b, i]
            for j in range(radial + 1):
                u = j / radial
                normal = math.cos(u * 2 * math.pi) * N + math.sin(u * 2 * math.pi) * B
                normal /= np.linalg.norm(normal)
                position = branches.positions[b, i] + branches.radii[b, i] * normal
                rows.setdefault(tree, []).append([*position, *normal, u, v])

    for root in np.flatnonzero(branches.parent < 0):
        traverse(root)
    return {tree: np.array(r) for tree, r in rows.items()}


def assert_same_rows(actual: np.ndarray, expected: np.ndarray, atol: float, what: str = "") -> None:
    """The two arrays hold the same multiset of rows, in any order: every row of each has a row of the other
    within atol (per component), and around every expected row both hold as many rows (a tube's last ring and a
    child's first ring can coincide exactly)."""
    from scipy.spatial import cKDTree

    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    mine, theirs = cKDTree(actual), cKDTree(expected)
    for rows, other, name in ((actual, theirs, "actual"), (expected, mine, "expected")):
        distance, _ = other.query(rows, p=np.inf)
        worst = int(np.argmax(distance))
        assert distance.max() <= atol, f"{what}: {name} row {worst} {rows[worst]} is {distance[worst]:.3g} away"
    near = 4 * atol
    count_expected = theirs.query_ball_point(expected, near, p=np.inf, return_length=True)
    count_actual = mine.query_ball_point(expected, near, p=np.inf, return_length=True)
    assert (count_expected == count_actual).all(), f"{what}: a row occurs a different number of times"


def tree_rows(sim: TreeSimulation) -> dict[int, np.ndarray]:
    m = sim.mesh()
    rows = np.concatenate([m.vertices, m.normals, m.uvs], axis=1).astype(np.float64)
    per_branch = (sim.params.height_segments + 1) * (sim.params.radial_segments + 1)
    tree_of_vertex = np.repeat(sim.branches.tree, per_branch)
    return {t: rows[tree_of_vertex == t] for t in np.unique(tree_of_vertex)}


SMALL_FOREST = {"trees": 5, "generations": 3, "height_segments": 5, "radial_segments": 6}


@pytest.mark.parametrize("builder", ["numpy", "opencl"])
def test_tree_rings_equal_the_books_loops_as_sets_per_tree(runtime, builder):
    sim = TreeSimulation(runtime, TreeParams(builder=builder, **SMALL_FOREST), seed=7)
    reference = book_tree_mesh(sim.branches, sim.params.radial_segments)
    got = tree_rows(sim)
    assert sorted(got) == sorted(reference) == list(range(5))
    for tree in reference:
        assert_same_rows(got[tree], reference[tree], 2e-5, f"tree {tree}")


def test_forest_kernel_equals_numpy(runtime):
    params = TreeParams(**SMALL_FOREST)
    cpu = TreeSimulation(runtime, params, seed=3)
    gpu = TreeSimulation(runtime, params.replace(builder="opencl"), seed=3)
    got, expected = tree_rows(gpu), tree_rows(cpu)
    for tree in expected:  # as sets: the order of branches is not the book's concern
        assert_same_rows(got[tree], expected[tree], 1e-5, f"tree {tree}")

    # triangles as sets of corner positions
    def corners(sim):
        return sim.mesh().vertices[sim.mesh().faces].reshape(-1, 9).astype(np.float64)

    assert_same_rows(corners(gpu), corners(cpu), 1e-5, "triangles")
    np.testing.assert_allclose(gpu.tangents[:, :3], np.asarray(cpu.tangents)[:, :3], atol=1e-6)
    assert (gpu.tangents[:, 3] == 0).all()


def test_tree_counts_and_invariants(runtime):
    sim = get("procedural_modeling").create(runtime)
    p, b, m = sim.params, sim.branches, sim.mesh()
    assert len(m.vertices) == len(b) * 99 and len(m.faces) == len(b) * 160
    assert len(b) <= sum(3**k for k in range(p.generations + 1))
    np.testing.assert_array_equal(b.start[b.parent < 0], [[0, 0, 0]])
    tips = b.generation == 0
    assert tips.any() and (b.radii[tips, -1] == 0).all()
    assert (b.radii[~tips, -1] > 0).all()
    v = m.uvs[:, 1]
    assert v.min() >= 0 and v.max() == pytest.approx(1.0, abs=1e-6)
    # children start on their parent's curve, offset by the parent's nominal length
    child = np.flatnonzero(b.parent >= 0)
    parent = b.parent[child]
    distance = np.linalg.norm(b.positions[parent] - b.start[child][:, None], axis=-1).min(axis=1)
    np.testing.assert_allclose(distance, 0, atol=1e-9)
    np.testing.assert_allclose(b.offset[child], b.offset[parent] + b.length[parent])
    assert normals_agree_with_winding(m) >= 0.99  # skewed frames (the book's): a few rings are tilted


BOOK_TREE_DATA = {  # TreeData's defaults in the sample (ProceduralTree.cs), the chapter's section 1.4.3
    "length_attenuation": 0.9,
    "radius_attenuation": 0.6,
    "branches_min": 1,
    "branches_max": 3,
    "growth_angle_min": -15.0,
    "growth_angle_max": 15.0,
    "growth_angle_scale": 4.0,
}


def test_tree_follows_the_books_branching_law(runtime):
    """The law of TreeBranch, checked on every branch of a forest against the chapter's rules written here: 1 to 3
    children spread from the middle to the end of the parent (ratio = lerp(0.5, 1, i / (count - 1)), 1 for one
    child), each starting on the parent's ring floor(ratio S) with length times lerp(1, 0.9, ratio) (0.90-0.95 of
    the parent's) and its direction the parent's tangent there turned by qn qb, two turns about perpendicular axes
    of at most scale 15 degrees each, scale = lerp(1, 4, 1 - generation / generations): so at most
    acos(cos^2(15 scale)) from the tangent, and near that at the tips (60 degrees a turn)."""
    sim = get("procedural_modeling").create(runtime, trees=16, generations=4)
    p, b = sim.params, sim.branches
    assert {k: getattr(p, k) for k in BOOK_TREE_DATA} == BOOK_TREE_DATA
    S, G = p.height_segments, p.generations
    tips_turn = []
    for parent in np.flatnonzero(b.generation > 0):
        children = np.flatnonzero(b.parent == parent)
        count = len(children)
        assert 1 <= count <= 3
        ratios = [1.0] if count == 1 else [0.5 + 0.5 * i / (count - 1) for i in range(count)]
        expected = sorted((b.length[parent] * (1 - 0.1 * r), int(math.floor(r * S))) for r in ratios)
        got = []
        for child in children:
            ring = int(np.argmin(np.linalg.norm(b.positions[parent] - b.start[child], axis=1)))
            assert np.linalg.norm(b.positions[parent, ring] - b.start[child]) < 1e-9
            got.append((b.length[child], ring))
            tangent = b.frames.tangent[parent, ring]
            direction = (b.end[child] - b.start[child]) / b.length[child]
            assert np.linalg.norm(b.end[child] - b.start[child]) == pytest.approx(b.length[child], rel=1e-9)
            turn = math.degrees(math.acos(np.clip(direction @ tangent / np.linalg.norm(tangent), -1, 1)))
            scale = 1 + 3 * (1 - b.generation[child] / G)
            bound = math.degrees(math.acos(math.cos(math.radians(15 * scale)) ** 2))
            assert turn <= bound + 1e-6, (child, turn, bound)
            if b.generation[child] == 0:
                tips_turn.append(turn)
        np.testing.assert_allclose(sorted(got), expected, rtol=1e-9)
        assert all(0.9 - 1e-12 <= length / b.length[parent] <= 0.95 + 1e-12 for length, _ in got)
    # the tips turn up to 60 degrees about each axis (75.5 in all): with scale 1 they would stay under 21.1
    assert len(tips_turn) > 200 and max(tips_turn) > 50.0


def test_tree_is_seeded_and_the_same_alone_or_in_a_forest(runtime):
    scene = get("procedural_modeling")
    a, b = scene.create(runtime, 5), scene.create(runtime, 5)
    np.testing.assert_array_equal(a.mesh().vertices, b.mesh().vertices)
    a.reset()  # a rebuild reseeds, as the book's Setup()
    np.testing.assert_array_equal(a.mesh().vertices, b.mesh().vertices)
    assert not np.array_equal(scene.create(runtime, 6).branches.end, a.branches.end)
    assert not np.array_equal(scene.create(runtime, 5, random_seed=1).branches.end, a.branches.end)
    forest = scene.create(runtime, 5, trees=4)
    first = forest.branches.tree == 0
    origin = pm.forest_origins(4, forest.params.spacing)[0]
    np.testing.assert_allclose(forest.branches.positions[first] - origin, a.branches.positions, atol=1e-12)


def test_growth_clip_advances_with_time(runtime):
    assert get("procedural_modeling").create(runtime, generations=2).grow_t == 1.0  # grown, the chapter's figure
    sim = get("procedural_modeling").create(runtime, generations=3, grow_seconds=2.0, grow_t=0.0)
    assert sim.grow_t == 0.0 and not sim.visible()[sim.mesh().uvs[:, 1] > 0].any()
    for _ in range(60):
        sim.step(1 / 60)
    assert sim.grow_t == pytest.approx(0.5)
    visible = sim.visible()
    assert 0 < visible.mean() < 1 and (sim.mesh().uvs[visible, 1] <= 0.5).all()
    for _ in range(200):
        sim.step(1 / 60)
    assert sim.grow_t == 1.0 and sim.visible().all()
    sim.restart_growth()
    assert sim.grow_t == 0.0


# }}}

# {{{ L-system


def book_lsystem(depth: int, length: float, attenuation: float, angle: float) -> list[tuple]:
    """LSystem.cs's DrawFractal written out with 4x4 matrices: draw M (0,0,0) -> M (0,len,0), then recurse with
    M Translate(0,len,0) RotZ(-angle) and M Translate(0,len,0) RotZ(+angle), depth - 1, len attenuation."""
    out = []

    def rot_z(degrees):
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
        return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])

    def translate(y):
        m = np.eye(4)
        m[1, 3] = y
        return m

    def draw(m, depth, length, level):
        if depth <= 0:
            return
        out.append(((m @ [0, 0, 0, 1])[:3], (m @ [0, length, 0, 1])[:3], level))
        for turn in (-angle, angle):
            draw(m @ translate(length) @ rot_z(turn), depth - 1, length * attenuation, level + 1)

    draw(np.eye(4), depth, length, 0)
    return out


FIGURE_1_15 = {"depth": 7, "length": 1.0, "attenuation": 0.635, "angle": 30.0}
"""Figure 1.15: "each branch is branched by changing by 30 degrees" (LSystem.scene); attenuation 0.635."""


@pytest.mark.parametrize("angle", [30.0, 20.0, 45.0])
def test_lsystem_segments_are_the_books_draw_fractal(angle):
    expected = book_lsystem(7, 1.0, 0.635, angle)
    segments, level = pm.lsystem_segments(7, 1.0, 0.635, angle)
    assert len(segments) == len(expected) == 127 and np.bincount(level).tolist() == [2**k for k in range(7)]
    rows = np.concatenate([segments.reshape(-1, 6), level[:, None]], axis=1).astype(np.float64)
    book = np.array([[*a, *b, lv] for a, b, lv in expected])
    assert_same_rows(rows, book, 1e-5, f"segments at {angle} degrees")


def test_lsystem_scene_is_figure_1_15(runtime):
    sim = get("procedural_modeling_lsystem").create(runtime)
    p = sim.params
    assert (p.depth, p.length, p.attenuation, p.angle) == tuple(FIGURE_1_15.values())
    segments = sim.state()["segments"]
    # every child turns exactly 30 degrees from its parent, left or right
    direction = segments[:, 1] - segments[:, 0]
    k = np.arange(1, 127)
    parent = direction[(k - 1) // 2].astype(np.float64)
    child = direction[k].astype(np.float64)
    cross = parent[:, 0] * child[:, 1] - parent[:, 1] * child[:, 0]
    turn = np.degrees(np.arctan2(cross, (parent[:, :2] * child[:, :2]).sum(1)))
    np.testing.assert_allclose(np.abs(turn), 30.0, atol=1e-3)
    lengths = np.linalg.norm(direction, axis=1)
    assert lengths.sum() == pytest.approx(sum((2 * 0.635) ** k for k in range(7)), rel=1e-6)
    assert lengths.sum() == pytest.approx(16.0324, abs=1e-4)


def test_lsystem_rewriting():
    algae = [pm.lsystem_expand("a", {"a": "ab", "b": "a"}, n) for n in range(6)]
    assert [len(s) for s in algae] == [1, 2, 3, 5, 8, 13] and algae[3] == "abaab"
    assert pm.lsystem_expand("X", {"X": "F[-X][+X]"}, 2) == "F[-F[-X][+X]][+F[-X][+X]]"


# }}}

# {{{ plane kernels


@pytest.mark.parametrize("surface", ["flat", "mountain", "terrain"])
@pytest.mark.parametrize("w, h", [(30, 30), (17, 9), (2, 2)])
def test_grid_kernels_equal_numpy(runtime, surface, w, h):
    params = PlaneParams(width_segments=w, height_segments=h, surface=surface, width=2.0, height=3.0, depth=2.0)
    if surface == "terrain":  # the terrain scene's noise offsets (chapter page: u_offset 0.77, v_offset 1)
        params = params.replace(u_offset=0.77, v_offset=1.0)
    cpu = PlaneSimulation(runtime, params, seed=4).mesh()
    gpu = PlaneSimulation(runtime, params.replace(builder="opencl"), seed=4).mesh()
    np.testing.assert_array_equal(gpu.faces, cpu.faces)
    np.testing.assert_allclose(
        gpu.vertices, cpu.vertices, atol=1e-5, err_msg=first_mismatch(gpu.vertices, cpu.vertices, 0, 1e-5)
    )
    np.testing.assert_allclose(gpu.uvs, cpu.uvs, atol=1e-6)
    np.testing.assert_allclose(gpu.normals, cpu.normals, atol=1e-4)


def test_grid_triangles_on_a_larger_launch_writes_only_its_cells(runtime):
    """GridTriangles' guard: launched over the whole vertex grid (W, H), as GridVertices and GridNormals are, the
    work-items of the last column and row write nothing; the cells' triangles are Plane.cs's, and nothing past them."""
    W, H = 5, 4
    cells = 6 * (W - 1) * (H - 1)
    triangles = runtime.to_device(np.full(cells + 12, -7, np.int32))  # 12 sentinels past the cells
    runtime.program("procedural_modeling", DEPTH_FN=0).kernel("GridTriangles")(
        (W, H), None, triangles, np.int32(W), np.int32(H)
    )
    out = triangles.get()
    np.testing.assert_array_equal(out[:cells].reshape(-1, 3), pm.plane(W, H, 1.0, 1.0, None).faces)
    np.testing.assert_array_equal(out[cells:], -7)


# }}}

# {{{ parameters, CLI and export


@pytest.mark.parametrize(
    "scene, overrides, message",
    [
        ("procedural_modeling", {"branches_min": 3, "branches_max": 2}, "branches_min"),
        ("procedural_modeling_tubular", {"curve": "spiral"}, "curve must be one of"),
    ],
)
def test_bad_parameters_name_the_field(scene, overrides, message):
    """The rules test_params does not try on every field: branches_min <= branches_max, unknown choices."""
    with pytest.raises(ValueError, match=message):
        get(scene).params(**overrides)


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_run_writes_npz_png_and_mesh(capsys, tmp_path, name):
    import trimesh

    sets = [f"{k}={v}" for k, v in SMALL.get(name, {}).items()]
    suffix = ".obj" if name.endswith("lsystem") else ".glb"
    out, png, mesh = tmp_path / "x.npz", tmp_path / "x.png", tmp_path / f"x{suffix}"
    argv = ["run", name, "--steps", "3", "--out", str(out), "--png", str(png), "--png-size", "96x64"]
    code, text = run_cli(capsys, *argv, "--mesh", str(mesh), *(["--set", *sets] if sets else []))
    assert code == 0, text
    data = np.load(out)
    assert "params" in data.files and png.stat().st_size > 0
    if name.endswith("lsystem"):
        assert data["segments"].shape == (127, 2, 3) and data["level"].shape == (127,)
        assert sum(line.startswith("l ") for line in mesh.read_text().splitlines()) == 127
        return
    for key in ("vertices", "normals", "uv", "triangles"):
        assert key in data.files, key
    assert data["triangles"].dtype == np.uint32
    loaded = trimesh.load(mesh, force="mesh", process=False)
    assert len(loaded.vertices) == len(data["vertices"]) and len(loaded.faces) == len(data["triangles"])
    np.testing.assert_allclose(np.asarray(loaded.vertices), data["vertices"], atol=1e-6)
    if name.endswith("_cylinder") and not name.endswith("bad_cylinder"):
        from ugpcl.geometry.mesh import Mesh

        welded = weld(drop_degenerate(Mesh(np.asarray(loaded.vertices), np.asarray(loaded.faces))))
        assert is_watertight(welded) and signed_volume(welded) == pytest.approx(9.18440, abs=1e-4)
    if name.endswith("tubular"):
        assert data["frame_n"].shape == data["curve_points"].shape == (26, 3)
    if name in ("procedural_modeling", "procedural_modeling_forest"):
        assert data["grow_t"] == pytest.approx(3 / 60 / 3.0)
        assert len(data["branch_parent"]) * 99 == len(data["vertices"])


def test_run_every_keeps_the_growth_history(capsys, tmp_path):
    out = tmp_path / "t.npz"
    code, text = run_cli(
        capsys,
        "run",
        "procedural_modeling",
        "--steps",
        "6",
        "--every",
        "2",
        "--out",
        str(out),
        "--set",
        "generations=2",
        "grow_t=0",
    )
    assert code == 0, text
    np.testing.assert_allclose(np.load(out)["grow_t_history"], np.arange(4) * 2 / 60 / 3.0, atol=1e-7)


# }}}

# {{{ views


def projected_state(view, camera, size) -> tuple[np.ndarray, np.ndarray]:
    """Where the scene's state lands in a (W, H) picture, by the test's own projection and rasterizer: the mesh at
    every copy of the view's layout (and the cylinder's other variant at x = -5), or the L-system's lines. (pixel
    centres covered, pixels touched: the covered ones and every pixel a triangle's edge crosses, for thin tips)."""
    sim = view.sim
    if not hasattr(view, "layout"):  # the L-system: lines
        ends, front = to_pixels(camera, sim.state()["segments"].reshape(-1, 3), size)
        assert front.all()
        lines = rasterize_segments(ends.reshape(-1, 2, 2), size)
        return lines, lines
    parts = [(sim.mesh(), offset) for offset, _ in view.layout()]
    if hasattr(view, "other"):
        parts.append((sim.mesh_of(not sim.params.bad), (-2 * view.spacing, 0.0, 0.0)))
    corners = []
    for mesh, offset in parts:
        xy, front = to_pixels(camera, mesh.vertices.astype(np.float64) + offset, size)
        assert front.all()
        corners.append(xy[mesh.faces])
    corners = np.concatenate(corners)
    covered = rasterize_triangles(corners, size)
    edges = np.stack([corners, np.roll(corners, 1, axis=1)], axis=2).reshape(-1, 2, 2)
    return covered, covered | rasterize_segments(edges, size)


@pytest.mark.gl
@pytest.mark.parametrize("name", SCENE_NAMES)
def test_views_draw_the_state_where_it_projects(runtime, gl, name):
    """The drawn pixels are the state's projection: nothing drawn farther than a pixel from it, and all of it
    drawn but its one-pixel rim (a mesh moved, scaled, left out or a copy missing fails)."""
    sim = get(name).create(runtime, **SMALL.get(name, {}))
    for _ in range(200):  # the trees grow fully (_T = 1 after 3 s)
        sim.step(1 / 60)
    size = (160, 96)
    pixels, primitives, view, camera = render_view(gl, name, sim, size=size, show_frames=False)
    drawn = foreground(pixels, view.background)
    expected, touched = projected_state(view, camera, size)
    assert expected.mean() > 0.005 and primitives > 0
    stray = drawn & ~dilate(touched, 1)
    assert stray.sum() <= 0.01 * drawn.sum(), f"{stray.sum()} of {drawn.sum()} drawn pixels outside the projection"
    if hasattr(view, "layout"):
        inner = ~dilate(~expected, 1)
        missing = inner & ~drawn
        assert missing.sum() <= 0.02 * inner.sum(), f"{missing.sum()} of {inner.sum()} projected pixels not drawn"
    else:  # lines: every pixel a segment crosses is drawn within a pixel
        missing = expected & ~dilate(drawn, 1)
        assert missing.sum() <= 0.02 * expected.sum(), f"{missing.sum()} of {expected.sum()} line pixels not drawn"
    assert {k.key for k in view.keys} >= {"[", "]"}
    for key in view.keys:
        assert callable(getattr(view, key.action)), key.action


@pytest.mark.gl
def test_material_modes_and_the_bad_cylinders_caps(runtime, gl):
    name = "procedural_modeling_cylinder"
    sim = get(name).create(runtime, material="normal")
    pixels, _, view, camera = render_view(gl, name, sim, size=(200, 120))
    # the good cylinder's top cap in Normal mode: (0, 1, 0) -> (0.5, 1, 0.5)
    clip = camera.projection() @ camera.view() @ np.array([0.0, 1.5, 0.0, 1.0])
    x = int(round((clip[0] / clip[3] + 1) / 2 * 200 - 0.5))
    y = int(round((1 - clip[1] / clip[3]) / 2 * 120 - 0.5))
    np.testing.assert_allclose(pixels[y, x] / 255, [0.5, 1.0, 0.5], atol=0.03)
    # the bad cylinder (x = -5, standard) beside the good one drawn standard: their caps are lit differently
    sim.update(material="standard")
    pixels, _, view, camera = render_view(gl, name, sim, size=(200, 120))

    def cap_colour(cx):
        clip = camera.projection() @ camera.view() @ np.array([cx, 1.5, 0.0, 1.0])
        px = int(round((clip[0] / clip[3] + 1) / 2 * 200 - 0.5))
        py = int(round((1 - clip[1] / clip[3]) / 2 * 120 - 0.5))
        return pixels[py, px].astype(int)

    good, bad = cap_colour(0.0), cap_colour(-5.0)
    assert np.abs(good - bad).sum() > 40, (good, bad)


@pytest.mark.gl
def test_the_tree_grows_on_screen(runtime, gl):
    name = "procedural_modeling"
    sim = get(name).create(runtime, generations=3)
    counts = []
    for t in (0.0, 0.3, 1.0):
        sim.grow_t = t
        pixels, _, view, camera = render_view(gl, name, sim, size=(160, 120))
        counts.append(foreground(pixels, view.background).sum())
    assert counts[0] <= 0.01 * counts[2] and counts[0] < counts[1] < counts[2]  # _T = 0 keeps uv.y = 0 only
    # at _T = 0.3 nothing is drawn above the kept part of the mesh: the vertices with uv.y <= 0.3 and the points
    # of the triangles' edges where uv.y (interpolated linearly in the world, as perspective-correct varyings are)
    # crosses 0.3 (plus a pixel)
    sim.grow_t = 0.3
    pixels, _, view, camera = render_view(gl, name, sim, size=(160, 120))
    m = sim.mesh()
    a, b = m.faces.reshape(-1), np.roll(m.faces, 1, axis=1).reshape(-1)  # every edge of every triangle
    ya, yb = m.uvs[a, 1].astype(np.float64), m.uvs[b, 1].astype(np.float64)
    crossing = (ya - 0.3) * (yb - 0.3) < 0
    s = ((0.3 - ya[crossing]) / (yb[crossing] - ya[crossing]))[:, None]
    edge_points = m.vertices[a[crossing]] * (1 - s) + m.vertices[b[crossing]] * s
    low = np.concatenate([m.vertices[m.uvs[:, 1] <= 0.3 + 1e-6], edge_points])
    clip = (camera.projection() @ camera.view() @ np.column_stack([low, np.ones(len(low))]).T).T
    top_row = ((1 - clip[:, 1] / clip[:, 3]) / 2 * 120 - 0.5).min()
    rows = np.flatnonzero(foreground(pixels, view.background).any(axis=1))
    assert rows.min() >= top_row - 2


@pytest.mark.gl
def test_tubular_overlay_draws_frames_and_division_points(runtime, gl):
    name = "procedural_modeling_tubular"
    sim = get(name).create(runtime, material="standard")
    with_overlay, _, view, _ = render_view(gl, name, sim, size=(200, 120))
    without, _, _, _ = render_view(gl, name, sim, size=(200, 120), show_frames=False)
    changed = np.abs(with_overlay.astype(int) - without).sum(axis=-1) > 30
    red = (with_overlay[..., 0] > 200) & (with_overlay[..., 1] < 80) & changed
    yellow = (with_overlay[..., 0] > 150) & (with_overlay[..., 1] > 120) & (with_overlay[..., 2] < 90) & changed
    assert changed.sum() > 50 and red.any() and yellow.any()


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind):
    for surface in ("mountain", "terrain"):
        params = PlaneParams(width_segments=5, height_segments=4, surface=surface)
        gpu = PlaneSimulation(oclgrind, params.replace(builder="opencl"), seed=1).mesh()
        cpu = PlaneSimulation(oclgrind, params, seed=1).mesh()
        np.testing.assert_allclose(gpu.vertices, cpu.vertices, atol=1e-5)
        np.testing.assert_allclose(gpu.normals, cpu.normals, atol=1e-4)
    params = TreeParams(trees=2, generations=2, height_segments=4, radial_segments=4, builder="opencl")
    gpu = TreeSimulation(oclgrind, params, seed=1)
    cpu = TreeSimulation(oclgrind, params.replace(builder="numpy"), seed=1)
    np.testing.assert_allclose(gpu.mesh().vertices, cpu.mesh().vertices, atol=1e-5)
    np.testing.assert_array_equal(gpu.mesh().faces, cpu.mesh().faces)
    assert triangle_areas(gpu.mesh().vertices, gpu.mesh().faces).sum() > 0
