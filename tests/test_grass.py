"""Geometry shaders: pyramid and grass (vol.1 ch.6; docs/chapters/06-grass.md): layout, GrassExpand/PyramidExpand
against a float64 numpy port of the book's geom() functions, golden blades, invariants, CLI, the GLSL shaders
themselves (transform feedback, primitive queries, pixels), Oclgrind."""

from __future__ import annotations

import json
from types import SimpleNamespace

import moderngl
import numpy as np
import pytest
from helpers import first_mismatch, foreground, linear_filter_error
from PIL import Image

from ugpcl.buffers import device_sizeof
from ugpcl.cli import main
from ugpcl.registry import get
from ugpcl.scenes.grass import GRASS_PARAMS_DTYPE, Params, PyramidParams, PyramidSimulation, Simulation

# {{{ numpy float64 reference, written from the book's listings (Grass.shader, SimpleGeometryShader)


def reference_plane(resolution: int):
    """The chapter page's Plane: 10x10 units in XZ, (resolution+1)^2 vertices, cell (i, j) -> triangles (a, c, b),
    (b, c, d)."""
    n = resolution + 1
    pos = np.array([[i * 10.0 / resolution - 5, 0.0, j * 10.0 / resolution - 5] for j in range(n) for i in range(n)])
    uv = np.array([[i / resolution, j / resolution] for j in range(n) for i in range(n)])
    tri = []
    for j in range(resolution):
        for i in range(resolution):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            tri += [(a, c, b), (b, c, d)]
    return pos, uv, np.array(tri)


def reference_sample(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """tex2Dlod with bilinear filtering and repeat wrapping (texel centres at (k + 1/2) / size)."""
    h, w = image.shape
    out = []
    for u, v in uv:
        x, y = u * w - 0.5, v * h - 0.5
        x0, y0 = int(np.floor(x)), int(np.floor(y))
        fx, fy = x - x0, y - y0
        texel = lambda i, j: float(image[j % h, i % w])  # noqa: E731
        out.append(
            (texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx) * (1 - fy)
            + (texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx) * fy
        )
    return np.array(out)


def lerp(a, b, t):
    return np.asarray(a, float) + (np.asarray(b, float) - np.asarray(a, float)) * t


def grass_geom(p, normals, hei, rot, wind, prm, time: float):
    """Grass.shader geom() for one triangle (object space): p, normals (3, 3); hei/rot/wind (3,); returns (7, 3)
    positions and (7, 4) colours. Only the NaN guard at rot == 0.5 is ours (sign -1 there)."""
    p0, p1, p2 = np.asarray(p, float)
    height, r, w = np.mean(hei), np.mean(rot), np.mean(wind)
    center = (p0 + p1 + p2) / 3.0
    normal = np.mean(normals, axis=0)
    bottom_height = height * prm.height * prm.bottom_height
    middle_height = height * prm.height * prm.middle_height
    top_height = height * prm.height * prm.top_height
    bottom_width = prm.width * prm.bottom_width
    middle_width = prm.width * prm.middle_width
    top_width = prm.width * prm.top_width
    r = r - 0.5
    edge = (p2 - p0) * (r if r != 0 else -1.0)
    direction = edge / np.linalg.norm(edge)
    o = np.zeros((7, 3))
    o[0] = center - direction * bottom_width
    o[1] = center + direction * bottom_width
    o[2] = center - direction * middle_width + normal * bottom_height
    o[3] = center + direction * middle_width + normal * bottom_height
    o[4] = o[3] - direction * top_width + normal * middle_height
    o[5] = o[3] + direction * top_width + normal * middle_height
    o[6] = o[5] + direction * top_width + normal * top_height
    bend = np.array([1.0, 0.0, 0.0]) * np.sin(time * prm.wind_time_scale)  # dir = (1, 0, 0) * sin(_Time).x
    o[2] += bend * prm.wind_power * w * prm.bottom_bend
    o[3] += bend * prm.wind_power * w * prm.bottom_bend
    o[4] += bend * prm.wind_power * w * prm.middle_bend
    o[5] += bend * prm.wind_power * w * prm.middle_bend
    o[6] += bend * prm.wind_power * w * prm.top_bend
    b, t = prm.bottom_color, prm.top_color
    colors = np.array([b, b, lerp(b, t, 0.33333), lerp(b, t, 0.33333), lerp(b, t, 0.66666), lerp(b, t, 0.66666), t])
    return o, colors


def apply(model, points):
    model = np.asarray(model, float)
    return points @ model[:3, :3].T + model[:3, 3]


def pyramid_geom(p, height: float):
    """SimpleGeometryShader geom(): (12, 3) vertices: base, then the three sides with the apex last."""
    p0, p1, p2 = np.asarray(p, float)
    c = np.array([0.0, 0.0, -height]) + (p0 + p1 + p2) * 0.33333
    return np.array([p0, p1, p2, p0, p1, c, p1, p2, c, p2, p0, c])


# }}}

GOLDEN_TRIANGLE = {
    "pos": np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0]], np.float32),
    "nrm": np.array([[0, 1, 0]] * 3, np.float32),
    "uv": np.zeros((3, 2), np.float32),
    "tri": np.array([[0, 1, 2]], np.uint32),
}


