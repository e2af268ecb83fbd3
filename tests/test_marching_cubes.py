"""Marching cubes (vol.1 ch.7; docs/chapters/07-marching-cubes.md, "Tests"): tables, field and polygonisation against
numpy and scikit-image, pool counters, topology and orientation, the headless CLI, the geometry-shader view,
Oclgrind."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import first_mismatch, foreground
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from skimage.measure import marching_cubes as skimage_marching_cubes

from ugpcl.buffers import Pool, device_sizeof
from ugpcl.geometry import marching_cubes_tables as tables
from ugpcl.registry import get
from ugpcl.scenes.marching_cubes import TRIANGLE_DTYPE, Params, Simulation

# {{{ numpy float64 reference, written from the book's Sample/geom_light (GPUMarchingCubesRenderStandardMesh.shader)

OFFSET = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)])
CONNECTION = np.array([(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)])
DIRECTION = OFFSET[CONNECTION[:, 1]] - OFFSET[CONNECTION[:, 0]]


def smooth_max(d1, d2, k=14.0):
    return np.log(np.exp(k * d1) + np.exp(k * d2)) / k


def round_box(q, size, r):
    return np.linalg.norm(np.maximum(np.abs(q) - np.asarray(size) * 0.5, 0.0), axis=-1) - r


def capsule(q, a, b, r):
    pa, ba = q - np.asarray(a), np.asarray(b) - np.asarray(a)
    h = np.clip((pa @ ba) / (ba @ ba), 0.0, 1.0)
    return np.linalg.norm(pa - ba * h[..., None], axis=-1) - r


def ellipsoid(q, r):
    r = np.asarray(r)
    return (np.linalg.norm(q / r, axis=-1) - 1.0) * r.min()


def kaiware(q):
    d1 = round_box(q, (1, 0.8, 1), 0.1)
    d2_0 = round_box(q - (0, -0.2, 0.7), (0.8, 0.25, 0.3), 0.1)
    d2_1 = round_box(q - (0, 0, 0.7), (1.1, 0.35, 1.1), 0.0)
    d2_2 = round_box(q - (0, -0.4, 0.7), (1.1, 0.35, 1.1), 0.0)
    d2_3 = round_box(q - (0, -0.2, 0.7), (0.75, 0.1, 0.25), 0.1)
    d2 = np.minimum(np.minimum(np.maximum(d2_0, d2_1), np.maximum(d2_0, d2_2)), d2_3)
    d3 = np.minimum(
        capsule(q, (0, 0.5, 0), (0, 0.75, 0), 0.05),
        np.minimum(
            ellipsoid(q - (0.2, 0.75, 0), (0.25, 0.025, 0.1)), ellipsoid(q - (-0.2, 0.75, 0), (0.25, 0.025, 0.1))
        ),
    )
    d4 = np.minimum(
        capsule(q, (0.2, 0.25, 0.6), (0.4, 0.2, 0.6), 0.03), capsule(q, (-0.2, 0.25, 0.6), (-0.4, 0.2, 0.6), 0.03)
    )
    return np.maximum(np.minimum(np.minimum(d1, d2), d3), -d4)


def sample(g: np.ndarray, n: int, shape: str, t: float) -> np.ndarray:
    """The book's Sample(x, y, z) at grid coordinates g (..., 3) in float64."""
    g = np.asarray(g, np.float64)
    border = np.any(g <= 1, axis=-1) | np.any(g >= n - 1, axis=-1)
    pos = g / n
    if shape == "kaiware":  # result = -DistanceFuncKaiware(twistY(pos - 0.5, _SinTime.z * 10), 0.5) + 0.5
        q = pos - 0.5
        angle = 10.0 * math.sin(t / 2) * q[..., 1]
        c, s = np.cos(angle), np.sin(angle)
        q = np.stack([c * q[..., 0] - s * q[..., 2], q[..., 1], s * q[..., 0] + c * q[..., 2]], axis=-1)
        result = 0.5 - 0.5 * kaiware(q / 0.5)
    else:
        base, amplitude = (0.1, 0.025) if shape == "spheres-book" else (0.005, 0.125)
        result = np.zeros(g.shape[:-1])
        for i in range(3):
            radius = base + (math.sin(t * 8.0 + i * 23.365) * 0.5 + 0.5) * amplitude
            sp = -(np.linalg.norm(pos - (0.5, 0.25 + 0.25 * i, 0.5), axis=-1) - radius) + 0.5
            result = smooth_max(result, sp)
    return np.where(border, 0.0, result)


def field_reference(n: int, shape: str, t: float) -> np.ndarray:
    z, y, x = np.meshgrid(*(np.arange(n + 1),) * 3, indexing="ij")
    return sample(np.stack([x, y, z], axis=-1), n, shape, t)  # [z, y, x]


def trilinear(field: np.ndarray, g: np.ndarray) -> np.ndarray:
    """field[z, y, x] at grid coordinates g (..., 3), clamped to the grid."""
    n = field.shape[0] - 1
    g = np.clip(g, 0, n)
    i = np.minimum(np.floor(g).astype(int), n - 1)
    f = g - i
    total = 0.0
    for k in range(8):
        o = OFFSET[k]
        w = np.prod(np.where(o, f, 1 - f), axis=-1)
        total = total + w * field[i[..., 2] + o[2], i[..., 1] + o[1], i[..., 0] + o[0]]
    return total


