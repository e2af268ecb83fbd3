"""Projection spray (vol.1 ch.10; docs/chapters/10-projection-spray.md): the paint law, occlusion against exact
ray casting, the stencil's shape, dilation, tile skipping, the per-triangle layout, kernels vs numpy, view, CLI,
Oclgrind."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import first_mismatch, foreground, render_view, run_cli
from scipy.ndimage import binary_dilation

from ugpcl.geometry.ear_clipping import point_in_polygon
from ugpcl.geometry.mesh import Mesh, vertex_normals
from ugpcl.geometry.projection_spray import (
    PRESETS,
    STAR_POINTS,
    STAR_RADII,
    STENCIL_PLATE_Z,
    Drawable,
    box_blocks,
    planar_mesh,
    spray_matrices,
    star,
)
from ugpcl.geometry.skinned_figure import Figure
from ugpcl.geometry.uv_atlas import bake, per_triangle_layout, unit_cube, uv_sphere
from ugpcl.registry import get
from ugpcl.scenes.projection_spray import DEPTH_BLOCK, Params, Simulation

RED = (1.0, 0.0, 0.0, 1.0)


def make(runtime, seed: int = 0, **overrides) -> Simulation:
    base = {"hue_cycle": False, "color": RED, "rotation_speed": 0.0, "aim": "fixed"}
    return Simulation(runtime, Params(**{**base, **overrides}), seed)


def quad(size: float, z: float) -> Drawable:
    """A size x size quad in the plane z facing the stencil preset's spray (at z = -5, looking +z), uvs [0, 1]^2."""
    h = size / 2
    return Drawable(
        "quad", planar_mesh(np.array([[-h, -h], [h, -h], [h, h], [-h, h]]), [[0, 1, 2], [0, 2, 3]], z), rotates=False
    )


# {{{ numpy float64 reference, written from the chapter page's retelling of the sample's passes


def bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """GL_LINEAR + CLAMP_TO_EDGE on an (h, w, ...) image at uv (..., 2), row 0 = v near 0."""
    h, w = image.shape[:2]
    p = uv * [w, h] - 0.5
    base = np.floor(p)
    t = p - base
    x0, y0 = base[..., 0].astype(int), base[..., 1].astype(int)
    x = [np.clip(x0, 0, w - 1), np.clip(x0 + 1, 0, w - 1)]
    y = [np.clip(y0, 0, h - 1), np.clip(y0 + 1, 0, h - 1)]
    tx, ty = t[..., 0], t[..., 1]
    if image.ndim == 3:
        tx, ty = tx[..., None], ty[..., None]
    bottom = image[y[0], x[0]] * (1 - tx) + image[y[0], x[1]] * tx
    top = image[y[1], x[0]] * (1 - tx) + image[y[1], x[1]] * tx
    return bottom * (1 - ty) + top * ty


def spray_reference(pos, nrm, o2w, pose, p: Params, shape, depth):
    """(alpha, tint, s, clip) per texel: the sample's paint alpha before colour.a * dt * emission."""
    proj, w2d = spray_matrices(pose, p.spray_angle, p.spray_range)
    wp = pos[..., :3].astype(np.float64) @ o2w[:3, :3].T + o2w[:3, 3]
    wn = nrm[..., :3].astype(np.float64) @ o2w[:3, :3].T
    wn /= np.maximum(np.linalg.norm(wn, axis=-1, keepdims=True), 1e-30)
    c = wp @ proj[:3, :3].T + proj[:3, 3]
    cw = wp @ proj[3, :3] + proj[3, 3]
    ok = (pos[..., 3] >= 0.5) & (c[..., 2] > 0) & (cw > 0)
    s = c[..., :2] / np.where(ok, cw, 1.0)[..., None]
    ok &= np.all(np.abs(s - 0.5) < 0.5, axis=-1)
    lp = wp @ w2d[:3, :3].T + w2d[:3, 3]
    ln = wn @ w2d[:3, :3].T
    dist = np.linalg.norm(lp, axis=-1)
    atten = np.maximum(0.0, np.sum(ln * -lp / dist[..., None], axis=-1))
    occ = bilinear(depth.astype(np.float64), s)
    lit = 1.0 - np.clip((dist - occ - p.occlusion_bias) * p.occlusion_sharpness, 0.0, 1.0)
    spray = bilinear(shape.astype(np.float64), s)
    alpha = spray[..., 3] * lit * atten * np.maximum(0.0, 1.0 - dist / p.spray_range)
    return np.where(ok, alpha, 0.0), spray[..., :3], s, (c[..., 2], cw)