def constant_maps(height: float, rot: float, wind: float) -> dict[str, np.ndarray]:
    return {"height": np.full((1, 1), height), "rot": np.full((1, 1), rot), "wind": np.full((1, 1), wind)}


def golden(runtime, rot: float, wind: float, **overrides) -> tuple[np.ndarray, np.ndarray]:
    sim = Simulation(runtime, Params(planes=(1, 1), plane_resolution=1, **overrides), 0)
    sim.set_ground(GOLDEN_TRIANGLE, np.identity(4), constant_maps(1.0, rot, wind))
    state = sim.state()
    return state["blade_pos"][0], state["blade_col"][0]


# {{{ layout


def test_grass_params_dtype_matches_the_device_struct(runtime):
    assert GRASS_PARAMS_DTYPE.itemsize == 96
    assert GRASS_PARAMS_DTYPE.fields["top_color"][1] == 64  # float4s 16-byte aligned, no hidden padding
    assert device_sizeof(runtime, "GrassParams", "grass.h") == GRASS_PARAMS_DTYPE.itemsize


# }}}

# {{{ kernels vs reference


@pytest.mark.parametrize("backend", ["opencl", "numpy"])
def test_grass_expand_matches_reference(runtime, seed, backend):
    params = Params(planes=(3, 3), plane_resolution=4, start_time=3.7, wind_time_scale=1.0, backend=backend)
    sim = Simulation(runtime, params, seed)
    state = sim.state()
    pos, uv, tri = reference_plane(4)
    samples = [reference_sample(state[f"noise_{name}"], uv) for name in ("height", "rot", "wind")]
    expected_pos, expected_col, expected_means = [], [], []
    for model in state["plane_model"]:
        for t in tri:
            v, c = grass_geom(pos[t], np.tile([0.0, 1.0, 0.0], (3, 1)), *(s[t] for s in samples), params, 3.7)
            expected_pos.append(apply(model, v))
            expected_col.append(c)
            expected_means.append([s[t].mean() for s in samples])
    expected_pos, expected_col = np.array(expected_pos), np.array(expected_col)
    assert state["blade_pos"].shape == (9 * 32, 7, 3) and state["blade_pos"].dtype == np.float32
    # float32 world coordinates up to |55| against float64: a few ulp (4e-6 each); 1e-5 of the blade height scale
    atol = 1e-5 * params.height
    actual = state["blade_pos"].reshape(-1, 3)
    assert np.allclose(actual, expected_pos.reshape(-1, 3), atol=atol, rtol=0), first_mismatch(
        actual, expected_pos.reshape(-1, 3), 0, atol
    )
    np.testing.assert_allclose(state["blade_col"], expected_col, atol=1e-6, rtol=0)
    means = np.column_stack([state["blade_h"], state["blade_rot"], state["blade_wind"]])
    np.testing.assert_allclose(means, expected_means, atol=1e-6, rtol=0)  # bilinear lookups of maps in [0, 1]


def tilted_mesh(seed: int) -> tuple[dict, np.ndarray, dict]:
    """A random mesh that is no plane: scattered vertices, per-vertex normals of varying length and direction (the
    blade grows along their unnormalised mean), UVs beyond [0, 1] (repeat wrapping), small random maps, and three
    general affine models. The plane field only ever has normals (0, 1, 0) and identical triangles."""
    rng = np.random.default_rng(seed)
    n_vertices = 12
    mesh = {
        "pos": rng.uniform(-2, 2, (n_vertices, 3)).astype(np.float32),
        "nrm": (rng.normal(size=(n_vertices, 3)) * [0.4, 1.0, 0.4] + [0.0, 1.0, 0.0]).astype(np.float32),
        "uv": rng.uniform(-0.5, 1.5, (n_vertices, 2)).astype(np.float32),
        "tri": np.array([rng.choice(n_vertices, 3, replace=False) for _ in range(10)], np.uint32),
    }
    models = np.tile(np.identity(4), (3, 1, 1))
    models[:, :3, :3] = rng.normal(size=(3, 3, 3))
    models[:, :3, 3] = rng.normal(size=(3, 3)) * 5
    maps = {name: rng.uniform(0, 1, (5, 7)) for name in ("height", "rot", "wind")}
    return mesh, models, maps