def case_indices(field: np.ndarray, threshold: float) -> np.ndarray:
    """flagIndex of every cell, [z, y, x]: bit k set when corner k's value <= threshold."""
    n = field.shape[0] - 1
    index = np.zeros((n, n, n), np.int64)
    for k, (ox, oy, oz) in enumerate(OFFSET):
        index |= (field[oz : oz + n, oy : oy + n, ox : ox + n] <= threshold).astype(np.int64) << k
    return index


def triangles_per_case() -> np.ndarray:
    return (tables.TRIANGLE_CONNECTION_TABLE >= 0).sum(axis=1) // 3


def polygonize_reference(field, threshold, normal_sample):
    """geom_light on every cell in cell-id order: (positions (T, 3, 3) object space, normals, cell ids)."""
    n = field.shape[0] - 1
    cases = case_indices(field, threshold).ravel()  # [z, y, x] ravel = cell id x + n (y + n z)
    positions, normals, cells = [], [], []
    h = np.identity(3)
    for cell in np.flatnonzero(triangles_per_case()[cases]):
        x, y, z = cell % n, (cell // n) % n, cell // (n * n)
        g = np.array([x, y, z])
        value = np.array([field[z + o[2], y + o[1], x + o[0]] for o in OFFSET], np.float64)
        row = tables.TRIANGLE_CONNECTION_TABLE[cases[cell]]
        for i in range(5):
            if row[3 * i] < 0:
                break
            tri_p, tri_n = [], []
            for e in row[3 * i : 3 * i + 3]:
                a, b = CONNECTION[e]
                delta = value[b] - value[a]
                offset = 0.5 if delta == 0 else (threshold - value[a]) / delta  # getOffset
                vertex = OFFSET[a] + offset * DIRECTION[e]
                tri_p.append((g + vertex) / n - 0.5)
                grad = np.array([normal_sample(g + vertex - h[k]) - normal_sample(g + vertex + h[k]) for k in range(3)])
                tri_n.append(grad / np.linalg.norm(grad))
            positions.append(tri_p)
            normals.append(tri_n)
            cells.append(cell)
    return np.array(positions).reshape(-1, 3, 3), np.array(normals).reshape(-1, 3, 3), np.array(cells, np.int64)


# }}}

# {{{ mesh measures (independent of our welding)


def area_and_volume(p: np.ndarray) -> tuple[float, float]:
    p = p.astype(np.float64)
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1).sum()
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    return float(area), float(volume)