def edge_thicken_reference(pos, src, e: int):
    h, w = pos.shape[:2]
    a = pos[..., 3]
    y, x = np.mgrid[0:h, 0:w]

    def cov(dx, dy):
        return a[np.clip(y + dy, 0, h - 1), np.clip(x + dx, 0, w - 1)]

    a00, a01, a10, a11 = cov(-e, -e), cov(-e, e), cov(e, -e), cov(e, e)
    direction = np.stack([a10 + a11 - a00 - a01, a01 + a11 - a00 - a10], -1).astype(np.float64)
    length = np.linalg.norm(direction, axis=-1)
    unit = direction / np.maximum(length, 1e-30)[..., None]
    uv = (np.stack([x, y], -1) + 0.5) / [w, h] + unit * [e / w, e / h]
    sampled = bilinear(src.astype(np.float64), uv)
    keep = (a >= 1.0) | (length == 0)
    return np.where(keep[..., None], src, sampled)


def exact_distance(origin, points, triangles) -> np.ndarray:
    """Distance from ``origin`` along the ray to each point of the nearest triangle hit (inf: none), float64."""
    a, e1, e2 = triangles[:, 0], triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    out = np.full(len(points), np.inf)
    for start in range(0, len(points), 256):
        d = points[start : start + 256] - origin
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        pv = np.cross(d[:, None, :], e2[None])
        det = np.einsum("fk,pfk->pf", e1, pv)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1 / np.where(ok, det, 1), 0)
        tv = origin - a
        u = np.einsum("fk,pfk->pf", tv, pv) * inv
        qv = np.cross(tv, e1)
        v = np.einsum("pk,fk->pf", d, qv) * inv
        t = np.einsum("fk,fk->f", e2, qv)[None] * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9)
        out[start : start + 256] = np.where(hit, t, np.inf).min(axis=1)
    return out


def world_triangles(sim: Simulation) -> np.ndarray:
    o2w = sim.object_to_world(sim.time)
    return np.concatenate([t @ m[:3, :3].T + m[:3, 3] for t, m in zip(sim.triangles, o2w, strict=True)])


# }}}

# {{{ the paint law


def test_fully_lit_texel_reaches_one_minus_0985_to_the_60(runtime):
    # the spray 3 units in front of a 4 x 4 quad, perpendicular, at its centre texel (odd size: one sits there)
    sim = make(runtime, preset="stencil", tex=65, depth_res=65)
    sim.set_drawables([quad(4.0, PRESETS["stencil"].spray_position[2] + 3.0)])
    sim.step(1.0 / 60.0)
    centre = sim.state()["paint"][0, 32, 32]
    np.testing.assert_allclose(centre[:3], [0.015, 0.0, 0.0], atol=1e-6)  # (1 - 3/30) / 60
    for _ in range(59):
        sim.step(1.0 / 60.0)
    paint = sim.state()["paint"][0]
    assert abs(paint[32, 32, 0] - (1 - 0.985**60)) <= 1e-4, paint[32, 32]
    assert abs(paint[32, 32, 0] - 0.59619) <= 1e-4
    # footprint: a disc of radius 3 tan 15 * ~0.98 = 0.79 units: 0.122 +- 0.015 of the quad
    assert abs((paint[..., 0] > 0).mean() - 0.122) <= 0.015


def test_paint_rate_is_colour_alpha_times_emission(runtime):
    """a_frame = a * color.a * dt * emission: alpha 0.5 and emission 3 paint the fully lit texel 1.5 times as fast."""
    sim = make(runtime, preset="stencil", tex=65, depth_res=65, color=(1.0, 0.0, 0.0, 0.5), emission=3.0)
    sim.set_drawables([quad(4.0, PRESETS["stencil"].spray_position[2] + 3.0)])
    sim.step(1.0 / 60.0)
    np.testing.assert_allclose(sim.state()["paint"][0, 32, 32, :3], [0.0225, 0.0, 0.0], atol=1e-6)  # 0.9 * 1.5 / 60