def tilted_reference(mesh, models, maps, params, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """grass_geom on every triangle of every model: world positions (B, 7, 3), colours (B, 7, 4), mean rotations."""
    samples = [reference_sample(maps[name], mesh["uv"].astype(np.float64)) for name in ("height", "rot", "wind")]
    pos, col, rot = [], [], []
    for model in models:
        for t in mesh["tri"]:
            v, c = grass_geom(mesh["pos"][t], mesh["nrm"][t], *(s[t] for s in samples), params, time)
            pos.append(apply(model, v))
            col.append(c)
            rot.append(samples[1][t].mean())
    return np.array(pos), np.array(col), np.array(rot)


@pytest.mark.parametrize("backend", ["opencl", "numpy"])
def test_grass_expand_on_a_tilted_random_mesh(runtime, seed, backend):
    """The blade grows along the mean of the three vertex normals (not y), its side follows p2 - p0 of each
    triangle, and the model is a general affine map: a kernel that assumed the flat plane would fail here."""
    mesh, models, maps = tilted_mesh(seed)
    params = Params(planes=(1, 1), plane_resolution=1, start_time=3.7, wind_time_scale=1.0, backend=backend)
    sim = Simulation(runtime, params, seed)
    sim.set_ground(mesh, models, maps)
    state = sim.state()
    expected_pos, expected_col, expected_rot = tilted_reference(mesh, models, maps, params, 3.7)
    assert np.abs(expected_rot - 0.5).min() > 1e-4, "a mean rotation this close to 0.5 could round either way"
    assert 0 < (expected_rot > 0.5).sum() < len(expected_rot), "both sides should occur"
    assert state["blade_pos"].shape == (3 * 10, 7, 3)
    # the blades really lean: their normal offsets are far from the plane field's +y
    lean = expected_pos[:, 6] - expected_pos[:, 0]
    assert (np.abs(lean[:, [0, 2]]).max(axis=1) > 1.0).all()
    atol = 1e-5 * params.height  # float32 world coordinates up to ~|100| against float64
    actual = state["blade_pos"].reshape(-1, 3)
    assert np.allclose(actual, expected_pos.reshape(-1, 3), atol=atol, rtol=0), first_mismatch(
        actual, expected_pos.reshape(-1, 3), 0, atol
    )
    np.testing.assert_allclose(state["blade_col"], expected_col, atol=1e-6, rtol=0)
    np.testing.assert_array_equal(state["blade_rot"] > 0.5, expected_rot > 0.5)


def test_golden_blade(runtime):
    pos, col = golden(runtime, rot=0.75, wind=0.0)
    third = 1 / 3
    expected = [
        [0.08333, 0, third],
        [0.58333, 0, third],
        [0.13333, 7.5, third],
        [0.53333, 7.5, third],
        [0.43333, 17.5, third],
        [0.63333, 17.5, third],
        [0.73333, 30, third],
    ]
    np.testing.assert_allclose(pos, expected, atol=1e-5)  # the expected values are rounded to five digits
    colors = [(0, 0.20766, 0.33088, 1), (0, 0.47177, 0.31944, 1), (0, 0.73588, 0.30800, 1), (0, 1, 0.29655, 1)]
    np.testing.assert_allclose(col, [colors[k // 2] for k in range(7)], atol=1e-5)
    mirrored, _ = golden(runtime, rot=0.25, wind=0.0)  # the rotation map only flips the side
    np.testing.assert_allclose(mirrored[:, 0] - third, -(pos[:, 0] - third), atol=1e-6)
    np.testing.assert_allclose(mirrored[:, 1:], pos[:, 1:], atol=1e-6)


def test_wind_moves_the_joints_along_object_x(runtime):
    calm, _ = golden(runtime, rot=0.75, wind=0.0)
    # sin(time * 1/20) = 1 at time = 10 pi: offsets WindPower * wind * (0, 0, bottom, bottom, middle, middle, top)
    windy, _ = golden(runtime, rot=0.75, wind=1.0, start_time=10 * np.pi)
    np.testing.assert_allclose(windy[:, 0] - calm[:, 0], [0, 0, 0.75, 0.75, 1.5, 1.5, 2.25], atol=1e-5)
    np.testing.assert_array_equal(windy[:2], calm[:2])  # the root never moves
    np.testing.assert_array_equal(windy[:, 1:], calm[:, 1:])


def test_rotation_exactly_one_half_gives_a_fixed_side_not_nan(runtime):
    pos, _ = golden(runtime, rot=0.5, wind=0.0)
    assert np.isfinite(pos).all()
    reference, _ = golden(runtime, rot=0.25, wind=0.0)
    np.testing.assert_allclose(pos, reference, atol=1e-6)  # sign -1, as rot < 0.5


@pytest.mark.parametrize("backend", ["opencl", "numpy"])
def test_pyramid_expand_matches_reference(runtime, seed, backend):
    rng = np.random.default_rng(seed)
    mesh = {"pos": rng.uniform(-1, 1, (9, 3)).astype(np.float32), "tri": rng.permutation(9).reshape(3, 3)}
    model = np.identity(4)
    model[:3, :3] = rng.normal(size=(3, 3))
    model[:3, 3] = rng.normal(size=3)
    sim = PyramidSimulation(runtime, PyramidParams(height=2.5, backend=backend), seed)
    sim.set_ground(mesh, model)
    state = sim.state()
    expected = np.array([apply(model, pyramid_geom(mesh["pos"][t], 2.5)) for t in mesh["tri"]])
    np.testing.assert_allclose(state["pyr_pos"], expected, atol=1e-5)
    top, bottom = sim.params.top_color, sim.params.bottom_color
    colors = np.array([top if k in (5, 8, 11) else bottom for k in range(12)])
    np.testing.assert_array_equal(state["pyr_col"], np.broadcast_to(colors, (3, 12, 4)))


def test_pyramids_on_the_quad(runtime):
    sim = PyramidSimulation(runtime, PyramidParams(height=1.5), 0)
    quad = sim.ground
    sim.set_ground(quad, np.identity(4))
    pos = sim.state()["pyr_pos"].astype(np.float64)
    assert pos.shape == (2, 12, 3)  # 24 vertices: 4 triangles per input triangle
    for t, triangle in enumerate(quad["tri"]):
        np.testing.assert_array_equal(pos[t, :3], quad["pos"][triangle])  # the base is the input triangle
        centroid = quad["pos"][triangle].astype(np.float64).mean(axis=0)
        np.testing.assert_allclose(pos[t, 5], centroid + [0, 0, -1.5], atol=1e-5)
        base, apex = pos[t, :3], pos[t, 5]
        volume = abs(np.dot(np.cross(base[1] - base[0], base[2] - base[0]), apex - base[0])) / 6
        area = np.linalg.norm(np.cross(base[1] - base[0], base[2] - base[0])) / 2
        assert volume == pytest.approx(area * 1.5 / 3, rel=1e-5)
    np.testing.assert_allclose(pos[:, 5], [[1 / 6, -1 / 6, -1.5], [-1 / 6, 1 / 6, -1.5]], atol=1e-5)


# }}}

# {{{ invariants


def test_field_invariants(runtime, seed):
    sim = Simulation(runtime, Params(start_time=20.0), seed)  # the book's 10x10 field, some sway
    state, p = sim.state(), sim.params
    pos = state["blade_pos"].astype(np.float64)
    assert pos.shape == (200 * 100, 7, 3) and state["blade_tris"].shape == (5 * 200 * 100, 3)
    assert np.isfinite(pos).all() and np.isfinite(state["blade_col"]).all()
    np.testing.assert_array_equal(pos[:, :2, 1], 0.0)  # the roots lie on the planes (y = 0)
    assert pos[:, :, 1].max() <= 1.2 * p.height * state["blade_h"].max() + 1e-4
    for (a, b), half in (((0, 1), p.bottom_width), ((2, 3), p.middle_width), ((4, 5), p.top_width)):
        length = np.linalg.norm(pos[:, b] - pos[:, a], axis=1)  # wind moves both ends of a section alike
        np.testing.assert_allclose(length, 2 * p.width * half, atol=2e-5)
    # the field covers PlaneDeployer's [-55, 45]^2
    assert pos[:, :2, 0].min() > -55 and pos[:, :2, 0].max() < 45 and pos[:, :2, 2].min() > -55


def test_blade_sides_follow_the_rotation_map(runtime, seed):
    sim = Simulation(runtime, Params(planes=(4, 4)), seed)
    state = sim.state()
    pos, models = state["blade_pos"].astype(np.float64), state["plane_model"].astype(np.float64)
    _, _, tri = reference_plane(10)
    plane_pos = reference_plane(10)[0]
    edge = plane_pos[tri[:, 2]] - plane_pos[tri[:, 0]]  # object-space p2 - p0
    world_edge = np.concatenate([edge @ m[:3, :3].T for m in models])
    direction = pos[:, 1] - pos[:, 0]
    plus = np.einsum("ij,ij->i", direction, world_edge) > 0
    rot = state["blade_rot"].astype(np.float64)
    assert np.abs(rot - 0.5).min() > 1e-6, "a mean rotation this close to 0.5 could round either way"
    assert plus.sum() == (rot > 0.5).sum()
    np.testing.assert_array_equal(plus, rot > 0.5)


def test_noise_maps_have_the_originals_statistics(runtime):
    sim = Simulation(runtime, Params(planes=(1, 1)), 3)
    for name, (shape, mean, std) in {
        "height": ((384, 512), 0.453, 0.104),
        "rot": ((512, 512), 0.371, 0.153),
        "wind": ((384, 512), 0.684, 0.277),
    }.items():
        image = sim.state()[f"noise_{name}"]
        assert image.shape == shape and image.dtype == np.float32
        assert 0 <= image.min() and image.max() <= 1
        assert abs(image.mean() - mean) < 0.01 and abs(image.std() - std) < 0.01, name
        assert np.abs(np.diff(image, axis=1)).mean() < 0.05, f"{name} is white noise, not clouds"
    assert 0.15 < (sim.maps["rot"] > 0.5).mean() < 0.3  # original: 21.6 % of the texels


def test_same_seed_is_bitwise_identical(runtime):
    a = Simulation(runtime, Params(planes=(3, 3)), 7)
    b = Simulation(runtime, Params(planes=(3, 3)), 7)
    for _ in range(3):
        a.step()
        b.step()
    for key, value in a.state().items():
        np.testing.assert_array_equal(value, b.state()[key], err_msg=key)
    c = Simulation(runtime, Params(planes=(3, 3)), 8).state()
    assert not np.array_equal(a.state()["noise_height"], c["noise_height"])
    assert not np.array_equal(a.state()["plane_model"], c["plane_model"])


def test_steps_advance_the_wind(runtime):
    sim = Simulation(runtime, Params(planes=(1, 1), wind_time_scale=1.0), 0)
    before = sim.state()["blade_pos"].copy()
    sim.step(0.5)
    after = sim.state()
    assert float(after["shader_time"]) == pytest.approx(0.5)
    moved = np.abs(after["blade_pos"] - before)
    assert moved[:, :2].max() == 0 and moved[:, 2:, 0].max() > 0.1 and moved[:, :, 1:].max() == 0


def test_live_parameter_changes_show_without_a_step(runtime):
    sim = Simulation(runtime, Params(planes=(1, 1)), 0)
    tall = sim.state()["blade_pos"][:, 6, 1].max()
    sim.update(height=50.0)
    assert sim.state()["blade_pos"][:, 6, 1].max() == pytest.approx(2 * tall, rel=1e-5)
    sim.update(plane_resolution=5)  # not live: a reset with a coarser mesh
    assert sim.blades == 50 and sim.state()["blade_pos"].shape == (50, 7, 3)


def test_extreme_parameters_stay_finite(runtime):
    extreme = {name: 100.0 for name in ("bottom_height", "middle_height", "top_height", "top_width", "top_bend")}
    params = Params(planes=(2, 2), height=1e4, width=1e3, wind_power=-1e3, start_time=31.4, **extreme)
    assert np.isfinite(Simulation(runtime, params, 0).state()["blade_pos"]).all()


# out-of-range values (every field of every scene) and the blade limit: tests/test_params.py
@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"wind_power": float("nan")}, "wind_power must be a finite number"),
        ({"backend": "cuda"}, "backend must be one of opencl\\|numpy"),
    ],
)
def test_bad_parameters_name_the_field(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_bad_dt_is_refused(runtime):
    sim = Simulation(runtime, Params(planes=(1, 1)), 0)
    for dt in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="dt must be in"):
            sim.step(dt)