def weld(p: np.ndarray, decimals: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Vertices rounded to 1e-5 and merged (docs/chapters/07-marching-cubes.md, "Tests"): (vertices, faces)."""
    vertices, inverse = np.unique(np.round(p.reshape(-1, 3).astype(np.float64), decimals), axis=0, return_inverse=True)
    return vertices, inverse.reshape(-1, 3)


def topology(faces: np.ndarray, n_vertices: int) -> dict:
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, uses = np.unique(edges, axis=0, return_counts=True)
    graph = coo_matrix((np.ones(len(unique)), (unique[:, 0], unique[:, 1])), shape=(n_vertices, n_vertices))
    used = np.unique(faces)
    components = connected_components(graph, directed=False)[1][used]
    return {
        "edge uses": np.bincount(uses),
        "degenerate": int(
            ((faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])).sum()
        ),
        "chi": len(used) - len(unique) + len(faces),
        "components": len(np.unique(components)),
    }


# }}}


def make(runtime, n: int = 32, cpu_kernels: bool | None = None, **overrides) -> Simulation:
    """A scene on ``runtime``; ``cpu_kernels`` True/False remeshes with the *_cpu or the one-cell kernels (None: the
    device's own choice). A switch fills the field with NaN first: the other kernels' field must not stand in for
    one that the chosen SampleField leaves unwritten."""
    sim = Simulation(runtime, Params(segment_num=n, **overrides))
    if cpu_kernels is not None and cpu_kernels != sim.cpu_kernels:
        sim.cpu_kernels = cpu_kernels
        sim.field.fill(np.float32(np.nan))
        sim.remesh()
    return sim


def test_cpu_kernels_are_chosen_by_device_type(runtime):
    sim = make(runtime, 8)
    assert sim.cpu_kernels == (not runtime.is_gpu)  # the fixture's devices: PoCL or a GPU
    cpu = "" if runtime.is_gpu else "_cpu"
    assert sim.stats()["kernels"] == f"SampleField{cpu}, PolygonizeAppend{cpu}"  # the summary names what ran
    sim.update(path="scan")
    expected = f"SampleField{cpu}, ClassifyCells{cpu}, ScanBlocks, AddBlockOffsets, GenerateTriangles{cpu}"
    assert sim.stats()["kernels"] == expected


# {{{ layout and tables


def test_triangle_dtype_matches_the_device_struct(runtime):
    assert TRIANGLE_DTYPE.itemsize == 76
    assert device_sizeof(runtime, "McTriangle", "marching_cubes.h") == TRIANGLE_DTYPE.itemsize


def test_tables_have_the_books_shape_and_counts():
    tri = tables.TRIANGLE_CONNECTION_TABLE
    assert tri.shape == (256, 16)
    counts = triangles_per_case()
    for row, count in zip(tri, counts, strict=True):
        assert (row[: 3 * count] >= 0).all() and (row[: 3 * count] < 12).all() and (row[3 * count :] == -1).all()
    # Bourke's table has this histogram for 0..5 triangles per case (docs/chapters/07-marching-cubes.md, "What
    # differs from the book"); ours must too
    assert np.bincount(counts).tolist() == [2, 16, 50, 80, 76, 32]
    assert counts[0] == counts[255] == 0


def test_edge_flags_are_the_cut_edges_and_derivable_from_the_triangles():
    for case in range(256):
        bits = [(case >> k) & 1 for k in range(8)]
        cut = sum(1 << e for e, (a, b) in enumerate(CONNECTION) if bits[a] != bits[b])
        used = 0
        for e in tables.TRIANGLE_CONNECTION_TABLE[case]:
            used |= (1 << int(e)) if e >= 0 else 0
        assert tables.CUBE_EDGE_FLAGS[case] == cut == used, case
    assert tables.CUBE_EDGE_FLAGS[:3].tolist() == [0x000, 0x109, 0x203]  # Bourke's edgeTable starts so
    np.testing.assert_array_equal(tables.VERTEX_OFFSET, OFFSET)
    np.testing.assert_array_equal(tables.EDGE_CONNECTION, CONNECTION)
    np.testing.assert_array_equal(tables.EDGE_DIRECTION, DIRECTION)


def _face_segments(case: int) -> dict:
    """The cell's boundary segments (triangle edges used once) grouped by the cube face they lie on, in that face's
    own 2D coordinates, keyed by (axis, the face's 4 corner bits)."""
    midpoint = (OFFSET[CONNECTION[:, 0]] + OFFSET[CONNECTION[:, 1]]) / 2
    row = tables.TRIANGLE_CONNECTION_TABLE[case]
    triangles = row[row >= 0].reshape(-1, 3)
    uses: dict = {}
    for tri in triangles:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            uses[frozenset((int(a), int(b)))] = uses.get(frozenset((int(a), int(b))), 0) + 1
    assert all(u in (1, 2) for u in uses.values()), f"case {case}: an edge inside the cell is used more than twice"
    faces: dict = {}
    for pair, count in uses.items():
        if count != 1:
            continue
        a, b = (midpoint[e] for e in pair)
        axes = [k for k in range(3) if a[k] == b[k] and a[k] in (0.0, 1.0)]
        assert axes, f"case {case}: boundary segment {sorted(pair)} is not on a face"
        axis = axes[0]
        side = a[axis]
        others = [k for k in range(3) if k != axis]
        on_face = sorted((tuple(OFFSET[k][others]), (case >> k) & 1) for k in range(8) if OFFSET[k][axis] == side)
        corner_bits = tuple(bit for _, bit in on_face)  # in face-local (u, v) order, the same from both sides
        local = frozenset((tuple(a[others]), tuple(b[others])))
        faces.setdefault((axis, corner_bits, side), set()).add(local)
    return faces


def test_tables_make_closed_meshes_neighbours_agree_on_every_face():
    """Both cells that share a face see its 4 corners with the same bits: their segments on it must coincide, for
    every case on either side (this is what keeps every mesh closed, ambiguous faces included)."""
    segments: dict = {}
    for case in range(256):
        for (axis, bits, _side), local in _face_segments(case).items():
            previous = segments.setdefault((axis, bits), local)
            assert previous == local, f"face pattern {bits} on axis {axis}: case {case} cuts it differently"
    ambiguous = [(axis, bits) for (axis, bits) in segments if len(segments[(axis, bits)]) == 2]
    assert len(ambiguous) == 6  # 3 axes x 2 diagonals, each cut around its set corners


def test_triangles_face_away_from_the_dense_corners():
    """Winding: (p1 - p0) x (p2 - p0) points against the trilinear field's gradient (set corners 0, others 1)."""
    midpoint = (OFFSET[CONNECTION[:, 0]] + OFFSET[CONNECTION[:, 1]]) / 2
    for case in range(1, 255):
        value = np.array([0.0 if (case >> k) & 1 else 1.0 for k in range(8)])
        row = tables.TRIANGLE_CONNECTION_TABLE[case]
        for a, b, c in row[row >= 0].reshape(-1, 3):
            normal = np.cross(midpoint[b] - midpoint[a], midpoint[c] - midpoint[a])
            p = (midpoint[a] + midpoint[b] + midpoint[c]) / 3
            grad = np.zeros(3)
            for k, o in enumerate(OFFSET):
                w = np.where(o, p, 1 - p)
                dw = np.where(o, 1.0, -1.0)
                grad += value[k] * np.array([dw[0] * w[1] * w[2], w[0] * dw[1] * w[2], w[0] * w[1] * dw[2]])
            assert normal @ grad < 0, f"case {case}: triangle ({a}, {b}, {c}) faces the dense side"


def test_generated_header_is_up_to_date():
    assert tables.HEADER.read_text() == tables.header_text(), "run: python -m ugpcl.geometry.marching_cubes_tables"


# }}}

# {{{ kernels vs reference


@pytest.mark.parametrize(
    "n, shape, t",
    [
        (8, "spheres-book", 0.0),
        (17, "spheres-repo", 0.3),
        (32, "spheres-book", 1.7),
        (32, "kaiware", 0.0),
        (33, "kaiware", 5.0),
    ],
)
@pytest.mark.parametrize("cpu_kernels", [False, True], ids=["one-cell", "cpu"])
def test_sample_field_matches_reference(runtime, n, shape, t, cpu_kernels):
    sim = make(runtime, n, cpu_kernels, shape=shape, time=t)
    field = sim.field_array()
    expected = field_reference(n, shape, t)
    # float32 exp/log/sqrt of values ~0.5 against float64: observed <= 4e-7 (the chapter page: < 2e-6)
    assert np.abs(field - expected).max() < 2e-6, first_mismatch(field.ravel(), expected.ravel(), 0, 2e-6)
    for border in (0, 1, n - 1, n):  # the book's Sample returns exactly 0 on the two outer layers
        assert not field[border].any() and not field[:, border].any() and not field[:, :, border].any()


@pytest.mark.parametrize("path", ["append", "scan"])
@pytest.mark.parametrize(
    "n, shape, t, normals",
    [(8, "spheres-book", 0.0, "analytic"), (17, "spheres-repo", 0.3, "grid"), (32, "spheres-repo", 0.0, "analytic")],
)
@pytest.mark.parametrize("cpu_kernels", [False, True], ids=["one-cell", "cpu"])
def test_polygonize_matches_reference(runtime, path, n, shape, t, normals, cpu_kernels):
    sim = make(runtime, n, cpu_kernels, shape=shape, time=t, normals=normals, path=path)
    state = sim.state()
    field = state["field"].astype(np.float64)  # classify on the kernel's own field: the same cases
    if normals == "analytic":
        normal_sample = lambda g: sample(g, n, shape, t)  # noqa: E731
    else:
        normal_sample = lambda g: trilinear(field, g)  # noqa: E731
    positions, nrm, cells = polygonize_reference(field, sim.params.threshold, normal_sample)
    assert len(cells) > 0
    np.testing.assert_array_equal(state["tri_cell"], cells)  # sorted by cell, table order inside a cell
    assert state["tri_count"] == len(cells)
    # float32 interpolation and object-space scaling against float64 (the chapter page: 1e-5 object units)
    np.testing.assert_allclose(state["tri_pos"], positions, rtol=0, atol=1e-5)
    # normals: float32 differences of field values ~0.5 over one cell; observed <= 2e-5
    np.testing.assert_allclose(state["tri_nrm"], nrm, rtol=0, atol=1e-4)


@pytest.mark.parametrize(
    "n, shape, t, threshold",
    [
        (32, "spheres-repo", 0.0, 0.5),
        (64, "spheres-repo", 0.3, 0.5),
        (32, "spheres-book", 0.0, 0.5),
        (32, "kaiware", 2.0, 0.45),
    ],
)
def test_against_scikit_image_on_the_same_field(runtime, n, shape, t, threshold):
    sim = make(runtime, n, shape=shape, time=t, threshold=threshold)
    state = sim.state()
    # the kernel compares with float32(threshold): give scikit-image the same level (fields with values within an
    # ulp of the level, like the kaiware's flat box faces, otherwise interpolate a different point)
    level = float(np.float32(threshold))
    verts, faces, _, _ = skimage_marching_cubes(state["field"], level=level, method="lorensen")
    theirs = verts[:, ::-1][faces]  # (z, y, x) index order -> (x, y, z) grid units
    ours = (state["tri_pos"].astype(np.float64) + 0.5) * n  # object space -> grid units
    assert len(ours) == len(theirs), "same cases on the same field: the same number of triangles"
    a, b = np.unique(ours.reshape(-1, 3), axis=0), np.unique(theirs.reshape(-1, 3), axis=0)
    assert cKDTree(b).query(a)[0].max() < 1e-4 and cKDTree(a).query(b)[0].max() < 1e-4  # same vertex sets
    (area, volume), (their_area, their_volume) = area_and_volume(ours), area_and_volume(theirs)
    # the tables fan some 4-6 sided (non-planar) polygons differently: observed area differences <= 1.2e-6 on the
    # spheres, 1.0e-3 on the creased kaiware (the issue asks for 1%); volume <= 8e-4 (N = 32 spheres-repo; the chapter
    # page's 1e-4 holds for Lorensen's table only, whose volumes are its reference values: test_prototype_values)
    assert abs(area - their_area) / their_area < (1e-5 if shape.startswith("spheres") else 2e-3)
    assert abs(volume - their_volume) / abs(their_volume) < 1e-3


def test_prototype_values(runtime):
    """The chapter page's float64 reference numbers (triangles, area and |signed volume| in grid units;
    docs/chapters/07-marching-cubes.md, "Tests")."""
    for n, shape, t, count, area, volume in [
        (32, "spheres-repo", 0.0, 544, 174.59, 151.64),
        (64, "spheres-repo", 0.0, 2192, 728.48, 1297.39),
        (64, "spheres-repo", 0.3, 4160, None, None),
        (32, "spheres-book", 0.0, 1528, 536.00, 836.01),
    ]:
        state = make(runtime, n, shape=shape, time=t).state()
        assert state["tri_count"] == count
        if area is not None:
            ours = area_and_volume((state["tri_pos"].astype(np.float64) + 0.5) * n)
            assert abs(ours[0] - area) < 0.01
            # the prototype's volumes are scikit-image's (Lorensen's table): 151.638, 1297.393, 836.014. Our
            # derived table fans 4-6 sided loops from their smallest edge index, another diagonal of the same
            # non-planar polygons: the area moves by ~1e-6, the volume by up to 8e-4 (151.519, 1297.150, 835.969)
            assert abs(ours[1] - volume) / volume < 1e-3


@pytest.mark.parametrize(
    "n, shape, t, threshold",
    [(32, "spheres-repo", 0.3, 0.47), (32, "spheres-book", 1.1, 0.5), (24, "kaiware", 2.0, 0.45)],
)
@pytest.mark.parametrize("path", ["append", "scan"])
def test_vertices_lie_on_the_iso_level(runtime, n, shape, t, threshold, path):
    """Every vertex sits on a cell edge where the kernel's own field, interpolated linearly along that edge, equals
    the threshold. Trilinear interpolation at the vertex is exactly that edge interpolation."""
    state = make(runtime, n, shape=shape, time=t, threshold=threshold, path=path).state()
    grid = (state["tri_pos"].reshape(-1, 3).astype(np.float64) + 0.5) * n
    on_edge = (np.abs(grid - np.round(grid)) < 1e-4).sum(axis=1)
    assert (on_edge >= 2).all(), "a vertex off the cell edges"
    # on a cell edge the trilinear field is the edge's linear interpolation: threshold up to float32 rounding
    level = trilinear(state["field"].astype(np.float64), grid)
    np.testing.assert_allclose(level, threshold, atol=1e-5)
    # and the vertex normals are unit length (the chapter page: |normal| = 1 +- 1e-4)
    np.testing.assert_allclose(np.linalg.norm(state["tri_nrm"], axis=-1), 1.0, atol=1e-4)


# }}}

# {{{ pool and scan invariants


def test_append_counter_equals_the_classification(runtime):
    sim = make(runtime, 32, shape="spheres-book", time=0.6)
    expected = triangles_per_case()[case_indices(sim.field_array(), sim.params.threshold)].sum()
    assert sim.pool.count() == expected and sim.pool.refused() == 0
    items = sim.pool.read()
    assert np.isfinite(items["position"]).all() and np.isfinite(items["normal"]).all()
    np.testing.assert_allclose(np.linalg.norm(items["normal"], axis=-1), 1.0, atol=1e-4)
    assert np.abs(items["position"]).max() <= 0.5


def test_full_pool_refuses_and_leaves_the_rest_untouched(runtime):
    sim = make(runtime, 16, shape="spheres-book")
    needed = sim.pool.count()
    capacity = needed // 3
    pool = Pool(runtime, needed, TRIANGLE_DTYPE, "canary")
    canary = np.zeros(needed, TRIANGLE_DTYPE)
    canary["cell"] = 0xDEADBEEF
    canary["position"] = 7.0
    pool.fill(canary)
    sim.polygonize_append(pool, capacity)
    assert pool.count() == capacity, "the counter clamps at capacity"
    assert pool.refused() == needed - capacity, "every triangle that did not fit is counted"
    items = pool.items.get()
    np.testing.assert_array_equal(items[capacity:], canary[capacity:])  # nothing written past capacity
    assert (items["cell"][:capacity] < 16**3).all()
    reference = {(int(t["cell"]), t["position"].tobytes()) for t in sim.triangles()}
    assert {(int(t["cell"]), t["position"].tobytes()) for t in items[:capacity]} <= reference


@pytest.mark.parametrize("path", ["append", "scan"])
def test_small_pool_grows_and_the_frame_is_redone(runtime, path):
    full = make(runtime, 24, shape="spheres-repo", time=0.3, path=path).state()
    sim = make(runtime, 24, shape="spheres-repo", time=0.3, path=path, triangle_capacity=10)
    state = sim.state()
    assert state["counter_overflowed"] and sim.overflows == 1
    assert sim.pool.capacity >= state["tri_count"] == full["tri_count"] and sim.pool.refused() == 0
    np.testing.assert_array_equal(state["tri_pos"], full["tri_pos"])
    sim.update(animate=False)
    sim.step()
    assert not sim.state()["counter_overflowed"]


@pytest.mark.parametrize("n", [1, 255, 256, 257, 1000, 65537, 300000])  # one value, under/at/over a block, 3 levels
def test_scan_matches_numpy(runtime, n, seed):
    sim = make(runtime, 4)
    values = np.random.default_rng(seed).integers(0, 6, n).astype(np.uint32)
    out = runtime.zeros(n, np.uint32)
    total = sim.scan(runtime.to_device(values), out, n)
    expected = np.concatenate([[0], np.cumsum(values)[:-1]]).astype(np.uint32)
    np.testing.assert_array_equal(out.get(), expected)
    assert total == values.sum()


def test_append_and_scan_paths_write_the_same_arrays(runtime):
    append = make(runtime, 40, shape="kaiware", time=3.0).state()
    scan = make(runtime, 40, shape="kaiware", time=3.0, path="scan").state()
    for key in ("tri_pos", "tri_nrm", "tri_cell", "vertices", "faces"):
        np.testing.assert_array_equal(append[key], scan[key])


def draw_reference(sim) -> np.ndarray:
    """What the view drew before PackVertices: each pooled corner's position and normal side by side, pool order."""
    tri = sim.pool.read()
    return np.concatenate([tri["position"].reshape(-1, 3), tri["normal"].reshape(-1, 3)], axis=1)


@pytest.mark.parametrize("path", ["append", "scan"])
def test_draw_vertices_are_the_pooled_triangles(runtime, path):
    """PackVertices hands the draw the pool's triangles bit for bit, frame after frame, as the mesh and its pinned
    buffers grow and after a reset; a frame without triangles is an empty array."""
    sim = make(runtime, 12, shape="kaiware", time=1.0, path=path, triangle_capacity=10)  # the pool grows once
    for change in ({}, {"segment_num": 24}, {"time": 2.0}, {"threshold": 1.0}):
        if change:
            sim.update(**change)
            sim.remesh()
        vertices = sim.draw_vertices()
        assert vertices.dtype == np.float32 and vertices.flags.c_contiguous
        assert len(vertices) == 3 * sim.pool.count() == 3 * sim.frame_counts[-1]
        np.testing.assert_array_equal(vertices, draw_reference(sim))
    assert len(vertices) == 0  # threshold 1: every corner outside, no cut cell


# }}}

# {{{ topology, orientation, animation


@pytest.mark.parametrize(
    "n, shape, t, components",
    [
        (32, "spheres-repo", 0.0, 3),
        (64, "spheres-repo", 0.0, 3),
        (64, "spheres-repo", 0.3, 2),
        (32, "spheres-book", 0.0, 1),
    ],
)
def test_mesh_is_closed_and_has_the_expected_pieces(runtime, n, shape, t, components):
    state = make(runtime, n, shape=shape, time=t).state()
    vertices, faces = weld(state["tri_pos"])
    found = topology(faces, len(vertices))
    assert found["edge uses"].tolist() == [0, 0, found["edge uses"][2]], "an edge not shared by exactly 2 triangles"
    assert found["degenerate"] == 0
    assert found["components"] == components and found["chi"] == 2 * components  # spheres: chi = 2 each
    # the scene's own welding (exact float equality) gives the same mesh
    assert len(state["vertices"]) == len(vertices) and len(state["faces"]) == len(faces)


def test_kaiware_mesh_is_closed_away_from_its_flat_beak(runtime):
    # the repository's box() is 0 everywhere inside, so part of the beak equals 0.5 exactly: at threshold 0.5 its
    # vertices sit on grid corners (degenerate triangles); any other threshold gives a closed sphere-like mesh
    # welded exactly (the scene's own mesh), not rounded to 1e-5: its flat box faces put many grid values within an
    # ulp of 0.45, and rounding merges vertices 1e-6 apart near those corners
    state = make(runtime, 32, shape="kaiware", time=2.0, threshold=0.45).state()
    vertices, faces = state["vertices"], state["faces"]
    found = topology(faces, len(vertices))
    assert set(np.flatnonzero(found["edge uses"])) == {2} and found["degenerate"] == 0
    assert found["chi"] == 2 * found["components"]


@pytest.mark.parametrize("shape", ["spheres-repo", "spheres-book", "kaiware"])
def test_faces_point_outward(runtime, shape):
    state = make(runtime, 32, shape=shape, time=0.5, threshold=0.45 if shape == "kaiware" else 0.5).state()
    p = state["tri_pos"].astype(np.float64)
    assert area_and_volume(p)[1] > 0, "signed volume must be positive: (p1 - p0) x (p2 - p0) outward"
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    agree = np.einsum("ij,ij->i", face, state["tri_nrm"].mean(axis=1)) > 0
    # the chapter page: > 99%; the kaiware's min/max creases make the +-1 cell differences straddle them
    # (observed 98.8%)
    assert agree.mean() > (0.98 if shape == "kaiware" else 0.99), (
        f"only {agree.mean():.3f} of face normals agree with the gradient normals"
    )


def test_animation_is_periodic(runtime):
    period = 2 * math.pi / 8  # sin(8 t + ...): every radius repeats
    a = make(runtime, 32, shape="spheres-repo", time=0.2).state()
    b = make(runtime, 32, shape="spheres-repo", time=0.2 + period).state()
    np.testing.assert_allclose(a["field"], b["field"], atol=1e-5)
    assert abs(int(a["tri_count"]) - int(b["tri_count"])) <= 0.005 * a["tri_count"]


def test_steps_advance_the_field_time_unless_still(runtime):
    sim = make(runtime, 16, shape="spheres-repo", time=0.1)
    sim.step(0.05)
    sim.step(0.05)
    state = sim.state()
    np.testing.assert_allclose(state["frame_time"], [0.1, 0.15, 0.2])
    assert len(state["tri_count_t"]) == 3 and state["tri_count_t"][-1] == state["tri_count"]
    np.testing.assert_allclose(state["field"], field_reference(16, "spheres-repo", 0.2), atol=2e-6)
    sim.update(animate=False)
    sim.step(0.05)
    assert sim.field_time == pytest.approx(0.2) and sim.time == pytest.approx(0.15)


# }}}

# {{{ parameters


# out-of-range values: tests/test_params.py, for every field of every scene
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"threshold": float("nan")}, "threshold must be a finite number"),
        ({"shape": "torus"}, "shape must be one of spheres-book\\|spheres-repo\\|kaiware"),
        ({"normals": "flat"}, "normals must be one of analytic\\|grid"),
        ({"path": "gs"}, "path must be one of append\\|scan"),
    ],
)
def test_bad_parameters_name_the_field(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_bad_dt_is_refused(runtime):
    sim = make(runtime, 8)
    for dt in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="dt must be in"):
            sim.step(dt)