def test_nothing_nearer_than_the_near_plane_is_painted(runtime):
    """The spray camera's near clip is 0.01: a 2 mm quad 5 mm in front of the spray lies inside the cone but before
    the frustum and takes no paint; 2 cm in front, it is painted all over."""
    z = PRESETS["stencil"].spray_position[2]
    for distance, painted in ((0.005, False), (0.02, True)):
        sim = make(runtime, preset="stencil", tex=16, depth_res=16, skip_tiles=False)
        sim.set_drawables([quad(0.002, z + distance)])
        sim.step(1.0 / 60.0)
        state = sim.state()
        red = state["paint"][0][state["pos_tex"][0][..., 3] >= 0.5][:, 0]
        assert len(red) == 16 * 16  # the quad covers its whole texture
        assert (red > 0.01).all() if painted else not red.any(), (distance, red.min(), red.max())


def test_incidence_range_and_facing(runtime):
    z = PRESETS["stencil"].spray_position[2] + 3.0
    tilted = quad(4.0, 0.0)
    c, s = np.cos(np.radians(60)), np.sin(np.radians(60))
    tilted.local = np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, z], [0, 0, 0, 1.0]])
    sim = make(runtime, preset="stencil", tex=65, depth_res=65)
    sim.set_drawables([tilted])
    sim.step(1.0 / 60.0)
    np.testing.assert_allclose(sim.state()["paint"][0, 32, 32, 0], 0.015 * 0.5, rtol=1e-3)
    far = make(runtime, preset="stencil", tex=33, depth_res=33)
    far.set_drawables([quad(4.0, PRESETS["stencil"].spray_position[2] + 31.0)])  # beyond range 30
    far.step()
    assert np.all(far.state()["paint"] == np.float32([0, 0, 0, 1]))
    away = make(runtime, preset="stencil", tex=33, depth_res=33)
    back = quad(4.0, 0.0)
    back.local = np.array([[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, z], [0, 0, 0, 1.0]])  # facing away
    away.set_drawables([back])
    away.step()
    assert np.all(away.state()["paint"] == np.float32([0, 0, 0, 1]))


# }}}

# {{{ occlusion


def test_depth_map_occlusion_agrees_with_exact_ray_casting(runtime):
    sim = make(runtime, tex=64, depth_res=256)
    sim.step()
    state = sim.state()
    pose = state["spray_pose"][0].astype(np.float64)
    origin, triangles = pose[:3, 3], world_triangles(sim)
    proj, _ = spray_matrices(pose, sim.params.spray_angle, sim.params.spray_range)
    o2w = sim.object_to_world(0.0)
    agree = total = 0
    for k in range(2):
        pos, nrm = state["pos_tex"][k], state["nrm_tex"][k]
        covered = pos[..., 3] >= 0.5
        wp = pos[..., :3].astype(np.float64) @ o2w[k][:3, :3].T + o2w[k][:3, 3]
        wn = nrm[..., :3].astype(np.float64) @ o2w[k][:3, :3].T
        clip = wp @ proj.T[:3] + proj[:, 3]
        s = clip[..., :2] / clip[..., 3:]
        to_spray = origin - wp
        dist = np.linalg.norm(to_spray, axis=-1)
        # candidates: in the shape's solid disc, facing the spray by > 10 degrees of grazing
        facing = np.sum(wn * to_spray, axis=-1) / np.maximum(np.linalg.norm(wn, axis=-1) * dist, 1e-30)
        candidate = covered & (clip[..., 3] > 0) & (np.linalg.norm(s - 0.5, axis=-1) < 0.4) & (facing > 0.17)
        hit = exact_distance(origin, wp[candidate], triangles)
        visible = hit >= dist[candidate] - 1e-3
        painted = state["paint"][k][candidate][:, :3].any(axis=-1)
        agree += int((painted == visible).sum())
        total += int(candidate.sum())
        hidden = hit < dist[candidate] - 0.1  # well inside a shadow: exactly no paint
        assert not painted[hidden].any(), f"{painted[hidden].sum()} occluded texels of drawable {k} got paint"
        assert hidden.sum() > 20 or k == 1  # the sphere shadows part of the cube's top
    assert total > 1000
    assert agree / total >= 0.99, f"{agree} of {total} texels agree"