# }}}

# {{{ headless CLI


def project(camera, points: np.ndarray, size) -> tuple[np.ndarray, np.ndarray]:
    """Pixel rows and columns (row 0 at the top) of world points seen by ``camera``."""
    clip = np.column_stack([points, np.ones(len(points))]) @ (camera.projection() @ camera.view()).T
    ndc = clip[:, :2] / clip[:, 3:]
    cols = np.floor((ndc[:, 0] + 1) / 2 * size[0]).astype(int)
    rows = np.floor((1 - ndc[:, 1]) / 2 * size[1]).astype(int)
    return rows, cols


@pytest.mark.gl  # --png renders through EGL
def test_run_grass_writes_the_chapter_page_arrays_and_a_lawn(capsys, tmp_path):
    out, png = tmp_path / "g.npz", tmp_path / "g.png"
    argv = ["run", "grass", "--steps", "2", "--seed", "4", "--set", "planes=2,3", "--out", str(out)]
    assert main([*argv, "--png", str(png), "--png-size", "96x72", "--mesh", str(tmp_path / "g.ply")]) == 0
    text = capsys.readouterr().out
    assert "blades: 1200" in text
    data = np.load(out)
    b = 6 * 200
    shapes = {
        "blade_pos": (b, 7, 3),
        "blade_col": (b, 7, 4),
        "blade_tris": (5 * b, 3),
        "blade_h": (b,),
        "blade_rot": (b,),
        "blade_wind": (b,),
        "plane_model": (6, 4, 4),
        "noise_height": (384, 512),
        "noise_rot": (512, 512),
        "noise_wind": (384, 512),
    }
    for key, shape in shapes.items():
        assert data[key].shape == shape, key
    assert data["blade_tris"].dtype == np.uint32 and data["blade_tris"].max() == 7 * b - 1
    np.testing.assert_array_equal(data["blade_tris"][:5], [[0, 1, 2], [2, 1, 3], [2, 3, 4], [4, 3, 5], [4, 5, 6]])
    assert json.loads(str(data["params"]))["planes"] == [2, 3]
    pixels = np.asarray(Image.open(png).convert("RGB"))
    mask = foreground(pixels, (0, 0, 0))
    # the book's camera (0, 30, -85), FOV 60: the 2x3 planes are a patch of lawn in the middle of the frame
    from ugpcl.viewer.offscreen import PICTURE_ASPECT
    from ugpcl.viewer.views.grass import book_grass_camera

    camera = book_grass_camera()
    camera.aspect, camera.framed_aspect = 96 / 72, PICTURE_ASPECT  # as --png frames it
    rows, cols = project(camera, data["blade_pos"].reshape(-1, 3), (96, 72))
    inside = np.zeros_like(mask)
    inside[max(rows.min() - 1, 0) : rows.max() + 2, max(cols.min() - 1, 0) : cols.max() + 2] = True
    assert mask.sum() > 0.5 * inside.sum(), "the lawn's box is mostly empty"
    assert not (mask & ~inside).any(), "pixels drawn outside the blades' box"
    assert (tmp_path / "g.ply").stat().st_size > 0


