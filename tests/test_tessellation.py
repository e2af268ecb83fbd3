"""Tessellation + displacement (vol.4 ch.6; docs/chapters/17-tessellation.md, "Checks"): the plane and camera, the fluid
the scene drives (vol.4's stripped solver in variant=book), the TCS factors and TES displacement captured from the GPU
against numpy, primitive counts, culling, the rendered image, CLI, view, Oclgrind."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from helpers import first_mismatch, foreground, linear_filter_error

from ugpcl.geometry.tessellation import (
    displace_plane_grid,
    fractional_odd_triangles,
    frustum_side_planes,
    plane_corners,
    plane_mesh,
    plane_model,
    scene_camera,
    tess_factors,
)
from ugpcl.registry import get
from ugpcl.scenes.tessellation import Params, Simulation

DT = 1.0 / 60.0

# {{{ numpy float64 references, written from the book's listings (UnityEdgeLengthBasedTessCull, domain_shader)


def edge_factor_ref(a, b, eye, screen_height, edge_length):
    return max(np.linalg.norm(a - b) * screen_height / (edge_length * np.linalg.norm((a + b) / 2 - eye)), 1.0)


def factors_ref(corners, eye, view_proj, screen_height, edge_length, displacement):
    """Per triangle, one at a time as the hull constant function does."""
    m = np.asarray(view_proj, float)
    planes = [m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1]]
    out = []
    for p0, p1, p2 in corners:
        culled = False
        for plane in planes:
            plane = plane / np.linalg.norm(plane[:3])
            if all(plane[:3] @ p + plane[3] < -1.5 * displacement for p in (p0, p1, p2)):
                culled = True
        if culled:
            out.append([0.0] * 4)
            continue
        f = [edge_factor_ref(a, b, eye, screen_height, edge_length) for a, b in ((p1, p2), (p2, p0), (p0, p1))]
        out.append(f + [sum(f) / 3])
    return np.array(out)


def bilinear_clamp_ref(texture, u, v):
    """GL LINEAR + CLAMP_TO_EDGE lookup of texture (h, w) at (u, v), texel centres at (i + 0.5) / w."""
    h, w = texture.shape
    x, y = u * w - 0.5, v * h - 0.5
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    fx, fy = x - x0, y - y0

    def t(i, j):
        return float(texture[min(max(j, 0), h - 1), min(max(i, 0), w - 1)])

    return (1 - fy) * ((1 - fx) * t(x0, y0) + fx * t(x0 + 1, y0)) + fy * (
        (1 - fx) * t(x0, y0 + 1) + fx * t(x0 + 1, y0 + 1)
    )


def gaussian_density(n: int, center=(0.5, 0.5), sigma=0.12, peak=1.0) -> np.ndarray:
    y, x = (np.mgrid[0:n, 0:n] + 0.5) / n
    return (peak * np.exp(-((x - center[0]) ** 2 + (y - center[1]) ** 2) / (2 * sigma**2))).astype(np.float32)


def blob_footprint(density, center, sigma, size, displacement) -> np.ndarray:
    """(H, W) bool, row 0 at the top: where the scene camera sees the plane within the gaussian blob (density > 1 %
    of its peak), raised or flat, dilated by 3 pixels."""
    vertices, _, _ = displace_plane_grid(density, 8, displacement)
    flat_vertices, _, _ = displace_plane_grid(np.zeros_like(density), 8, displacement)
    y, x = (np.mgrid[0:81, 0:81]) / 80.0
    weight = np.exp(-((x - center[0]) ** 2 + (y - center[1]) ** 2) / (2 * sigma**2)).ravel() > 0.01
    view_m, proj, _ = scene_camera(size[0] / size[1])
    footprint = np.zeros(size[::-1], bool)
    for points in (vertices[weight], flat_vertices[weight]):
        clip = np.c_[points, np.ones(len(points))] @ (proj @ view_m).T
        px = ((clip[:, 0] / clip[:, 3] + 1) / 2 * size[0]).astype(int)
        py = ((1 - clip[:, 1] / clip[:, 3]) / 2 * size[1]).astype(int)
        for cx, cy in zip(px, py, strict=True):
            footprint[max(cy - 3, 0) : cy + 4, max(cx - 3, 0) : cx + 4] = True
    return footprint


# }}}


def make(runtime, **overrides) -> Simulation:
    overrides.setdefault("grid", 32)
    overrides.setdefault("stroke", "none")
    return Simulation(runtime, Params(**overrides), seed=0)


# {{{ the plane, the camera, the fluid the scene owns


def test_plane_is_unitys_and_faces_the_camera():
    vertices, triangles = plane_mesh()
    assert vertices.shape == (121, 12) and triangles.shape == (200, 3)
    assert vertices[:, 0].min() == -5 and vertices[:, 0].max() == 5 and not vertices[:, 1].any()
    assert vertices[:, 10:].min() == 0 and vertices[:, 10:].max() == 1
    assert np.unique(np.sort(triangles, axis=1), axis=0).shape[0] == 200  # no triangle twice
    normal = plane_model()[:3, :3] @ [0, 1, 0]
    np.testing.assert_allclose(normal, [0, 0.669, -0.743], atol=1e-3)  # the sample scene's Plane, Euler (48, 180, 0)
    # uv (0, 0) lands bottom-left on screen and (1, 1) top-right: the painting reads upright
    view, proj, _ = scene_camera(16 / 9)
    corner = {tuple(v[10:]): v[:3] for v in vertices if tuple(v[10:]) in {(0.0, 0.0), (1.0, 1.0)}}
    model = plane_model()
    clip = {uv: proj @ view @ model @ np.append(p, 1.0) for uv, p in corner.items()}
    ndc = {uv: c[:2] / c[3] for uv, c in clip.items()}
    assert ndc[(0.0, 0.0)][0] < 0 < ndc[(1.0, 1.0)][0] and ndc[(0.0, 0.0)][1] < 0 < ndc[(1.0, 1.0)][1]


@pytest.mark.gl
def test_headless_camera_is_the_views(runtime, gl):
    from ugpcl.viewer.views import create_view

    view = create_view(get("tessellation"), gl, make(runtime))
    camera = view.make_camera()
    camera.aspect = 16 / 9
    v, p, eye = scene_camera(16 / 9)
    np.testing.assert_allclose(camera.view(), v, atol=1e-12)
    np.testing.assert_allclose(camera.projection(), p, atol=1e-12)
    np.testing.assert_allclose(camera.eye(), eye, atol=1e-12)


def test_fluid_is_the_2d_chapters_with_vol4_settings(runtime):
    book, fixed = make(runtime, variant="book"), make(runtime)
    assert type(book.fluid).__module__ == "ugpcl.scenes.stable_fluids_2d"
    assert book.fluid.params.solver == "vol4" and fixed.fluid.params.solver == "vol1"
    fp = book.fluid.params
    assert (fp.width, fp.height, fp.visc, fp.diff, fp.velocity_coef, fp.density_coef) == (32, 32, 100, 10, 4, 6)
    assert fp.source_radius == 0.072 and fp.variant == "book"
    book.update(visc=50.0, variant="fixed")  # live: handed to the same fluid
    assert book.fluid.params.visc == 50.0 and book.fluid.params.solver == "vol1"
    fluid = book.fluid
    book.update(grid=16)  # a new grid: a new fluid
    assert book.fluid is not fluid and book.fluid.w == 16


@pytest.mark.parametrize("variant", ["book", "fixed"])
def test_no_source_stays_exactly_zero_for_100_frames(runtime, variant):
    sim = make(runtime, variant=variant)
    for _ in range(100):
        sim.step()
    state = sim.fluid.state()
    for key in ("velocity", "density", "prev"):
        assert not state[key].any()


def test_blob_peaks_at_its_centre_and_adds_exactly_f_times_gain(runtime):
    sim = make(runtime, grid=33, variant="book")  # odd grid: texel 16 sits at uv 0.5
    fluid = sim.fluid
    fluid.add_source_brush(0.5, 0.5, 0.0, 0.0)
    f = fluid.state()["source"][..., 2]
    assert f[16, 16] == 1.0 and f.max() == 1.0
    y, x = (np.mgrid[0:33, 0:33] + 0.5) / 33
    far = np.hypot(x - 0.5, y - 0.5) > sim.params.source_radius
    assert not f[far].any(), "f = 0 farther than R"
    np.testing.assert_allclose(f, f[::-1, :], atol=1e-6)  # uv = (i + 0.5)/w - 0.5 rounds differently either side
    np.testing.assert_allclose(f, f.T, atol=1e-6)
    fluid.add_source_density(DT)
    density = fluid.state()["density"]
    np.testing.assert_allclose(density, f * np.float32(6.0) * np.float32(DT), rtol=1e-7, atol=0)


@pytest.mark.parametrize("variant", ["book", "fixed"])
def test_advection_without_velocity_returns_prev_z(runtime, seed, variant):
    sim = make(runtime, variant=variant)
    rng = np.random.default_rng(seed)
    prev = rng.uniform(0, 1, (32, 32, 4)).astype(np.float32)
    sim.fluid.set_fields(prev=prev)
    sim.fluid.advect_density(DT)
    np.testing.assert_array_equal(sim.fluid.state()["density"][1:-1, 1:-1], prev[1:-1, 1:-1, 2])


@pytest.mark.parametrize("n", [32, 128])
def test_boundaries_copy_the_inward_neighbour_and_negate_the_normal_velocity(runtime, seed, n):
    """After boundary_density every edge cell equals its inward neighbour exactly; after boundary_velocity the normal
    component is the negated neighbour's, the tangential one the cell's own (the book's rule); corners average their two
    edge neighbours."""
    rng = np.random.default_rng(seed)
    fluid = make(runtime, grid=n, variant="book").fluid
    velocity = rng.uniform(-1, 1, (n, n, 2)).astype(np.float32)
    density = rng.uniform(0, 1, (n, n)).astype(np.float32)
    fluid.set_fields(velocity=velocity, density=density)
    fluid.set_boundary_density()
    fluid.set_boundary_velocity()
    state = fluid.state()
    d, v = state["density"], state["velocity"]
    inner = slice(1, -1)
    np.testing.assert_array_equal(d[1:-1, 1:-1], density[1:-1, 1:-1])  # the interior untouched
    np.testing.assert_array_equal(v[1:-1, 1:-1], velocity[1:-1, 1:-1])
    for edge, inward in (
        ((inner, 0), (inner, 1)),
        ((inner, -1), (inner, -2)),
        ((0, inner), (1, inner)),
        ((-1, inner), (-2, inner)),
    ):
        np.testing.assert_array_equal(d[edge], d[inward])
    np.testing.assert_array_equal(v[inner, 0, 0], -velocity[inner, 1, 0])  # x walls: u negated, v kept
    np.testing.assert_array_equal(v[inner, -1, 0], -velocity[inner, -2, 0])
    np.testing.assert_array_equal(v[inner, 0, 1], velocity[inner, 0, 1])
    np.testing.assert_array_equal(v[inner, -1, 1], velocity[inner, -1, 1])
    np.testing.assert_array_equal(v[0, inner, 1], -velocity[1, inner, 1])  # y walls: v negated, u kept
    np.testing.assert_array_equal(v[-1, inner, 1], -velocity[-2, inner, 1])
    np.testing.assert_array_equal(v[0, inner, 0], velocity[0, inner, 0])
    np.testing.assert_array_equal(v[-1, inner, 0], velocity[-1, inner, 0])
    for y, x in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        ix, iy = (1 if x == 0 else -2), (1 if y == 0 else -2)
        np.testing.assert_array_equal(d[y, x], np.float32(0.5) * (d[y, ix] + d[iy, x]))
        np.testing.assert_array_equal(v[y, x], np.float32(0.5) * (v[y, ix] + v[iy, x]))


@pytest.mark.parametrize("variant", ["book", "fixed"])
def test_density_stays_between_zero_and_the_injected_total(runtime, variant):
    sim = make(runtime, variant=variant, stroke="circle")
    injected = 0.0
    for _ in range(80):
        sim.step()
        injected += sim.params.density_coef * DT  # f <= 1 per frame
        density = sim.density()
        assert density.min() >= 0.0 and density.max() <= injected * (1 + 1e-6)
    assert density.max() > 0.05


def test_book_projection_only_touches_the_walls_and_fixed_sweeps_converge(runtime, seed):
    rng = np.random.default_rng(seed)
    velocity = rng.uniform(-1, 1, (32, 32, 2)).astype(np.float32)
    book = make(runtime, variant="book")
    book.fluid.set_fields(velocity=velocity)
    book.fluid.project()  # vol.4: no sweep, p = 0
    assert not book.fluid.state()["prev"][..., 0].any(), "p must stay 0 without a pressure solve"
    after = book.fluid.state()["velocity"]
    np.testing.assert_array_equal(after[1:-1, 1:-1], velocity[1:-1, 1:-1])
    assert not np.array_equal(after[0], velocity[0])
    norms = []
    for sweeps in (10, 40, 100):
        fixed = make(runtime, variant="fixed")
        y, x = (np.mgrid[0:32, 0:32] + 0.5) / 32 - 0.5
        bump = np.exp(-(x**2 + y**2) / 0.02)
        fixed.fluid.set_fields(velocity=np.stack([x * bump, y * bump], -1))
        fixed.fluid.project(sweeps)
        v = fixed.fluid.state()["velocity"].astype(float)
        div = (v[1:-1, 2:, 0] - v[1:-1, :-2, 0]) + (v[2:, 1:-1, 1] - v[:-2, 1:-1, 1])
        norms.append(np.linalg.norm(div))
    assert norms[0] > norms[1] > norms[2], norms


# }}}
# {{{ the fluid's kernels one by one (random inputs, 32 x 32 and 128 x 128, the scene's values)


def smooth_field(rng, n: int, channels: int, amplitude: float, k_max: float) -> np.ndarray:
    """(n, n, channels): 3 random sine modes per channel of up to k_max radians per cell, peak |value| <= amplitude."""
    y, x = np.mgrid[0:n, 0:n]
    out = np.zeros((n, n, channels))
    for c in range(channels):
        for _ in range(3):
            k = rng.uniform(-k_max, k_max, 2)
            out[..., c] += np.sin(k[0] * x + k[1] * y + rng.uniform(0, 2 * np.pi))
    return amplitude / 3 * out


@pytest.mark.parametrize("n", [32, 128])
@pytest.mark.parametrize("variant", ["book", "fixed"])
def test_every_fluid_kernel_matches_numpy_on_random_inputs(runtime, seed, n, variant):
    """Each kernel of the scene's fluid (the 2D chapter's, with this scene's coefficients) against the 2D chapter's
    float64 reference, rtol 1e-5, atol 1e-6."""
    import reference.stable_fluids_2d as ref  # the same kernels: the numpy reference of vol.1 ch.4's Solver2D

    rng = np.random.default_rng(seed + n)
    sim = make(runtime, grid=n, variant=variant)
    fluid, p = sim.fluid, sim.fluid.params
    book = variant == "book"

    def check(key, expected, channel=None):
        actual = fluid.state()[key].astype(np.float64)
        if channel is not None:
            actual = actual[..., channel]
        assert np.allclose(actual, expected, rtol=1e-5, atol=1e-6), first_mismatch(actual, expected, 1e-5, 1e-6)

    def load(**fields):
        fluid.set_fields(**{k: np.asarray(v, np.float32) for k, v in fields.items()})
        return {k: np.asarray(v, np.float32).astype(np.float64) for k, v in fields.items()}

    f = load(**{k: v for k, v in ref.random_fields(rng, n, n).items()})
    fluid.add_source_brush(0.43, 0.58, 0.6, -0.8)
    check("source", ref.brush_ref(n, n, (0.43, 0.58), (0.6, -0.8), p.source_radius))
    source = fluid.state()["source"].astype(np.float64)
    fluid.add_source_velocity(DT)
    fluid.add_source_density(DT)
    check("velocity", f["velocity"] + source[..., :2] * p.velocity_coef * DT)
    check("density", f["density"] + source[..., 2] * p.density_coef * DT)
    check("prev", source[..., :3] * [p.velocity_coef * DT, p.velocity_coef * DT, p.density_coef * DT], slice(0, 3))

    f = load(**ref.random_fields(rng, n, n))
    fluid.diffuse_velocity(DT, 1)
    fluid.diffuse_density(DT, 1)
    check("velocity", ref.boundary_velocity(ref.diffuse_ref(f["velocity"], f["prev"][..., :2], DT * p.visc * n * n)))
    check("density", ref.boundary_copy(ref.diffuse_ref(f["density"], f["prev"][..., 2], DT * p.diff * n * n)))

    f = load(**ref.random_fields(rng, n, n))
    fluid.project_step1()
    prev = ref.boundary_copy(ref.boundary_copy(ref.project_step1_ref(f["velocity"], f["prev"], book), 1, book), 0)
    check("prev", prev)
    fluid.project_step2(2)  # two sweeps: the first starts from p = 0, so only the second reads neighbours' p
    for _ in range(2):
        prev = ref.boundary_copy(ref.project_step2_ref(prev), 0)
    check("prev", prev)
    fluid.project_step3()
    check("velocity", ref.boundary_velocity(ref.project_step3_ref(f["velocity"], prev)))

    # advection: back-traces of up to ~ 4 cells (book: leaving the grid at the walls) into a field that changes by
    # < 0.1 per cell and fades to 0 at the walls (the zero reads outside). A float32 traced point near x = 127 is only
    # known to ulp(127) = 7.6e-6 cells, so on white noise any float32 kernel is ~1e-5 off; here that is < 1e-6, while
    # a wrong tap or weight is off by ~0.01-0.1.
    dfdt = DT * n
    y, x = np.mgrid[0:n, 0:n]
    fade = (np.sin(np.pi * (x + 1) / (n + 1)) * np.sin(np.pi * (y + 1) / (n + 1)))[..., None]
    f = load(
        velocity=smooth_field(rng, n, 2, 2.0, 1.5),
        prev=smooth_field(rng, n, 4, 1.0, 0.08) * fade,
        source=smooth_field(rng, n, 4, 2.0, 1.5),
    )
    fluid.advect_density(DT)
    check("density", ref.boundary_copy(ref.advect_density_ref(f["velocity"], f["prev"], dfdt, book)))
    fluid.advect_density_from_ext(DT)
    check("density", ref.boundary_copy(ref.advect_density_ref(f["source"][..., :2], f["prev"], dfdt, book)))
    fluid.advect_velocity(DT)
    check("velocity", ref.boundary_velocity(ref.advect_velocity_ref(f["prev"], dfdt, book)))


@pytest.mark.parametrize("variant, sweep", [("book", None), ("fixed", "ProjectStep2"), ("fixed", "ProjectStep2Rows")])
def test_whole_fluid_steps_match_numpy_with_the_scenes_values(runtime, variant, sweep):
    """The scene's step (vol.4's stripped solver for book, vol.1's for fixed) against the 2D chapter's reference of
    the host order: a stroke for 4 frames, then 2 without (prev keeps its leftovers). fixed: with either pressure
    sweep, ProjectStep2 (what CPUs run) and ProjectStep2Rows (strips of 4 cells, what GPUs run)."""
    import reference.stable_fluids_2d as ref

    sim = make(runtime, variant=variant, stroke="circle", stroke_frames=4)
    if sweep:
        sim.fluid.sweep_kernel = sweep
    state = sim.fluid.state()
    expected = {k: state[k].astype(np.float64) for k in ("velocity", "density", "prev", "source")}
    for frame in range(6):
        sim.step(DT)
        brush = sim.fluid.last_brush
        assert (brush is not None) == (frame < 4)
        expected = ref.step_ref(expected, sim.fluid.params, brush)
        state = sim.fluid.state()
        for key in ("velocity", "density", "prev"):
            scale = max(np.abs(expected[key]).max(), 1e-3)
            actual = state[key].astype(np.float64)
            assert np.allclose(actual, expected[key], rtol=0, atol=1e-5 * scale), first_mismatch(
                actual, expected[key], 0, 1e-5 * scale
            )
    assert expected["density"].max() > 0.01


# }}}

# {{{ the tessellation formulas in numpy


def test_tess_factors_match_the_per_patch_reference_and_the_chapter_page_ranges():
    view, proj, eye = scene_camera(16 / 9)
    corners = plane_corners()
    for edge_length in (2.0, 15.0):
        got = tess_factors(corners, eye, proj @ view, 1080, edge_length, 0.5)
        np.testing.assert_allclose(got, factors_ref(corners, eye, proj @ view, 1080, edge_length, 0.5), rtol=1e-12)
    vertices, triangles = plane_mesh()
    ij = np.stack([np.arange(121) % 11, np.arange(121) // 11], -1)
    quad_edges = []  # factors of the edges along the grid (not the diagonals)
    factors2 = tess_factors(corners, eye, proj @ view, 1080, 2.0, 0.5)
    factors15 = tess_factors(corners, eye, proj @ view, 1080, 15.0, 0.5)
    for t, tri in enumerate(triangles):
        for k in range(3):
            a, b = tri[(k + 1) % 3], tri[(k + 2) % 3]
            if (ij[a] == ij[b]).any():
                quad_edges.append((factors2[t, k], factors15[t, k]))
    q = np.array(quad_edges)
    # docs/chapters/17-tessellation.md, the paragraph on tess_factors:
    # EdgeLength 2 -> 41.5..105 (about half clamp to 64); EdgeLength 15 -> 5.5..14.0
    assert q[:, 0].min() == pytest.approx(41.5, abs=0.05) and q[:, 0].max() == pytest.approx(105.0, abs=0.05)
    assert 0.4 < (q[:, 0] >= 64).mean() < 0.6
    assert q[:, 1].min() == pytest.approx(5.5, abs=0.05) and q[:, 1].max() == pytest.approx(14.0, abs=0.05)


def test_fractional_odd_triangle_counts():
    counts = {1: 1, 2: 13, 2.5: 13, 3: 13, 4: 37, 5: 37, 8: 121, 64: 5953, 0: 0}  # measured on llvmpipe
    assert {f: fractional_odd_triangles(f) for f in counts} == counts


def test_displace_plane_grid_matches_reference(seed):
    rng = np.random.default_rng(seed)
    density = rng.uniform(0, 1, (20, 24)).astype(np.float32)
    vertices, triangles, normal = displace_plane_grid(density, 2, 0.7)
    model = plane_model()
    n = 21
    assert vertices.shape == (n * n, 3) and triangles.shape == (2 * 20 * 20, 3) and triangles.max() == n * n - 1
    for k in rng.integers(0, n * n, 50):
        j, i = divmod(int(k), n)
        x, z = 5.0 - i / 2.0, 5.0 - j / 2.0  # uv = ((5 - x)/10, (5 - z)/10) = (i, j) / 20
        d = bilinear_clamp_ref(density, i / 20, j / 20) * 0.7
        expected = model[:3, :3] @ np.array([x, d, z]) + model[:3, 3]
        np.testing.assert_allclose(vertices[k], expected, atol=1e-6)
    flat, _, _ = displace_plane_grid(np.zeros((4, 4), np.float32), 2, 0.7)
    raised, _, _ = displace_plane_grid(np.ones((4, 4), np.float32), 2, 0.7, negative=True)
    np.testing.assert_allclose(raised - flat, np.tile(-0.7 * normal, (n * n, 1)), atol=1e-6)


# }}}

# {{{ the GPU tessellation (EGL, llvmpipe)


class Capture:
    """The view's program rebuilt with -D CAPTURE: the TCS writes its factors, the TES (tess coord, primitive,
    world position, d) per vertex, into shader storage buffers."""

    def __init__(self, gl, view, capacity: int = 200000):
        from ugpcl.viewer.gl import load_program

        self.gl, self.view, self.capacity = gl, view, capacity
        view.program = load_program(gl, "tessellation", defines={"CAPTURE": 1})
        view.vao = gl.vertex_array(
            view.program,
            [(view.vbo, "3f 3f 4f 2f", "in_position", "in_normal", "in_tangent", "in_uv")],
            index_buffer=view.ibo,
        )
        self.factors = gl.buffer(reserve=200 * 16)
        self.points = gl.buffer(reserve=16 + capacity * 32)

    def render(self, size, camera):
        from ugpcl.viewer.offscreen import frame

        self.factors.write(np.zeros(200 * 4, np.float32).tobytes())
        self.points.write(np.array([0, self.capacity, 0, 0], np.uint32).tobytes())
        self.factors.bind_to_storage_buffer(0)
        self.points.bind_to_storage_buffer(1)
        pixels = frame(size).render(self.view, camera)
        factors = np.frombuffer(self.factors.read(), np.float32).reshape(200, 4)
        raw = self.points.read()
        count = int(np.frombuffer(raw[:4], np.uint32)[0])
        assert count <= self.capacity, "capture buffer too small"
        points = np.frombuffer(raw[16:], np.float32).reshape(-1, 2, 4)[:count]
        return pixels, factors, points


def setup_view(runtime, gl, density=None, size=(160, 90), **overrides):
    from ugpcl.viewer.views import create_view

    scene = get("tessellation")
    overrides.setdefault("edge_length", 15.0)
    sim = make(runtime, **overrides)
    if density is not None:
        sim.fluid.set_fields(density=density)
    view = create_view(scene, gl, sim)
    camera = view.make_camera()
    camera.aspect = size[0] / size[1]
    view.upload()
    return sim, view, camera


@pytest.mark.gl
def test_uniform_levels_give_the_fractional_odd_primitive_counts(runtime, gl):
    from ugpcl.viewer.offscreen import frame

    _, view, camera = setup_view(runtime, gl, size=(32, 18))
    levels = ((1.0, 1), (2.0, 13), (2.5, 13), (3.0, 13), (4.0, 37), (5.0, 37), (8.0, 121), (64.0, 5953), (0.0, 0))
    for level, per_patch in levels:
        view.forced_level = level
        frame((32, 18)).render(view, camera)
        assert view.primitives == 200 * per_patch, f"level {level}"


@pytest.mark.gl
def test_tcs_factors_captured_from_the_gpu_match_numpy(runtime, gl):
    sim, view, camera = setup_view(runtime, gl, size=(192, 108), edge_length=2.0)
    capture = Capture(gl, view)
    _, factors, _ = capture.render((192, 108), camera)
    v, p, eye = scene_camera(192 / 108)
    expected = factors_ref(plane_corners(), eye, p @ v, 108, 2.0, sim.params.displacement)
    assert np.allclose(factors, expected, rtol=1e-5, atol=1e-5), first_mismatch(factors, expected, 1e-5, 1e-5)


@pytest.mark.gl
def test_a_camera_looking_away_culls_every_patch(runtime, gl):
    from ugpcl.viewer.camera import OrbitCamera
    from ugpcl.viewer.offscreen import frame

    _, view, _ = setup_view(runtime, gl)
    away = OrbitCamera(target=(0.0, 0.0, -20.0), distance=10.0, yaw=180.0)  # at (0, 0, -10), looking along -z
    away.aspect = 16 / 9
    assert np.allclose(away.eye(), [0, 0, -10])
    frame((160, 90)).render(view, away)
    assert view.primitives == 0


@pytest.mark.gl
def test_tcs_culls_exactly_the_patches_numpy_culls_for_a_camera_seeing_part_of_the_plane(runtime, gl):
    """The TCS factors against numpy (the chapter page's "Checks") with the frustum cull active on some patches only:
    the camera moved right and closer, so about a third of the patches lie beyond its left plane by more than the slack.
    Captured factors (0 = culled) must match numpy's per patch."""
    from ugpcl.viewer.camera import OrbitCamera

    size = (192, 108)
    sim, view, _ = setup_view(runtime, gl, size=size, edge_length=2.0)
    camera = OrbitCamera(target=(3.0, 0.0, 0.0), distance=6.0)
    camera.aspect = size[0] / size[1]
    view_proj, eye = camera.projection() @ camera.view(), camera.eye()
    slack = 1.5 * sim.params.displacement
    planes = frustum_side_planes(view_proj)
    distances = np.einsum("tkc,pc->tkp", plane_corners(), planes[:, :3]) + planes[:, 3]
    deciding = np.abs(distances.max(axis=1) + slack)  # how far each patch's cull decision is from flipping
    assert deciding.min() > 1e-3, "a patch sits on the cull threshold: float rounding may decide it"
    capture = Capture(gl, view)
    _, factors, _ = capture.render(size, camera)
    expected = factors_ref(plane_corners(), eye, view_proj, size[1], 2.0, sim.params.displacement)
    culled = expected[:, 3] == 0
    assert 40 < culled.sum() < 100, culled.sum()
    np.testing.assert_array_equal(factors[:, 3] == 0, culled)
    assert np.allclose(factors, expected, rtol=1e-5, atol=1e-5), first_mismatch(factors, expected, 1e-5, 1e-5)


_depth_frames: dict = {}


def render_depth(gl, view, camera, size) -> np.ndarray:
    """The view drawn into a single-sample frame with a readable depth texture: window depth (H, W), row 0 at the
    bottom, 1.0 where nothing was drawn. Frames are kept (see viewer.offscreen.frame)."""
    if size not in _depth_frames:
        _depth_frames[size] = gl.framebuffer(
            color_attachments=[gl.renderbuffer(size, 4)], depth_attachment=gl.depth_texture(size)
        )
    fbo = _depth_frames[size]
    fbo.use()
    gl.viewport = (0, 0, *size)
    fbo.clear(*view.background, 1.0, depth=1.0)
    view.draw(camera)
    return np.frombuffer(fbo.depth_attachment.read(), np.float32).reshape(size[1], size[0]).copy()


@pytest.mark.gl
def test_depth_of_the_flat_tessellated_plane_is_the_plain_planes_and_a_blob_raises_only_its_footprint(runtime, gl):
    """The chapter page's image check ("Checks") on the depth buffers: with zero density the tessellated plane (edge
    length 2: thousands of triangles) has the depth of the untessellated one within 1e-4 and covers the same pixels;
    with a blob the depth changes (by more than 1e-4) somewhere, and only inside the blob's projected footprint."""
    size = (160, 90)
    sim, view, camera = setup_view(runtime, gl, size=size, edge_length=2.0)
    tessellated = render_depth(gl, view, camera, size)
    assert view.primitives > 200 * 13, "the plane was not tessellated"
    view.forced_level = 1.0
    plain = render_depth(gl, view, camera, size)
    assert view.primitives == 200
    view.forced_level = -1.0
    covered = plain < 1.0
    assert 0.5 < covered.mean() < 0.9
    np.testing.assert_array_equal(tessellated < 1.0, covered)
    assert np.abs(tessellated - plain).max() <= 1e-4
    density = gaussian_density(32, (0.3, 0.7), sigma=0.07)
    sim.fluid.set_fields(density=density)
    view.upload()
    raised = render_depth(gl, view, camera, size)[::-1]  # row 0 at the top, as the footprint
    changed = np.abs(raised - tessellated[::-1]) > 1e-4
    assert changed.sum() > 100, "the blob did not move the surface"
    assert (raised[changed] < tessellated[::-1][changed]).all(), "the blob must come towards the camera"
    footprint = blob_footprint(density, (0.3, 0.7), 0.07, size, sim.params.displacement)
    assert not (changed & ~footprint).any(), "depth changed outside the blob's footprint"


@pytest.mark.gl
def test_tes_positions_captured_from_the_gpu_match_numpy(runtime, gl):
    density = gaussian_density(32, (0.4, 0.6), sigma=0.1)
    sim, view, camera = setup_view(runtime, gl, density=density, size=(96, 54), edge_length=2.0)
    capture = Capture(gl, view)
    _, _, points = capture.render((96, 54), camera)
    assert len(points) > 2000
    vertices, triangles = plane_mesh()
    model = plane_model()
    # a texture unit with rounded sub-texel weights (NVIDIA: d was 1.2e-4 off) misreads the density by up to its filter
    # error x the steepest texel step, once per axis; float filtering (llvmpipe) leaves float error only
    steepest = max(np.abs(np.diff(density, axis=a)).max() for a in (0, 1)) * sim.params.displacement
    tolerance = 1e-4 + 2 * linear_filter_error(gl) * float(steepest)
    rng = np.random.default_rng(1)
    for k in rng.choice(len(points), 300, replace=False):
        (b0, b1, b2, prim), (wx, wy, wz, d) = points[k]
        tri = vertices[triangles[int(prim)]].astype(np.float64)
        b = np.array([b0, b1, b2])
        position, normal, uv = b @ tri[:, :3], b @ tri[:, 3:6], b @ tri[:, 10:12]
        d_ref = bilinear_clamp_ref(density, *uv) * sim.params.displacement
        world = model @ np.append(position + normal * d_ref, 1.0)
        np.testing.assert_allclose([wx, wy, wz], world[:3], atol=tolerance)  # the chapter page's "Checks": 1e-4
        assert d == pytest.approx(d_ref, abs=tolerance)
    # zero density: every generated vertex lies on the plane
    sim.fluid.set_fields(density=np.zeros((32, 32), np.float32))
    view.upload()
    _, _, flat = capture.render((96, 54), camera)
    normal = model[:3, :3] @ [0, 1, 0]
    assert np.abs((flat[:, 1, :3] - model[:3, 3]) @ normal).max() < 1e-5


@pytest.mark.gl
def test_displacement_changes_pixels_only_where_the_density_is(runtime, gl):
    from ugpcl.viewer.offscreen import frame

    size = (160, 90)
    _, view, camera = setup_view(runtime, gl, size=size, edge_length=2.0)  # zero density
    flat_tessellated = frame(size).render(view, camera).astype(int)
    tessellated = view.primitives
    view.forced_level = 1.0
    flat_plain = frame(size).render(view, camera).astype(int)
    assert view.primitives == 200 and tessellated > 200 * 13, "the plane was not tessellated"
    # zero density: the tessellated plane looks like the plain one, up to one MSAA sample of the silhouette
    plane = foreground(flat_plain.astype(np.uint8), view.background)
    inner = plane[1:-1, 1:-1] & plane[:-2, 1:-1] & plane[2:, 1:-1] & plane[1:-1, :-2] & plane[1:-1, 2:]
    assert np.abs(flat_tessellated - flat_plain)[1:-1, 1:-1][inner].max() <= 3
    assert np.abs(flat_tessellated - flat_plain).max() <= 64  # 255 / 4 samples
    view.forced_level = -1.0
    density = gaussian_density(32, (0.3, 0.7), sigma=0.07)
    view.sim.fluid.set_fields(density=density)
    view.upload()
    raised = frame(size).render(view, camera).astype(int)
    changed = np.abs(raised - flat_tessellated).sum(-1) > 12
    assert changed.sum() > 100, "no displaced pixels"
    footprint = blob_footprint(density, (0.3, 0.7), 0.07, size, view.sim.params.displacement)
    assert not (changed & ~footprint).any(), "pixels changed outside the blob's footprint"


@pytest.mark.gl
def test_book_lighting_shows_the_fluid_through_its_shadow(runtime, gl):
    """variant=book lights the plane with its own, undisplaced normal (Unity's surface shader): a raised blob shows
    through the shadow it casts on the highlight; without the shadow pass hardly anything of it shows."""
    from ugpcl.viewer.offscreen import frame

    size = (160, 90)
    sim, view, camera = setup_view(runtime, gl, size=size, edge_length=2.0, variant="book")
    flat = frame(size).render(view, camera).astype(int)
    sim.fluid.set_fields(density=gaussian_density(32, (0.5, 0.45), sigma=0.08, peak=2.0))
    view.upload()
    shadowed = frame(size).render(view, camera).astype(int)
    sim.update(shadows=False)
    unshadowed = frame(size).render(view, camera).astype(int)
    darker = shadowed.sum(-1) < flat.sum(-1) - 24
    changed_without = np.abs(unshadowed - flat).sum(-1) > 24
    assert darker.sum() > 60, "no shadow under the blob"
    assert darker.sum() > 4 * changed_without.sum(), (darker.sum(), changed_without.sum())
    rows, cols = np.nonzero(darker)
    assert 0.3 * size[0] < cols.mean() < 0.7 * size[0], "the shadow is not near the blob (centre of the plane)"


@pytest.mark.gl
def test_the_fluid_run_shows_a_displaced_lit_plane(runtime, gl):
    """What a person sees after `ugpcl run tessellation --png`: the black specular plane on white, its centre bright,
    tessellated, and a raised ring where the circle stroke painted."""
    from ugpcl.viewer.offscreen import render

    scene = get("tessellation")
    sim = scene.create(runtime, grid=64, edge_length=15.0)
    for _ in range(90):
        sim.step()
    size = (160, 90)
    pixels = render(scene, sim, size)
    view_plane = foreground(pixels, (1.0, 1.0, 1.0))
    assert 0.5 < view_plane.mean() < 0.9, "the plane covers most of the frame, the white sky the top corners"
    assert not view_plane[0, 0] and not view_plane[0, -1] and view_plane[-5, size[0] // 2]
    grey = pixels.astype(int).sum(-1) / 3
    assert grey[view_plane].min() < 40 and grey[view_plane].max() > 100  # black with a specular highlight
    flat = scene.create(runtime, grid=64, edge_length=15.0)  # the same plane with no fluid
    difference = np.abs(render(scene, flat, size).astype(int) - pixels.astype(int)).sum(-1) > 24
    assert difference.mean() > 0.02, "the fluid does not show on the plane"


# }}}

# {{{ headless CLI, parameters, view keys


def test_cli_run_writes_the_chapter_page_arrays_png_and_mesh(tmp_path):
    out, png, mesh = tmp_path / "t.npz", tmp_path / "t.png", tmp_path / "t.ply"
    cmd = [sys.executable, "-m", "ugpcl", "run", "tessellation", "--steps", "8", "--every", "4", "--out", str(out)]
    cmd += ["--set", "grid=24", "--set", "mesh_level=2", "--set", "edge_length=20", "--png", str(png)]
    cmd += ["--png-size", "96x54", "--mesh", str(mesh)]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    assert result.returncode == 0, result.stderr
    data = np.load(out)
    shapes = {k: data[k].shape for k in data.files}
    assert shapes["density"] == (24, 24) and shapes["velocity"] == (24, 24, 2)
    assert shapes["density_history"] == (3, 24, 24) and shapes["velocity_history"] == (3, 24, 24, 2)
    assert shapes["stroke_uv"] == shapes["stroke_vel"] == (8, 2)
    assert shapes["mesh_vertices"] == (21 * 21, 3) and shapes["mesh_triangles"] == (800, 3)
    assert shapes["tess_factors"] == (200, 4) and data["tess_factors"][:, :3].min() >= 1.0
    np.testing.assert_allclose(
        data["stroke_uv"][2],
        [0.5 + 0.25 * np.cos(2 * np.pi * 2 / 120), 0.5 + 0.25 * np.sin(2 * np.pi * 2 / 120)],
        atol=1e-6,
    )
    assert png.stat().st_size > 0 and mesh.read_bytes().startswith(b"ply")


# ranges: tests/test_params.py checks them for every field of every scene
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"variant": "unity"}, "variant must be one of fixed\\|book"),
        ({"lighting": "flat"}, "lighting must be one of auto\\|height\\|mesh"),
        ({"screen_size": (1920,)}, "screen_size must be 2 numbers"),
    ],
)
def test_bad_parameters_name_the_field_and_range(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


@pytest.mark.gl
def test_view_keys_and_painting_under_the_cursor(runtime, gl):
    sim, view, camera = setup_view(runtime, gl)
    # the plane's centre (uv 0.5, 0.5) projected to the window
    v, p, _ = scene_camera(camera.aspect)
    clip = p @ v @ plane_model() @ np.array([0.0, 0.0, 0.0, 1.0])
    u, w = (clip[:2] / clip[3] + 1) / 2
    assert view.plane_uv(camera, u, w) == pytest.approx([0.5, 0.5], abs=1e-9)
    assert view.plane_uv(camera, 0.5, 0.99) is None  # the sky
    view.on_drag(camera, u, w, 0.0, 0.0)
    view.on_drag(camera, u + 0.01, w, 0.01, 0.0)
    u_tex, v_tex, du, dv = sim.fluid.pending_brush
    assert u_tex > 0.5 and du > 0 and abs(dv) < 1e-6  # moving right on screen moves +u on the plane
    sim.step()
    view.on_release(camera)
    assert sim.density().max() > 0
    view.toggle_wireframe()
    assert view.wireframe
    view.more_displacement()
    assert sim.params.displacement == pytest.approx(0.55)
    view.shorter_edges()
    assert sim.params.edge_length == 14.0
    view.toggle_variant()
    assert sim.params.variant == "book" and sim.fluid.params.solver == "vol4"
    view.next_lighting()
    assert sim.params.lighting == "height"
    view.toggle_negative()
    assert sim.params.negative
    view.more_viscous()
    assert sim.fluid.params.visc == 200.0
    view.toggle_density()
    view.toggle_levels()
    view.upload()
    from ugpcl.viewer.offscreen import frame

    frame((160, 90)).render(view, camera)
    view.toggle_freeze()
    assert view.frozen is not None
    keys = {k.key for k in view.keys}
    assert keys >= {"w", "+", "-", "[", "]", "v", "l", "up", "down", "left", "right", "d", "p", "k"}
    view.toggle_shadows()
    assert not sim.params.shadows


# }}}


@pytest.mark.oclgrind
def test_fluid_steps_on_oclgrind(oclgrind):
    for variant in ("book", "fixed"):
        sim = Simulation(oclgrind, Params(grid=9, variant=variant, local_size=(4, 4), stroke="circle"))
        sim.step()
        assert np.isfinite(sim.density()).all() and sim.density().max() > 0