def test_stencil_leaves_the_cut_out_shape(runtime):
    sim = make(runtime, preset="stencil", tex=128, depth_res=256)
    sim.step()
    state = sim.state()
    pos = state["pos_tex"][0]  # the wall
    covered = pos[..., 3] >= 0.5
    origin = np.asarray(PRESETS["stencil"].spray_position)
    wp = pos[..., :3].astype(np.float64)
    # the wall point's ray crosses the plate's plane at q: inside the star <=> the paint gets through
    t = (STENCIL_PLATE_Z - origin[2]) / (wp[..., 2] - origin[2])
    q = origin[:2] + (wp[..., :2] - origin[:2]) * t[..., None]
    ring = star(*STAR_RADII, STAR_POINTS)
    inside = np.array([point_in_polygon(ring, p) for p in q[covered]])
    # distance from q to the star's outline, to leave out the band the depth map's texels blur (1.5 pixels)
    a, b = ring, np.roll(ring, -1, axis=0)
    rel = q[covered][:, None, :] - a
    along = np.clip(np.sum(rel * (b - a), -1) / np.sum((b - a) ** 2, -1), 0, 1)
    edge = np.linalg.norm(rel - along[..., None] * (b - a), axis=-1).min(axis=1)
    pixel = 2 * 2.5 * np.tan(np.radians(15)) / sim.params.depth_res  # a depth pixel's width at the plate
    clear = edge > 1.5 * pixel
    painted = state["paint"][0][covered][:, 0] > 0
    assert inside.sum() > 200
    np.testing.assert_array_equal(painted[clear], inside[clear])
    assert (painted == inside).mean() > 0.97


# }}}

# {{{ dilation and tiles


def test_edge_thicken_fills_only_gutter_texels_next_to_paint(runtime):
    sim = make(runtime, tex=64, depth_res=64, aim="orbit", rotation_speed=20.0)
    for _ in range(6):
        sim.step()
    state = sim.state()
    e = sim.params.edge_texels
    clear = np.float32(sim.params.clear_color)
    for k in range(2):
        covered = state["pos_tex"][k][..., 3] >= 0.5
        canvas, paint = state["canvas"][k], state["paint"][k]
        np.testing.assert_array_equal(canvas[covered], paint[covered])
        changed = np.any(canvas != clear, axis=-1) & ~covered
        painted = np.any(paint != clear, axis=-1) & covered
        near_paint = binary_dilation(painted, np.ones((2 * e + 3, 2 * e + 3), bool))
        assert changed.sum() > 10
        assert not (changed & ~near_paint).any(), "a gutter texel took paint from nowhere near it"
        assert np.isfinite(canvas).all()


def test_edge_thicken_matches_reference(runtime):
    sim = make(runtime, tex=48, depth_res=64, aim="orbit", skip_tiles=False)
    for _ in range(3):
        sim.step()
    state = sim.state()
    for k in range(2):
        expected = edge_thicken_reference(state["pos_tex"][k], state["paint"][k], sim.params.edge_texels)
        np.testing.assert_allclose(state["canvas"][k], expected, atol=1e-6)


def test_skipping_tiles_changes_nothing(runtime):
    kwargs = dict(tex=96, depth_res=64, aim="orbit", rotation_speed=20.0, hue_cycle=True)
    skipping, full = make(runtime, skip_tiles=True, **kwargs), make(runtime, skip_tiles=False, **kwargs)
    skipped = []
    for _ in range(8):
        skipping.step()
        full.step()
        skipped.append(skipping.tiles_last < full.tiles_last)
    assert all(skipped), "the cube_sphere spray reaches only part of the textures: some tiles must be skipped"
    a, b = skipping.state(), full.state()
    for name in ("paint", "canvas", "guide"):
        np.testing.assert_array_equal(a[name], b[name])