def test_run_pyramid_with_the_numpy_backend(capsys, tmp_path):
    out = tmp_path / "p.npz"
    assert main(["run", "grass_pyramid", "--steps", "1", "--set", "backend=numpy", "--out", str(out)]) == 0
    data = np.load(out)
    assert data["pyr_pos"].shape == (2, 12, 3) and data["pyr_col"].shape == (2, 12, 4)
    assert data["quad_model"].shape == (2, 4, 4)
    apex_height = data["pyr_pos"][:, 5, 1]
    np.testing.assert_allclose(apex_height, 7.5, atol=1e-5)  # 1.5 object units x scale 5, quad lying flat


def test_bad_cli_input_is_one_line(capsys):
    assert main(["run", "grass", "--set", "plane_resolution=0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "plane_resolution must be in [1, 1000]" in err


# }}}

# {{{ view: the GLSL geometry shaders themselves


def render(glr, name: str, size=(96, 72), camera=None, prepare=None, **overrides):
    from ugpcl.viewer.offscreen import frame
    from ugpcl.viewer.views import create_view

    scene = get(name)
    sim = scene.create(glr.runtime, 0, **overrides)
    view = create_view(scene, glr.ctx, sim)
    if prepare:
        prepare(view)
    camera = camera or view.make_camera()
    camera.aspect = size[0] / size[1]
    view.upload()
    query = glr.ctx.query(primitives=True)
    with query:
        pixels = frame(size).render(view, camera)
    return sim, view, camera, pixels, query.primitives


@pytest.fixture
def glr(runtime, gl):
    """The GL context plus the OpenCL runtime the scenes use (made before the GL context)."""
    return SimpleNamespace(ctx=gl, runtime=runtime)


def edge_side(p, q, px, py):
    """Sign of the sample points (px, py) against the edge p -> q (2D cross product)."""
    return (q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (px - p[0])


def covered_pixels(triangles_clip: np.ndarray, size, samples: int = 1) -> np.ndarray:
    """Pixels with any of ``samples`` x ``samples`` sample points inside one of the (N, 3, 4) clip-space triangles
    (all in front of the camera); samples = 1 tests the pixel centre."""
    w, h = size[0] * samples, size[1] * samples
    ndc = triangles_clip[..., :2] / triangles_clip[..., 3:]
    xy = np.stack([(ndc[..., 0] + 1) / 2 * w, (1 - ndc[..., 1]) / 2 * h], axis=-1)  # row 0 at the top
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    mask = np.zeros((h, w), bool)
    for a, b, c in xy:
        lo, hi = np.floor(np.minimum(np.minimum(a, b), c)).astype(int), np.ceil(np.maximum(np.maximum(a, b), c))
        x0, y0, x1, y1 = max(lo[0], 0), max(lo[1], 0), min(int(hi[0]), w), min(int(hi[1]), h)
        if x0 >= x1 or y0 >= y1:
            continue
        px, py = xx[y0:y1, x0:x1], yy[y0:y1, x0:x1]
        s1, s2, s3 = (edge_side(p, q, px, py) for p, q in ((a, b), (b, c), (c, a)))
        mask[y0:y1, x0:x1] |= ((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))
    return mask.reshape(size[1], samples, size[0], samples).any(axis=(1, 3))


@pytest.mark.gl
def test_grass_view_draws_blades_where_the_blades_are(glr):
    from ugpcl.viewer.camera import OrbitCamera

    camera = OrbitCamera(target=(0.0, 5.0, 0.0), distance=32.0, yaw=20.0, pitch=25.0)
    size = (96, 72)
    sim, view, camera, pixels, primitives = render(glr, "grass", size, camera, planes=(1, 1), start_time=30.0)
    assert primitives == 5 * sim.blades == 1000, "one 5-triangle strip per input triangle"
    state = sim.state()
    world = state["blade_pos"].reshape(-1, 3)[state["blade_tris"].ravel()].reshape(-1, 3, 3)
    clip = np.concatenate([world, np.ones((*world.shape[:2], 1))], axis=-1) @ (camera.projection() @ camera.view()).T
    assert (clip[..., 3] > 0).all()
    expected = covered_pixels(clip, size)
    mask = foreground(pixels, view.background)
    assert 0.05 < expected.mean() < 0.5, "the test camera should see a patch of lawn with sky around it"
    assert not expected[0].any() and not expected[:, 0].any(), "the lawn should not touch the frame"
    recall = (mask & expected).sum() / expected.sum()
    # a sliver can cover a pixel centre and miss all four MSAA samples: observed 0.971
    assert recall > 0.95, f"only {recall:.3f} of the pixels whose centre a blade covers are drawn"
    touched = covered_pixels(clip, size, samples=4)  # MSAA also tints pixels a thin blade only grazes
    stray = (mask & ~touched).sum() / mask.sum()
    assert stray < 0.01, f"{stray:.3f} of the drawn pixels are touched by no blade"
    # unlit vertex colours between the book's bottom (0, .21, .33) and top (0, 1, .30): red stays 0, tips are green
    assert pixels[mask][:, 0].max() <= 3
    assert pixels[mask][:, 1].mean() > pixels[mask][:, 2].mean()


@pytest.mark.gl
def test_grass_geometry_shader_matches_grass_expand(glr):
    """Transform feedback of the viewer's own grass.geom against the kernel, 2x2 planes, with wind."""
    from ugpcl.viewer.offscreen import frame

    sim, view, camera, _, _ = render(glr, "grass", planes=(2, 2), start_time=7.0, wind_time_scale=1.0)
    frame((16, 16)).msaa.use()  # transform feedback still wants a complete framebuffer bound
    view.set_uniforms(camera)
    captured = glr.ctx.buffer(reserve=sim.blades * 15 * 7 * 4)  # 5 triangles x 3 vertices x (vec3 + vec4)
    view.vao.transform(captured, moderngl.TRIANGLES, vertices=len(sim.ground["tri"]) * 3, instances=len(sim.models))
    out = np.frombuffer(captured.read(), "f4").reshape(-1, 7)
    captured.release()
    state = sim.state()
    corners = state["blade_tris"].ravel()  # GL splits each strip into triangles by the same alternation
    pos, col = state["blade_pos"].reshape(-1, 3)[corners], state["blade_col"].reshape(-1, 4)[corners]
    # llvmpipe samples R32F maps bilinearly in float: observed 5e-6; 1e-4 of the blade height scale
    atol = 1e-4 * sim.params.height
    assert np.allclose(out[:, :3], pos, atol=atol, rtol=0), first_mismatch(out[:, :3], pos, 0, atol)
    np.testing.assert_allclose(out[:, 3:], col, atol=1e-6)


@pytest.mark.gl
def test_grass_geometry_shader_matches_the_reference_on_a_tilted_mesh(glr, seed):
    """Transform feedback of grass.vert/grass.geom on the random tilted mesh (tilted normals, UVs wrapping, three
    instanced affine models) against the float64 port of the book's geom() and against GrassExpand."""
    from ugpcl.viewer.offscreen import frame

    mesh, models, maps = tilted_mesh(seed)

    def tilted(view):
        view.sim.set_ground(mesh, models, maps)

    sim, view, camera, _, primitives = render(
        glr, "grass", prepare=tilted, planes=(1, 1), start_time=3.7, wind_time_scale=1.0
    )
    assert primitives == 5 * 3 * 10, "one 5-triangle strip per triangle per instance"
    frame((16, 16)).msaa.use()
    view.set_uniforms(camera)
    captured = glr.ctx.buffer(reserve=sim.blades * 15 * 7 * 4)
    view.vao.transform(captured, moderngl.TRIANGLES, vertices=len(mesh["tri"]) * 3, instances=len(models))
    out = np.frombuffer(captured.read(), "f4").reshape(-1, 7)
    captured.release()
    expected_pos, expected_col, _ = tilted_reference(mesh, models, maps, sim.params, 3.7)
    corners = sim.state()["blade_tris"].ravel()
    pos, col = expected_pos.reshape(-1, 3)[corners], expected_col.reshape(-1, 4)[corners]
    # float sampling (llvmpipe): 1e-4 of the blade height, as the plane-field test. A texture unit with rounded weights
    # (NVIDIA: 0.007 off here) misreads these steep random maps by up to filter error x texel step; the blade moves
    # with height, rotation and wind, scaled by the model: bound that by 4 x blade height x the largest model gain
    steepest = max(np.abs(np.diff(m, axis=a)).max() for m in maps.values() for a in (0, 1))
    gain = max(np.linalg.norm(model[:3, :3], 2) for model in models)
    atol = 1e-4 * sim.params.height + linear_filter_error(glr.ctx) * steepest * 4 * sim.params.height * gain
    assert np.allclose(out[:, :3], pos, atol=atol, rtol=0), first_mismatch(out[:, :3], pos, 0, atol)
    np.testing.assert_allclose(out[:, 3:], col, atol=1e-6)
    kernel = sim.state()["blade_pos"].reshape(-1, 3)[corners]
    np.testing.assert_allclose(out[:, :3], kernel, atol=atol, rtol=0)


@pytest.mark.gl
def test_opencl_path_draws_the_same_lawn(glr):
    size = (96, 72)

    def opencl(view):
        view.next_path()

    _, _, _, gs, gs_primitives = render(glr, "grass", size, planes=(2, 2))
    _, view, _, cl, primitives = render(glr, "grass", size, prepare=opencl, planes=(2, 2))
    assert gs_primitives == 5 * 800, "instanced geometry shader: one 5-triangle strip per triangle of every plane"
    assert view.path == "OpenCL" and primitives == 5 * 800
    a, b = foreground(gs, (0, 0, 0)), foreground(cl, (0, 0, 0))
    assert (a & b).sum() / (a | b).sum() > 0.97
    assert np.abs(gs.astype(int) - cl.astype(int)).mean() < 2


@pytest.mark.gl
@pytest.mark.parametrize("rot, front", [(0.75, False), (0.25, True)])
def test_culling_shows_why_the_book_says_cull_off(glr, rot, front):
    """One blade seen from -Z: along +X its strip turns counter-clockwise on screen (a back face: Unity's fronts are
    clockwise), along -X clockwise. Cull Off draws both; with culling one of them vanishes."""
    from ugpcl.viewer.camera import OrbitCamera

    def one_blade(view):
        view.sim.set_ground(GOLDEN_TRIANGLE, np.identity(4), constant_maps(0.2, rot, 0.0))

    camera = OrbitCamera(target=(0.3, 3.0, 0.0), distance=8.0)

    def culled(view):
        one_blade(view)
        view.toggle_cull()

    _, _, _, shown, _ = render(glr, "grass", (64, 64), camera, prepare=one_blade)
    _, _, _, kept, _ = render(glr, "grass", (64, 64), camera, prepare=culled)
    assert foreground(shown, (0, 0, 0)).sum() > 50
    assert foreground(kept, (0, 0, 0)).sum() == (foreground(shown, (0, 0, 0)).sum() if front else 0)


@pytest.mark.gl
def test_pyramid_view_shows_the_plain_quad_and_two_pyramids(glr):
    size = (128, 96)
    sim, view, camera, pixels, primitives = render(glr, "grass_pyramid", size)
    assert primitives == 2 + 8, "the plain quad's 2 triangles + 4 per triangle from the geometry shader"

    def pixel_of(point):
        clip = camera.projection() @ camera.view() @ np.append(point, 1.0)
        x, y = clip[:2] / clip[3]
        return int((1 - y) / 2 * size[1]), int((x + 1) / 2 * size[0])

    state = sim.state()
    for apex in state["pyr_pos"][:, 5]:
        row, col = pixel_of(apex - [0, 0.4, 0])  # just below the tip: the top colour (green)
        r, g, b = pixels[row, col].astype(int)
        assert g > 150 and g > b and r < 10, (row, col, pixels[row, col])
    row, col = pixel_of(state["quad_model"][0][:3, 3])  # the plain quad's centre: grey
    np.testing.assert_allclose(pixels[row, col], 128, atol=3)
    assert not foreground(pixels, view.background)[:, size[0] // 2 - 2 : size[0] // 2 + 2].any()  # gap between


@pytest.mark.gl
def test_pyramid_geometry_shader_matches_pyramid_expand(glr):
    from ugpcl.viewer.offscreen import frame

    sim, view, camera, _, _ = render(glr, "grass_pyramid", height=2.0)
    frame((16, 16)).msaa.use()
    view.set_uniforms(camera)
    captured = glr.ctx.buffer(reserve=2 * 12 * 7 * 4)
    view.vao.transform(captured, moderngl.TRIANGLES, vertices=6)
    out = np.frombuffer(captured.read(), "f4").reshape(-1, 7)
    captured.release()
    state = sim.state()
    np.testing.assert_allclose(out[:, :3], state["pyr_pos"].reshape(-1, 3), atol=1e-5)
    np.testing.assert_allclose(out[:, 3:], state["pyr_col"].reshape(-1, 4), atol=1e-6)


@pytest.mark.gl
def test_view_keys_change_the_parameters(glr):
    from ugpcl.viewer.views import create_view

    scene = get("grass")
    sim = scene.create(glr.runtime, 0, planes=(2, 2))
    view = create_view(scene, glr.ctx, sim)
    view.taller()
    assert sim.params.height == pytest.approx(27.5)
    view.narrower()
    assert sim.params.width == pytest.approx(0.5 / 1.1)
    view.toggle_wind()
    assert sim.params.wind_power == 0.0
    view.toggle_wind()
    assert sim.params.wind_power == 0.75
    view.more_wind()
    assert sim.params.wind_power == 1.0
    view.toggle_time_scale()
    assert sim.params.wind_time_scale == 1.0
    view.denser()
    assert sim.params.plane_resolution == 20 and sim.blades == 4 * 800
    view.fewer_planes()
    assert sim.params.planes == (1, 1)
    view.next_path()
    assert view.path == "OpenCL"
    keys = {k.key for k in view.keys}
    assert keys >= {"up", "down", "left", "right", "[", "]", "w", ",", "+", "-", "c", "f", "tab"}
    assert not keys & {"space", "n", "r", "s", "h", "esc"}, "shared keys are the app's"


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind, seed):
    sim = Simulation(oclgrind, Params(planes=(2, 1), plane_resolution=2, start_time=5.0, wind_time_scale=1.0), seed)
    sim.step()  # GrassExpand: 16 blades over 2 planes
    reference = Simulation(oclgrind, Params(planes=(2, 1), plane_resolution=2, backend="numpy"), seed)
    reference.update(start_time=5.0, wind_time_scale=1.0)
    reference.step()
    np.testing.assert_allclose(sim.state()["blade_pos"], reference.state()["blade_pos"], atol=1e-4)
    pyramid = PyramidSimulation(oclgrind, PyramidParams(), seed)
    pyramid.step()  # PyramidExpand: the quad's 2 triangles
    assert np.isfinite(pyramid.state()["pyr_pos"]).all()