# }}}

# {{{ headless CLI


def test_run_writes_npz_ply_and_obj(capsys, tmp_path):
    from ugpcl.cli import main
    from ugpcl.geometry.mesh_io import read_ply

    out, ply, obj = tmp_path / "mc.npz", tmp_path / "mc.ply", tmp_path / "mc.obj"
    argv = ["run", "marching_cubes", "--steps", "3", "--set", "segment_num=24", "--set", "shape=spheres-repo"]
    assert main([*argv, "--out", str(out), "--mesh", str(ply)]) == 0
    assert main([*argv, "--out", str(out), "--mesh", str(obj)]) == 0
    data = np.load(out)
    for key in (
        "field",
        "tri_pos",
        "tri_nrm",
        "tri_cell",
        "tri_count",
        "counter_overflowed",
        "tri_count_t",
        "vertices",
        "normals",
        "faces",
        "params",
    ):
        assert key in data.files, key
    assert data["field"].shape == (25, 25, 25) and data["tri_pos"].shape == (int(data["tri_count"]), 3, 3)
    assert data["tri_count_t"].shape == (4,)  # the frame at reset and one per step
    vertices, faces = read_ply(ply)
    np.testing.assert_array_equal(faces, data["faces"])
    np.testing.assert_allclose(vertices, data["vertices"])
    assert topology(faces, len(vertices))["edge uses"].tolist()[:2] == [0, 0]
    lines = obj.read_text().splitlines()
    assert sum(line.startswith("f ") for line in lines) == int(data["tri_count"])
    assert sum(line.startswith("vn ") for line in lines) == len(vertices)