def test_reachable_tiles_hold_every_reachable_texel(runtime):
    sim = make(runtime, tex=96, depth_res=64, aim="orbit", skip_tiles=False, emission=1e3)
    for _ in range(4):
        before = sim.state()["paint"]
        sim.step()
        after = sim.state()["paint"]
        pose, o2w = sim.last["pose"], sim.last["o2w"]
        for k in range(2):
            changed = np.any(after[k] != before[k], axis=-1)
            tiles = np.zeros(sim.tiles_x**2, bool)
            tiles[sim.reachable_tiles(k, pose, o2w[k])] = True
            ty, tx = np.nonzero(changed)
            assert tiles[(ty // 16) * sim.tiles_x + tx // 16].all(), "paint in a tile judged unreachable"
            assert not tiles.all() or k == 1  # the whole sphere fits in the cone; the cube does not


# }}}

# {{{ layouts


def test_per_triangle_layout_gives_every_triangle_its_own_texels():
    vertices, triangles, _ = Figure().mesh()
    mesh = per_triangle_layout(Mesh(vertices, triangles, vertex_normals(vertices, triangles)), 512, 2)
    pos, _, owner, hits = bake(mesh, 512)
    assert hits.max() == 1, "two triangles share a texel"
    counts = np.bincount(owner[owner >= 0], minlength=len(triangles))
    assert counts.min() >= 1, f"triangle {counts.argmin()} has no texel"
    # every texel's position lies on the triangle that owns it
    v = mesh.vertices[mesh.faces[owner[owner >= 0]]].astype(np.float64)
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    off_plane = np.abs(np.sum((pos[owner >= 0, :3] - v[:, 0]) * n, axis=1))
    assert off_plane.max() < 1e-5
    with pytest.raises(ValueError, match="tex must be >= "):
        per_triangle_layout(mesh, 64, 2)


@pytest.mark.parametrize("make_mesh", [unit_cube, uv_sphere])
def test_cube_and_sphere_layouts(make_mesh):
    tex, gutter = 128, 16
    mesh = make_mesh(tex, gutter)
    pos, nrm, owner, _ = bake(mesh, tex)
    covered = pos[..., 3] >= 0.5
    # islands keep the gutter: no covered texel within `gutter` texels of the texture's edge
    assert not covered[: gutter - 1].any() and not covered[:, : gutter - 1].any()
    # positions sit on the surface, the baked normals point out
    if make_mesh is uv_sphere:
        radius = np.linalg.norm(pos[covered, :3], axis=1)
        assert radius.max() <= 0.5 + 1e-6 and radius.min() > 0.48
    else:
        assert np.allclose(np.abs(pos[covered, :3]).max(axis=1), 0.5, atol=1e-6)
    assert np.all(np.sum(pos[covered, :3] * nrm[covered, :3], axis=1) > 0)


# }}}

# {{{ kernels vs numpy


def test_spray_kernels_match_reference(runtime):
    sim = make(runtime, tex=40, depth_res=64, aim="orbit", rotation_speed=20.0, hue_cycle=True, skip_tiles=False)
    p = sim.params
    shape = sim.shape.get()
    for frame in range(10):
        painting = frame % 3 != 2
        sim.update(painting=painting)
        before = sim.state()["paint"]
        sim.step(1.0 / 60.0)
        state = sim.state() if painting else None
        depth = sim.depth_map()
        last = sim.last
        for k in range(2):
            tex = sim.textures[k]
            alpha, tint, s, (cz, cw) = spray_reference(
                tex["pos"], tex["nrm_tex"].get(), last["o2w"][k], last["pose"], p, shape, depth
            )
            color = np.asarray(last["color"])
            # texels within 1e-5 of a frustum test's threshold may fall either way in float32
            edge = (np.abs(np.abs(s - 0.5) - 0.5) < 1e-5).any(axis=-1) | (np.abs(cz) < 1e-5)
            if painting:
                weight = (alpha * color[3] * last["dt"] * p.emission)[..., None]
                expected = before[k].astype(np.float64).copy()
                expected[..., :3] += (tint * color[:3] - expected[..., :3]) * weight
                expected[..., 3] = np.where(alpha > 0, 1.0, expected[..., 3])
                got = state["paint"][k]
            else:
                a = alpha * color[3]
                expected = np.concatenate([tint * color[:3] * a[..., None], a[..., None]], -1)
                got = sim.textures[k]["guide"].get()
            ok = ~edge
            assert np.allclose(got[ok], expected[ok], atol=1e-5), first_mismatch(got[ok], expected[ok], 0, 1e-5)


def test_depth_map_matches_exact_ray_casting(runtime):
    sim = make(runtime, tex=16, depth_res=64)
    sim.step()
    depth = sim.depth_map()
    pose = sim.last["pose"]
    d = sim.params.depth_res
    half = np.tan(np.radians(sim.params.spray_angle) / 2)
    j, i = np.mgrid[0:d, 0:d]
    sx, sy = (2 * (i + 0.5) / d - 1) * half, (2 * (j + 0.5) / d - 1) * half
    directions = pose[:3, 2] + sx[..., None] * pose[:3, 0] + sy[..., None] * pose[:3, 1]
    points = pose[:3, 3] + directions.reshape(-1, 3) * 100.0
    exact = np.minimum(exact_distance(pose[:3, 3], points, world_triangles(sim)), sim.params.spray_range)
    exact = exact.reshape(d, d)
    close = np.abs(depth - exact) <= 1e-4 * exact
    assert close.mean() >= 0.995, f"{(~close).sum()} of {d * d} depth pixels differ"
    assert depth.min() > 0 and depth.max() <= sim.params.spray_range


def test_depth_map_of_a_wall_filling_the_frustum_is_exact_to_its_edges(runtime):
    """A 4 x 4 quad 3 units ahead fills the spray's view: every pixel, the last row and column too, holds the
    distance 3 |forward + sx right + sy up| to the plane."""
    d = 31
    sim = make(runtime, preset="stencil", tex=16, depth_res=d, skip_tiles=False)
    sim.set_drawables([quad(4.0, PRESETS["stencil"].spray_position[2] + 3.0)])
    sim.step()
    half = np.tan(np.radians(sim.params.spray_angle) / 2)
    j, i = np.mgrid[0:d, 0:d]
    exact = 3.0 * np.sqrt(1 + ((2 * (i + 0.5) / d - 1) * half) ** 2 + ((2 * (j + 0.5) / d - 1) * half) ** 2)
    depth = sim.depth_map()
    assert np.allclose(depth, exact, rtol=1e-5), first_mismatch(depth.ravel(), exact.ravel(), 1e-5, 0)


def serial_depth(sim: Simulation) -> np.ndarray:
    """The depth map of the last frame's triangles by SprayDepth_serial (one work-item per triangle over its whole
    box, the shape of work before the blocks), as uint bits."""
    p = sim.params
    count = sum(len(t) for t in sim.triangles)
    depth = sim.runtime.to_device(np.full(p.depth_res**2, np.float32(p.spray_range)).view(np.uint32))
    frame = sim.depth_frame(sim.last["pose"])
    sim.program.kernel("SprayDepth_serial").over(count, 64, sim.world_triangles, count, depth, *frame)
    return depth.get()


def triangle_soup(count: int, seed: int) -> Drawable:
    """``count`` triangles of sizes from a few depth pixels to the whole map, around the stencil preset's spray (at
    z = -5, looking +z), some of them straddling its plane or behind it."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform([-3, -3, -6], [3, 3, 3], (count, 1, 3))
    vertices = (centres + rng.normal(size=(count, 3, 3)) * rng.uniform(0.02, 3.0, (count, 1, 1))).reshape(-1, 3)
    mesh = Mesh(vertices, np.arange(3 * count).reshape(count, 3))
    return Drawable("soup", per_triangle_layout(mesh, 128, 1), rotates=False)


@pytest.mark.parametrize(
    "preset, depth_res", [("cube_sphere", 64), ("cube_sphere", 61), ("stencil", 67), ("figure", 40), ("soup", 53)]
)
def test_blocked_depth_map_is_the_serial_kernels_bit_for_bit(runtime, preset, depth_res):
    """SprayDepth (one work-item per pixel of each (triangle, block) pair) against SprayDepth_serial: the same
    pixels cast with the same arithmetic, so the same float bits; sizes that are not a multiple of DEPTH_BLOCK."""
    scene = "stencil" if preset == "soup" else preset
    figure = {"tex": 512, "edge_texels": 2, "aim_radius": 0.35}  # the figure scene's: its layout needs 512 texels
    sizes = figure if preset == "figure" else {"tex": 32}
    sim = make(runtime, preset=scene, depth_res=depth_res, aim="orbit", **sizes)
    assert sim.blocked_depth == runtime.is_gpu, "GPUs cast in blocks, CPU devices serially"
    sim.blocked_depth = True  # the blocks on every device, against the serial kernel
    if preset == "soup":
        sim.set_drawables([triangle_soup(200, seed=1)])
    for _ in range(3):
        sim.step(0.3)
        blocked = sim.depth.get()
        np.testing.assert_array_equal(blocked, serial_depth(sim))
        assert (blocked != np.float32(sim.params.spray_range).view(np.uint32)).mean() > 0.05  # the map holds hits


def test_box_blocks_lists_each_block_a_box_meets_once():
    rng = np.random.default_rng(0)
    lo = rng.integers(0, 70, (50, 2))
    boxes = np.concatenate([lo, lo + rng.integers(-3, 40, (50, 2))], axis=1).clip(0, 69).astype(np.int32)
    pairs = box_blocks(boxes, DEPTH_BLOCK, 5)  # a 70-pixel map: 5 blocks a row
    expected = set()
    for k, (x0, y0, x1, y1) in enumerate(boxes):
        for y in range(y0, y1 + 1):
            for x in range(x0, x1 + 1):
                expected.add((k, (y // DEPTH_BLOCK) * 5 + x // DEPTH_BLOCK))
    assert len(pairs) == len(expected) == len({tuple(pair) for pair in pairs})
    assert {tuple(pair) for pair in pairs} == expected


# }}}

# {{{ guide, parameters


def test_guide_does_not_accumulate_and_canvas_stays(runtime):
    sim = make(runtime, tex=48, depth_res=64, aim="orbit", painting=False)
    sim.step()
    first_guide, canvas = sim.state()["guide"], sim.state()["canvas"]
    assert first_guide[..., 3].max() > 0.5
    for _ in range(9):
        sim.step()
        assert np.array_equal(sim.state()["canvas"], canvas)
    # the same pose again: the same guide, not a sum of frames
    sim.update(aim="fixed")
    sim.step()
    g1 = sim.state()["guide"]
    sim.step()
    np.testing.assert_array_equal(sim.state()["guide"], g1)


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"preset": "teapot"}, "preset must be one of cube_sphere\\|stencil\\|figure"),
        ({"emission": float("inf")}, "emission must be a finite number"),
    ],
)
def test_bad_parameters_name_the_field_and_range(overrides, message):
    """What test_params does not try on every field: an unknown choice, infinity (the ranges are tried there)."""
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_figure_texture_too_small_is_a_param_error(runtime):
    from ugpcl.scene import ParamError

    with pytest.raises(ParamError, match="tex must be >= "):
        get("projection_spray_figure").create(runtime, tex=128)


# }}}

# {{{ view and CLI


def test_texture_rgba8_is_the_canvas_rounded_to_8_bits(runtime):
    sim = make(runtime, tex=24, depth_res=16)
    values = np.linspace(-0.1, 1.1, 24 * 24 * 4, dtype=np.float32).reshape(24, 24, 4)
    values[0, :4] = (np.arange(16, dtype=np.float32).reshape(4, 4) + 0.5) / 255  # halfway: to even, as np.round
    values[1, 0] = (np.nan, np.inf, -np.inf, 1.0)
    sim.textures[1]["guide_canvas"].set(values)
    got = sim.texture_rgba8(1, "guide_canvas")
    expected = np.round(np.clip(np.nan_to_num(values, nan=0.0), 0, 1) * np.float32(255)).astype(np.uint8)
    np.testing.assert_array_equal(got, expected)


@pytest.mark.gl
def test_view_uploads_only_the_textures_that_changed(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("projection_spray")
    sim = scene.create(runtime, tex=32, depth_res=32)
    view = create_view(scene, gl, sim)
    written = []
    convert = sim.texture_rgba8
    sim.texture_rgba8 = lambda k, name: written.append((k, name)) or convert(k, name)
    view.upload()
    assert sorted(written) == [(0, "canvas"), (0, "guide_canvas"), (1, "canvas"), (1, "guide_canvas")]
    for painting, expected in ((True, "canvas"), (False, "guide_canvas"), (False, "guide_canvas")):
        written.clear()
        sim.update(painting=painting)
        sim.step()
        view.upload()
        assert sorted(written) == [(0, expected), (1, expected)], (painting, written)
    written.clear()
    view.upload()  # nothing new
    sim.clear()
    view.upload()
    assert sorted(written) == [(0, "canvas"), (1, "canvas")]


@pytest.mark.gl
def test_view_shows_the_star_on_the_wall(runtime, gl):
    sim = get("projection_spray_stencil").create(runtime, tex=64, depth_res=128, hue_cycle=False, color=RED)
    for _ in range(60):
        sim.step()
    size = (200, 150)
    pixels, primitives, view, camera = render_view(gl, "projection_spray_stencil", sim, size, show_frustum=False)
    assert primitives == sum(len(d.mesh.faces) for d in sim.drawables)

    def pixel(point):
        clip = camera.projection() @ camera.view() @ np.append(point, 1.0)
        x, y = clip[:2] / clip[3]
        return int((x + 1) / 2 * size[0]), int((1 - y) / 2 * size[1])

    x, y = pixel((0.0, 0.0, 0.0))  # the star's centre on the wall
    r, g, b = pixels[y, x].astype(int)
    assert r > 120 and g < 60 and b < 60, pixels[y, x]
    x, y = pixel((1.7, 1.3, 0.0))  # a wall corner the plate shadows: black
    assert pixels[y, x].max() < 40, pixels[y, x]
    assert foreground(pixels, view.background).mean() > 0.05


@pytest.mark.gl
def test_view_mouse_aims_and_keys(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("projection_spray_stencil")
    sim = scene.create(runtime, tex=32, depth_res=32)
    view = create_view(scene, gl, sim)
    camera = view.make_camera()
    camera.aspect = 4 / 3
    clip = camera.projection() @ camera.view() @ np.array([0.5, 0.3, 0.0, 1.0])  # a point on the wall
    u, v = (clip[:2] / clip[3] + 1) / 2
    yaw = camera.yaw
    view.on_drag(camera, u, v, 0.01, 0.0)
    assert sim.params.aim == "mouse" and sim.params.painting
    np.testing.assert_allclose(sim.target, [0.5, 0.3, 0.0], atol=1e-6)
    assert camera.yaw == yaw, "a drag on an object aims, it does not orbit"
    view.on_release(camera)
    assert not sim.params.painting
    view.on_drag(camera, 0.02, 0.98, 0.01, 0.0)  # beside the objects: orbit
    assert camera.yaw != yaw
    sim.step()
    assert sim.state()["guide"][0, ..., 3].max() > 0.5  # released: the guide shows where it points
    view.wider()
    assert sim.params.spray_angle == 35.0
    view.farther()
    assert sim.params.spray_range == 37.5
    view.next_aim()
    assert sim.params.aim == "orbit" and sim.params.painting
    sim.step()
    view.clear()
    assert np.all(sim.state()["canvas"] == np.float32(sim.params.clear_color))


def test_cli_run_writes_the_spec_arrays(runtime, capsys, tmp_path):
    out, png, glb = tmp_path / "x.npz", tmp_path / "x.png", tmp_path / "x.glb"
    code, text = run_cli(
        capsys, "run", "projection_spray", "--steps", "4", "--set", "tex=32", "depth_res=32",
        "--out", str(out), "--png", str(png), "--mesh", str(glb), "--png-size", "160x120",
    )  # fmt: skip
    assert code == 0, text
    data = np.load(out)
    assert data["canvas"].shape == data["guide"].shape == data["pos_tex"].shape == (2, 32, 32, 4)
    assert data["nrm_tex"].shape == (2, 32, 32, 4) and data["depth_map"].shape == (32, 32)
    assert data["spray_pose"].shape == (4, 4, 4) and data["aim_points"].shape == (4, 3)
    assert data["colors"].shape == (4, 4) and data["o2w"].shape == (4, 2, 4, 4)
    assert (data["canvas"][..., :3] > 0).any() and (data["guide"][..., 3] > 0).any()
    import trimesh

    loaded = trimesh.load(glb, force="mesh")
    assert len(loaded.faces) == sum(
        len(d.mesh.faces) for d in get("projection_spray").create(runtime, tex=32).drawables
    )
    assert loaded.visual.material.baseColorTexture.size == (64, 32)
    assert png.stat().st_size > 1000


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind):
    for skip in (True, False):
        sim = Simulation(oclgrind, Params(tex=16, depth_res=16, shape_res=16, skip_tiles=skip), seed=0)
        sim.step()  # SprayDepthClear, SprayDepthBoxes, SprayDepth, SprayDraw, EdgeThicken
        np.testing.assert_array_equal(sim.depth.get(), serial_depth(sim))  # SprayDepth_serial
        sim.update(painting=False)
        sim.step()  # SprayGuide, EdgeThicken on the guide
        state = sim.state()
        assert np.isfinite(state["canvas"]).all() and (state["paint"][..., :3] > 0).any()
        rgba8 = sim.texture_rgba8(0, "canvas")  # CanvasToRGBA8
        np.testing.assert_array_equal(rgba8, np.round(np.clip(state["canvas"][0], 0, 1) * np.float32(255)))