# }}}

# {{{ view


def _project(camera, points: np.ndarray, size) -> np.ndarray:
    clip = (camera.projection() @ camera.view() @ np.column_stack([points, np.ones(len(points))]).T).T
    ndc = clip[:, :2] / clip[:, 3:]
    return (
        np.column_stack([(ndc[:, 0] + 1) / 2 * size[0] - 0.5, (1 - ndc[:, 1]) / 2 * size[1] - 0.5]).round().astype(int)
    )


def _render(view, camera, size=(96, 72)):
    from ugpcl.viewer.offscreen import frame

    camera.aspect = size[0] / size[1]
    view.upload()
    return frame(size).render(view, camera)


@pytest.mark.gl
def test_geometry_shader_emits_the_kernels_triangles(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("marching_cubes")
    sim = scene.create(runtime, segment_num=20, shape="spheres-repo", time=0.3)
    view = create_view(scene, gl, sim)
    view.shadows, view.show_floor = False, False
    camera = view.png_camera()
    view.use_gs = True  # the book's path (the view starts with the kernels' mesh)
    view.field_source = 1  # corners from SampleField's texture: the very same cases as the OpenCL path
    texture_image = _render(view, camera)
    assert view.gs_triangles == sim.pool.count() > 0
    view.field_source = 0  # the book's GS: Sample() evaluated in GLSL
    analytic_image = _render(view, camera)
    assert abs(view.gs_triangles - sim.pool.count()) <= 0.005 * sim.pool.count()
    view.use_gs = False  # the kernels' mesh
    mesh_image = _render(view, camera)
    assert view.mesh_vertices == 3 * sim.pool.count()
    masks = [foreground(image, view.background) for image in (texture_image, analytic_image, mesh_image)]
    assert (masks[0] == masks[2]).mean() > 0.995 and (masks[0] == masks[1]).mean() > 0.995
    assert np.abs(texture_image.astype(int) - mesh_image).mean() < 1.0


@pytest.mark.gl
@pytest.mark.parametrize("use_gs", [False, True], ids=["mesh", "geometry-shader"])
def test_view_shows_a_lit_surface_where_the_spheres_are(runtime, gl, use_gs):
    from ugpcl.viewer.views import create_view

    scene = get("marching_cubes")
    sim = scene.create(runtime, segment_num=32, shape="spheres-book")  # radii 0.10-0.125: one blob of three balls
    view = create_view(scene, gl, sim)
    assert not view.use_gs  # the kernels' mesh by default
    view.show_floor, view.use_gs = False, use_gs
    camera = view.make_camera()  # the book's: (0, 0, -1) looking at the object
    size = (128, 128)
    image = _render(view, camera, size)
    assert (view.gs_triangles if use_gs else view.mesh_vertices // 3) == sim.pool.count()
    mask = foreground(image, view.background)
    # sphere centres (object y = -0.25, 0, 0.25; the 180-degree yaw leaves x = z = 0)
    centres = _project(camera, np.array([[0.0, -0.25, 0.0], [0.0, 0.0, 0.0], [0.0, 0.25, 0.0]]), size)
    for x, y in centres:
        r, g, b = image[y, x].astype(int)
        assert mask[y, x] and g > r and g > b, f"no green surface at ({x}, {y}): {image[y, x]}"
    half_width = 0.13 * size[1] / (2 * math.tan(math.radians(30)) * (1.0 - 0.13))  # widest ball, on screen
    columns = np.flatnonzero(mask.any(axis=0))
    assert columns.min() >= size[0] / 2 - half_width - 2 and columns.max() <= size[0] / 2 + half_width + 2
    # lit from the upper right (lighting.glsl: towards the light is +x, +y, -z; the camera looks along +z with +x
    # to the right): on the top ball the upper-right quarter is brighter than the lower-left one
    yy, xx = np.mgrid[0 : size[1], 0 : size[0]]
    cx, cy = centres[2]
    near = mask & ((xx - cx) ** 2 + (yy - cy) ** 2 < 8**2)
    brightness = image.astype(int).sum(axis=-1)
    upper_right = brightness[near & (xx - cx + cy - yy > 3)].mean()
    lower_left = brightness[near & (xx - cx + cy - yy < -3)].mean()
    assert upper_right > lower_left + 30, (upper_right, lower_left)


@pytest.mark.gl
def test_outward_faces_are_the_visible_ones(runtime, gl):
    """Culling back faces changes nothing when the winding is outward; culling with the wrong front face does."""
    from ugpcl.viewer.views import create_view

    scene = get("marching_cubes")
    sim = scene.create(runtime, segment_num=20, shape="spheres-book")
    view = create_view(scene, gl, sim)
    view.show_floor, view.shadows, view.use_gs = False, False, False
    camera = view.png_camera()
    culled = _render(view, camera)
    view.cull = False
    both = _render(view, camera)
    view.cull, view.front_face = True, "ccw"
    wrong = _render(view, camera)
    assert np.abs(culled.astype(int) - both).max() <= 2
    assert np.abs(wrong.astype(int) - both).mean() > 5 * max(np.abs(culled.astype(int) - both).mean(), 0.1)


@pytest.mark.gl
def test_view_keys_change_the_simulation(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("marching_cubes")
    sim = scene.create(runtime, segment_num=16)
    view = create_view(scene, gl, sim)
    before = sim.pool.count()
    view.threshold_down()
    assert sim.params.threshold == pytest.approx(0.48) and sim.pool.count() != before  # remeshed at once
    view.threshold_up()
    assert sim.params.threshold == pytest.approx(0.5)
    view.more_cells()
    assert sim.n == 32
    view.fewer_cells()
    assert sim.n == 16
    view.toggle_animation()
    assert not sim.params.animate
    view.toggle_path()
    assert view.use_gs
    view.toggle_kernel_path()
    assert sim.params.path == "scan"
    view.toggle_normals()
    assert sim.params.normals == "grid"
    view.shape_kaiware()
    assert sim.params.shape == "kaiware"
    view.toggle_wireframe()
    _render(view, view.make_camera())
    assert view.wireframe
    assert {k.key for k in view.keys} >= {"[", "]", "+", "-", "a", "f", "tab", "g", "m", "p", "1", "2", "3"}


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind):
    for path in ("append", "scan"):  # N = 9: 729 cells = 3 scan blocks (two levels), 1000 field points
        sim = Simulation(oclgrind, Params(segment_num=9, shape="spheres-book", path=path, triangle_capacity=8))
        assert sim.overflows == 1  # the first append/generate ran into a full pool, the rerun fit
        state = sim.state()
        assert state["tri_count"] > 0
        np.testing.assert_allclose(state["field"], field_reference(9, "spheres-book", 0.0), atol=2e-6)
    kaiware = Simulation(oclgrind, Params(segment_num=8, shape="kaiware", normals="grid", time=1.0))
    assert kaiware.state()["tri_count"] > 0
    # PackVertices on a pool filled to the last slot: its vertex buffers then have no slack either
    exact = kaiware.pool.count()
    full = Simulation(oclgrind, Params(segment_num=8, shape="kaiware", time=1.0, triangle_capacity=exact))
    assert full.pool.count() == full.pool.capacity and full.overflows == 0
    np.testing.assert_array_equal(full.draw_vertices(), draw_reference(full))
    # the *_cpu kernels: N = 9 has a full run of 8 cells and a run of 1 per row (the field: 8 + 2 points), N = 16
    # full runs whose last vload8 reads the row's last point
    for n, shape in ((9, "spheres-book"), (16, "spheres-repo"), (9, "kaiware")):
        for path in ("append", "scan"):
            sim = make(oclgrind, n, True, shape=shape, path=path)
            assert sim.state()["tri_count"] > 0
            if shape != "kaiware":
                np.testing.assert_allclose(sim.field_array(), field_reference(n, shape, 0.0), atol=2e-6)
