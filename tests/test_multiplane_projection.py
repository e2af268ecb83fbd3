"""MultiPlane projection (vol.1 ch.9; docs/chapters/09-multiplane-projection.md): the face cameras against the
chapter's formulas, a golden table of its numbers and glm.frustum; every direction hits one face; the kernels
against a numpy ray-marcher; the seamless composite; the mesh; the CLI; the view; Oclgrind."""

from __future__ import annotations

import math

import glm
import numpy as np
import pytest
from helpers import foreground, run_cli
from scipy.ndimage import maximum_filter, minimum_filter

from ugpcl.geometry.mesh import is_watertight, normals_agree_with_winding, signed_volume, weld
from ugpcl.geometry.multiplane_projection import (
    SHAPE_DTYPE,
    WORLD_DTYPE,
    face_cameras,
    lens_shift_projection,
    world_record,
)
from ugpcl.registry import get
from ugpcl.scenes.multiplane_projection import MARCH_STEPS, MAX_DISTANCE, SURFACE_EPSILON, Params, Simulation

# {{{ the room, written out: Unity axes, the book's face order, then the ceiling

ROOM = (20.0, 5.0, 10.0)
FACE_TABLE = {  # name: (F, U, R, (W, H), distance from the room centre)
    "Front": ((0, 0, 1), (0, 1, 0), (1, 0, 0), (20, 5), 5.0),
    "Right": ((1, 0, 0), (0, 1, 0), (0, 0, -1), (10, 5), 10.0),
    "Back": ((0, 0, -1), (0, 1, 0), (-1, 0, 0), (20, 5), 5.0),
    "Left": ((-1, 0, 0), (0, 1, 0), (0, 0, 1), (10, 5), 10.0),
    "Bottom": ((0, -1, 0), (0, 0, 1), (1, 0, 0), (20, 10), 2.5),
    "Top": ((0, 1, 0), (0, 0, -1), (1, 0, 0), (20, 10), 2.5),
}
NAMES = list(FACE_TABLE)
F, U, R = (np.array([FACE_TABLE[n][i] for n in NAMES], float) for i in range(3))
SIZE = np.array([FACE_TABLE[n][3] for n in NAMES], float)
DIST = np.array([FACE_TABLE[n][4] for n in NAMES])
NEAR = 0.3  # Unity's default near plane; far = 1000 d (the sample's CameraGenerator)


def window(eye_center: np.ndarray, k: int) -> tuple[float, float, float]:
    """(d, cx, cy) of face k seen from the eye (metres from the room centre): v = C_k - E along F, R, U."""
    v = F[k] * DIST[k] - eye_center
    return float(v @ F[k]), float(v @ R[k]), float(v @ U[k])


def random_eyes(rng, n: int, margin: float = 0.1) -> np.ndarray:
    half = np.array(ROOM) / 2 - margin
    return rng.uniform(-half, half, (n, 3))


def make(runtime, seed: int = 0, **overrides) -> Simulation:
    return Simulation(runtime, Params(**overrides), seed)


# }}}

# {{{ layout


def test_struct_mirrors_are_float4_records():
    # Shape and World of multiplane_projection.cl hold only float4 fields: no padding to mirror
    assert SHAPE_DTYPE.itemsize == 3 * 16 and WORLD_DTYPE.itemsize == 8 * 16


def test_face_order_and_bases_are_the_specs(runtime):
    c = make(runtime, faces=6, face_resolution=(4, 2), view_resolution=(2, 2)).cameras
    assert c.names == tuple(NAMES)
    np.testing.assert_array_equal(c.basis[:, 0], R)
    np.testing.assert_array_equal(c.basis[:, 1], U)
    np.testing.assert_array_equal(c.basis[:, 2], F)
    np.testing.assert_array_equal(c.size, SIZE)


# }}}

# {{{ the face cameras


GOLDEN = {  # spec section 5: E = (2, -1, 1) from the room centre: d, vFOV (degrees), shift
    "Front": (4.0, 64.011, (-0.2, 0.4)),
    "Right": (8.0, 34.708, (0.2, 0.4)),
    "Back": (6.0, 45.240, (0.2, 0.4)),
    "Left": (12.0, 23.537, (-0.2, 0.4)),
    "Bottom": (1.5, 146.602, (-0.2, -0.2)),
}
GOLDEN_CENTRE = {"Front": (5, 53.130, 4), "Right": (10, 28.072, 2), "Back": (5, 53.130, 4), "Left": (10, 28.072, 2)}
GOLDEN_CENTRE["Bottom"] = (2.5, 126.870, 2)


def test_golden_table_at_the_centre_and_off_centre(runtime):
    centre = make(runtime, eye=(0.0, 2.5, 0.0), face_resolution=(4, 2), view_resolution=(2, 2)).cameras
    moved = make(runtime, eye=(2.0, 1.5, 1.0), face_resolution=(4, 2), view_resolution=(2, 2)).cameras
    for k, name in enumerate(centre.names):
        d, fov, aspect = GOLDEN_CENTRE[name]
        assert centre.distance[k] == pytest.approx(d, abs=1e-9)
        assert centre.vfov_deg[k] == pytest.approx(fov, abs=1e-3), name
        assert centre.aspect[k] == pytest.approx(aspect, abs=1e-12)
        np.testing.assert_allclose(centre.shift[k], 0.0, atol=1e-12)
        d, fov, shift = GOLDEN[name]
        assert moved.distance[k] == pytest.approx(d, abs=1e-9), name
        assert moved.vfov_deg[k] == pytest.approx(fov, abs=1e-3), name
        np.testing.assert_allclose(moved.shift[k], shift, atol=1e-6, err_msg=name)
        # the matrix entries the book writes: [0,2], [1,2] = shift, [1,1] = 1 / tan(vFOV / 2)
        np.testing.assert_allclose(moved.proj[k][[0, 1], [2, 2]], shift, atol=1e-6, err_msg=name)
        assert moved.proj[k][1, 1] == pytest.approx(1 / math.tan(math.radians(moved.vfov_deg[k]) / 2), rel=1e-9)


def book_projection(face_size, position_offset, face_distance: float, near: float, far: float) -> np.ndarray:
    """A face camera's projection matrix as the chapter makes it, with nothing of ugpcl. Listing 9.1: aspect =
    faceSize.x / faceSize.y, fieldOfView = 2 Atan2(faceSize.y * 0.5, distance) * Rad2Deg, with distance from the
    eye to the face (faceDistance + positionOffset.z, as the sample tracks the eye). Camera.projectionMatrix of that
    camera, from the conditions of section 9.3: the view looks down -z and C_w = -V_z (Proj[3,2] = -1); the
    upper-right corner N of the near plane lands on NDC x = y = 1 (Proj[0,0] = N_z / N_x, Proj[1,1] = N_z / N_y with
    the near distance for N_z); NDC z = C_z / C_w maps N_z to -1 and F_z to 1 (Proj[2,2], Proj[2,3] solved from those
    two equations here, not copied: the printed system divides by N_z and F_z instead of C_w = -V_z, so the printed
    (F_z + N_z) / (F_z - N_z) and -2 F_z N_z / (F_z - N_z) come out with the opposite sign, 1.00015 and 0.60005 for
    n = 0.3, f = 4000, where Unity's OpenGL-style matrix holds -1.00015 and -0.60005). Listing 9.2: shift =
    (positionOffset.x / faceSize.x, positionOffset.y / faceSize.y) * 2 into Proj[0,2], Proj[1,2]."""
    width, height = face_size
    distance = face_distance + position_offset[2]
    aspect = width / height  # Listing 9.1
    field_of_view = 2.0 * math.atan2(height * 0.5, distance) * (180.0 / math.pi)
    half_height = near * math.tan(math.radians(field_of_view) / 2)  # N = (half_height * aspect, half_height, -near)
    proj = np.zeros((4, 4))
    proj[0, 0] = near / (half_height * aspect)  # N_x / C_w = 1
    proj[1, 1] = near / half_height  # N_y / C_w = 1
    n_z, f_z = -near, -far
    # (a V_z + b) / (-V_z) = -1 at V_z = N_z and +1 at F_z: a N_z + b = N_z, a F_z + b = -F_z
    proj[2, 2], proj[2, 3] = np.linalg.solve([[n_z, 1.0], [f_z, 1.0]], [n_z, -f_z])
    proj[3, 2] = -1.0
    shift = np.array([position_offset[0] / width, position_offset[1] / height]) * 2.0  # Listing 9.2
    proj[0, 2], proj[1, 2] = shift
    return proj


def test_projection_equals_glm_frustum_and_the_books_listings_for_random_eyes(seed):
    rng = np.random.default_rng(seed)
    eyes = random_eyes(rng, 2_000)  # 12,000 face matrices: any formula error shows in the first few
    worst_glm = worst_book = worst_helper = 0.0
    for eye in eyes:
        cameras = face_cameras(ROOM, eye, 6)
        proj = cameras.proj
        for k in range(6):
            d, cx, cy = window(eye, k)
            (w, h), far = SIZE[k], 1000 * d
            bounds = (
                NEAR * (cx - w / 2) / d,
                NEAR * (cx + w / 2) / d,
                NEAR * (cy - h / 2) / d,
                NEAR * (cy + h / 2) / d,
            )
            expected = np.array(glm.frustum(*bounds, NEAR, far))  # numpy gets glm's rows (float32)
            worst_glm = max(worst_glm, float((np.abs(proj[k] - expected) / np.maximum(np.abs(expected), 1)).max()))
            # the sample's positionOffset = inverse(faceRotation) * -eye: the eye's offset seen in the face's axes
            position_offset = -np.array([eye @ R[k], eye @ U[k], eye @ F[k]])
            book = book_projection(SIZE[k], position_offset, DIST[k], NEAR, far)
            worst_book = max(worst_book, float(np.abs(proj[k] - book).max()))
            # the module's own helper of the two listings (not what the scene draws with) agrees as well
            fov = math.degrees(2 * math.atan2(h / 2, d))
            helper = lens_shift_projection(fov, w / h, 2 * position_offset[:2] / (w, h), NEAR, far)
            worst_helper = max(worst_helper, float(np.abs(helper - book).max()))
    # glm computes in float32 (a few ulp: 1.2e-6 absolute on entries near 4), so 1e-6 relative to entries >= 1;
    # ours and the book's form are float64 and agree to rounding
    assert worst_glm < 1e-6 and worst_book < 1e-12 and worst_helper < 1e-12, (worst_glm, worst_book, worst_helper)


def test_face_corners_project_to_the_ndc_corners(seed):
    rng = np.random.default_rng(seed)
    for eye in random_eyes(rng, 200):
        scale = 20.0  # the room drawn into the CG world at the sample's scale, centred on the CG origin
        cameras = face_cameras(ROOM, eye, 6, eye_cg=scale * eye)
        for k in range(6):
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                corner = F[k] * DIST[k] + R[k] * a * SIZE[k, 0] / 2 + U[k] * b * SIZE[k, 1] / 2
                clip = cameras.proj[k] @ cameras.view[k] @ np.append(scale * corner, 1.0)
                np.testing.assert_allclose(clip[:2] / clip[3], (a, b), atol=1e-9)
                assert -1 <= clip[2] / clip[3] <= 1  # between the near and far planes


def test_recomputing_for_the_same_eye_is_identical(runtime):
    sim = make(runtime, eye=(1.0, 2.0, -3.0), face_resolution=(4, 2), view_resolution=(2, 2))
    first = sim.cameras.proj.copy()
    sim.update(eye=(-4.0, 0.5, 2.0))
    sim.update(eye=(1.0, 2.0, -3.0))
    np.testing.assert_array_equal(sim.cameras.proj, first)  # stateless: made from scratch every time


@pytest.mark.parametrize("faces", [5, 6])
def test_every_direction_from_the_eye_hits_exactly_one_face(faces, seed):
    """With the ceiling every direction lands in exactly one face's NDC square; without it, exactly the upward
    directions that leave through the ceiling land in none."""
    rng = np.random.default_rng(seed + faces)
    for eye in random_eyes(rng, 20):
        cameras = face_cameras(ROOM, eye, faces, eye_cg=eye)
        directions = rng.normal(size=(5000, 3))
        points = np.column_stack([eye + directions, np.ones(len(directions))])
        hits = np.zeros(len(directions), int)
        for k in range(faces):
            clip = points @ (cameras.proj[k] @ cameras.view[k]).T
            ndc = clip[:, :2] / clip[:, 3:]
            hits += (clip[:, 3] > 0) & (np.abs(ndc) < 1).all(axis=1)
        # the exit face by ray-box intersection (reference): the smallest positive t over the six planes
        towards = directions @ F.T
        t = np.where(towards > 0, (DIST - F @ eye) / np.where(towards > 0, towards, 1), np.inf)
        exit_face = t.argmin(axis=1)
        np.testing.assert_array_equal(hits, (exit_face < faces).astype(int))
        if faces == 6:
            assert (hits == 1).all()


# }}}

# {{{ kernels vs a numpy ray-marcher (float64, written from the chapter's camera model and the kernel's world)


def pixel_directions(width: int, height: int, basis: np.ndarray, lens) -> np.ndarray:
    """(H, W, 3): NDC of each pixel centre (row 0 at the bottom) through ((x + P02)/P00, (y + P12)/P11, -1)."""
    p00, p02, p11, p12 = lens
    x = 2 * (np.arange(width) + 0.5) / width - 1
    y = 2 * (np.arange(height) + 0.5) / height - 1
    vx, vy = (x[None, :] + p02) / p00, (y[:, None] + p12) / p11
    vx, vy = np.broadcast_to(vx, (height, width)), np.broadcast_to(vy, (height, width))
    return vx[..., None] * basis[0] + vy[..., None] * basis[1] + basis[2]


def trace_reference(shapes: np.ndarray, world: np.ndarray, origin, directions: np.ndarray) -> np.ndarray:
    """RGBA8 colours of rays (N, 3): sphere tracing of the shapes up to the analytic ground, sun + ambient, fog."""
    o = np.asarray(origin, float)
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    ground_y, checker, fog = world["ground"][0, :3].astype(float)
    centre, size = shapes["center"].astype(float), shapes["size"].astype(float)
    going_down = (d[:, 1] < 0) & (o[1] > ground_y)
    t_ground = np.where(going_down, (ground_y - o[1]) / np.where(going_down, d[:, 1], -1), np.inf)
    t_limit = np.minimum(t_ground, MAX_DISTANCE)
    t, hit = np.zeros(len(d)), np.full(len(d), -1)
    active = np.ones(len(d), bool)
    for _ in range(MARCH_STEPS):
        active &= t < t_limit
        p = o + t[:, None] * d
        q = p[:, None, :] - centre[None, :, :3]
        box = np.abs(q) - size[None, :, :3]
        dist = np.where(
            centre[:, 3] == 0,
            np.linalg.norm(q, axis=2) - size[:, 0],
            np.linalg.norm(np.maximum(box, 0), axis=2) + np.minimum(box.max(axis=2), 0),
        )
        nearest, which = dist.min(axis=1), dist.argmin(axis=1)
        newly = active & (nearest < SURFACE_EPSILON)
        hit[newly] = which[newly]
        active &= ~newly
        t = np.where(active, t + nearest, t)
    horizon, zenith = world["sky_horizon"][0, :3], world["sky_zenith"][0, :3]

    def sky(dirs):
        return horizon + (zenith - horizon) * np.sqrt(np.clip(dirs[:, 1:2], 0, 1))

    on_shape, on_ground = hit >= 0, (hit < 0) & (t_ground < MAX_DISTANCE)
    t = np.where(on_shape, t, t_ground)
    p = o + np.where(np.isfinite(t), t, 0)[:, None] * d
    normal = np.tile([0.0, 1.0, 0.0], (len(d), 1))
    albedo = np.zeros((len(d), 3))
    k = math.pi / checker
    pattern = 0.5 + 0.5 * np.sin(k * p[:, 0]) * np.sin(k * p[:, 2])
    albedo[on_ground] = world["ground_dark"][0, :3] + np.outer(
        pattern[on_ground], world["ground_light"][0, :3] - world["ground_dark"][0, :3]
    )
    for i in np.flatnonzero(on_shape):
        s = hit[i]
        q = p[i] - centre[s, :3]
        if centre[s, 3] == 0:
            normal[i] = q / np.linalg.norm(q)
        else:
            axis = int(np.argmax(np.abs(q / size[s, :3])))
            normal[i] = np.eye(3)[axis] * np.sign(q[axis])
        albedo[i] = shapes["color"][s, :3]
    diffuse = np.maximum(normal @ -world["sun_direction"][0, :3], 0)[:, None]
    lit = albedo * (world["ambient"][0, :3] + world["sun_color"][0, :3] * diffuse)
    fogged = lit + (sky(d) - lit) * (1 - np.exp(-np.where(np.isfinite(t), t, 0) / fog))[:, None]
    color = np.where((on_shape | on_ground)[:, None], fogged, sky(d))
    return np.clip(np.rint(color * 255), 0, 255).astype(np.uint8)


def ambiguous_rays(shapes, world, origin, directions, colors, tolerance: int = 2) -> np.ndarray:
    """Rays whose colour changes when the direction moves by 1e-5: a silhouette or a step cap; float32 and
    float64 may legitimately disagree there."""
    rng = np.random.default_rng(0)
    out = np.zeros(len(directions), bool)
    for _ in range(4):
        nudged = (
            directions + rng.normal(scale=1e-5, size=directions.shape) * np.linalg.norm(directions, axis=1)[:, None]
        )
        out |= np.abs(trace_reference(shapes, world, origin, nudged).astype(int) - colors).max(axis=1) > tolerance
    return out


def assert_image_matches(actual: np.ndarray, expected: np.ndarray, ambiguous: np.ndarray, what: str) -> None:
    """RGB within 2 of the reference (float32 against float64 shading) everywhere but at ambiguous rays."""
    bad = (np.abs(actual[:, :3].astype(int) - expected.astype(int)).max(axis=1) > 2) & ~ambiguous
    first = np.flatnonzero(bad)[:1]
    assert not bad.any(), f"{what}: {bad.sum()} pixels differ; first {first}: {actual[first]} vs {expected[first]}"
    assert (actual[:, 3] == 255).all()
    assert ambiguous.mean() < 0.1, "too few pixels checked"


@pytest.mark.parametrize("eye", [(0.0, 1.46, 0.0), (-7.0, 4.0, 3.5)])
def test_render_faces_matches_reference(runtime, eye, seed):
    sim = make(runtime, seed, eye=eye, faces=6, face_resolution=(12, 6), view_resolution=(2, 2))
    sim.render_faces()
    images = sim.face_buffer.get()
    world = world_record(sim.params.ground_y)
    eye_cg = np.asarray(eye) * sim.params.world_scale
    for k in range(6):
        d, cx, cy = window(np.asarray(eye) - (0, 2.5, 0), k)
        w, h = SIZE[k]
        lens = (2 * d / w, 2 * cx / w, 2 * d / h, 2 * cy / h)  # P00, P02, P11, P12 of the lens-shift matrix
        directions = pixel_directions(12, 6, np.array([R[k], U[k], F[k]]), lens).reshape(-1, 3)
        expected = trace_reference(sim.shapes, world, eye_cg, directions)
        ambiguous = ambiguous_rays(sim.shapes, world, eye_cg, directions, expected)
        assert_image_matches(images[k].reshape(-1, 4), expected, ambiguous, NAMES[k])


def test_render_eye_direct_matches_reference(runtime, seed):
    sim = make(runtime, seed, view_yaw=-60.0, view_pitch=15.0, view_fov=70.0, view_resolution=(15, 9))
    sim.render_eye_direct()
    yaw, pitch = math.radians(-60.0), math.radians(15.0)
    forward = np.array([math.sin(yaw) * math.cos(pitch), math.sin(pitch), math.cos(yaw) * math.cos(pitch)])
    right = np.array([math.cos(yaw), 0.0, -math.sin(yaw)])
    up = np.cross(forward, right)  # Unity's left-handed frame: R = U x F, so U = F x R
    focal = 1 / math.tan(math.radians(35.0))
    directions = pixel_directions(15, 9, np.array([right, up, forward]), (focal * 9 / 15, 0, focal, 0))
    world, eye_cg = world_record(sim.params.ground_y), sim.eye_cg
    expected = trace_reference(sim.shapes, world, eye_cg, directions.reshape(-1, 3))
    ambiguous = ambiguous_rays(sim.shapes, world, eye_cg, directions.reshape(-1, 3), expected)
    assert_image_matches(sim.direct_buffer.get().reshape(-1, 4), expected, ambiguous, "eye view")


def test_composite_eye_view_matches_reference(runtime, seed):
    """CompositeEyeView on made-up face images: exit face by ray-box intersection, uv on that wall, bilinear."""
    eye = np.array([3.0, 1.0, -2.0])
    sim = make(runtime, seed, eye=tuple(eye), faces=5, face_resolution=(7, 5), view_resolution=(21, 17))
    rng = np.random.default_rng(seed)
    faces = rng.integers(0, 256, (5, 5, 7, 4), dtype=np.uint8)
    sim.face_buffer.set(faces)
    sim.composite_eye_view()
    got = sim.composite_buffer.get().reshape(-1, 4).astype(int)
    basis, lens = sim.eye_view_camera()
    directions = pixel_directions(21, 17, basis, lens).reshape(-1, 3)
    e = eye - (0, 2.5, 0)
    towards = directions @ F.T
    t = np.where(towards > 0, (DIST - F @ e) / np.where(towards > 0, towards, 1), np.inf)
    k = t.argmin(axis=1)
    hit = e + t.min(axis=1)[:, None] * directions - F[k] * DIST[k][:, None]
    u = np.einsum("ij,ij->i", hit, R[k]) / SIZE[k, 0] + 0.5
    v = np.einsum("ij,ij->i", hit, U[k]) / SIZE[k, 1] + 0.5
    x, y = np.clip(u * 7 - 0.5, 0, 6), np.clip(v * 5 - 0.5, 0, 4)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    x1, y1, fx, fy = np.minimum(x0 + 1, 6), np.minimum(y0 + 1, 4), (x - x0)[:, None], (y - y0)[:, None]
    kk = np.minimum(k, 4)
    image = faces.astype(float)
    bottom = image[kk, y0, x0] * (1 - fx) + image[kk, y0, x1] * fx
    top = image[kk, y1, x0] * (1 - fx) + image[kk, y1, x1] * fx
    expected = np.rint(bottom * (1 - fy) + top * fy)
    expected[k == 5] = (0, 0, 0, 255)  # through the missing ceiling
    assert (k == 5).any() and (k < 5).sum() > 100
    # 1: rounding of float32 against float64 bilinear weights
    assert np.abs(got - expected).max() <= 1, np.argwhere(np.abs(got - expected) > 1)[:3]


# }}}

# {{{ the seamless composite


def test_composite_through_the_room_equals_the_direct_view(runtime, seed):
    """From the eye, the room's faces showing their images look like the world itself (section 9.2). Only
    resampling differs: bilinear filtering of 256x128 face images against point samples of the 96x96 view."""
    sim = make(runtime, seed, eye=(4.0, 2.2, -2.5), faces=6, face_resolution=(256, 128), view_resolution=(96, 96))
    state = sim.state()
    direct, composite = (state[k][..., :3].astype(int) for k in ("direct_view", "composite_view"))
    diff = np.abs(direct - composite)
    assert diff.mean() < 2.0, diff.mean()
    assert np.percentile(diff, 99) < 24
    # a resampled pixel lies within the range of the direct view's 3x3 neighbourhood (+ a little for the filter),
    # but for sub-pixel features one of the two samplings catches and the other misses (8 of 9216 pixels here:
    # one-pixel-wide box sides)
    low = minimum_filter(direct, size=(3, 3, 1), mode="nearest")
    high = maximum_filter(direct, size=(3, 3, 1), mode="nearest")
    outside = np.maximum(low - composite, composite - high).max(axis=-1)
    assert (outside > 12).mean() < 0.002, np.argwhere(outside > 12)[:5]


def test_without_the_ceiling_only_upward_rays_through_it_are_black(runtime, seed):
    sim = make(runtime, seed, faces=5, view_pitch=45.0, face_resolution=(64, 32), view_resolution=(48, 48))
    composite = sim.state()["composite_view"][..., :3].reshape(-1, 3)
    basis, lens = sim.eye_view_camera()
    directions = pixel_directions(48, 48, basis, lens).reshape(-1, 3)
    towards = directions @ F.T
    t = np.where(towards > 0, (DIST - F @ sim.eye_center) / np.where(towards > 0, towards, 1), np.inf)
    ceiling = t.argmin(axis=1) == 5
    assert 0.1 < ceiling.mean() < 0.9
    assert (composite[ceiling] == 0).all()
    assert (composite[~ceiling].sum(axis=1) > 0).all()


# }}}

# {{{ params, state, mesh, CLI


# ranges and limits at their edges: tests/test_params.py checks them for every field of every scene
@pytest.mark.parametrize(
    "overrides, message",
    [
        (  # a wall, not the floor that test_params's edge case moves to: the margin shown is the smallest
            {"eye": (0.0, 1.0, 5.0)},
            "distance from eye to every face of room_size must be >= 0.05 m, got room_size=.*\\(0, 1, 5\\) \\(0 m\\)$",
        ),
        ({"faces": 4}, "faces must be one of 5\\|6"),
        ({"room_size": (20.0, float("inf"), 10.0)}, "room_size must be a finite number"),
    ],
)
def test_bad_parameters_name_the_field_and_range(overrides, message):
    with pytest.raises(ValueError, match=message):
        Params(**overrides)


def test_state_holds_what_the_page_lists(runtime):
    state = make(runtime, face_resolution=(8, 4), view_resolution=(6, 5)).state()
    assert state["face_images"].shape == (5, 4, 8, 4) and state["face_images"].dtype == np.uint8
    assert state["direct_view"].shape == state["composite_view"].shape == (5, 6, 4)
    assert state["proj"].shape == state["view"].shape == (5, 4, 4) and state["shift"].shape == (5, 2)
    assert list(state["face_names"]) == NAMES[:5]
    np.testing.assert_allclose(state["eye_cg"], np.array([0.0, 1.46, 0.0]) * 20, rtol=1e-6)


@pytest.mark.parametrize("faces", [5, 6])
def test_mesh_is_the_room_seen_from_inside(runtime, faces):
    mesh = make(runtime, faces=faces, face_resolution=(4, 2), view_resolution=(2, 2)).mesh()
    assert mesh.vertices.shape == (4 * faces, 3) and mesh.faces.shape == (2 * faces, 3)
    assert normals_agree_with_winding(mesh) == 1.0
    lower, upper = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    np.testing.assert_allclose(lower, (-10, 0, -5))
    np.testing.assert_allclose(upper, (10, 5 if faces == 6 else 5, 5))
    # normals point into the room (towards its centre), where the images are seen
    to_centre = np.array([0.0, 2.5, 0.0]) - mesh.vertices
    assert (np.einsum("ij,ij->i", mesh.normals, to_centre) > 0).all()
    # the atlas: face k covers u in [k, k + 1] / faces, v in [0, 1]
    face = np.repeat(np.arange(faces), 4)
    assert ((mesh.uvs[:, 0] * faces - face >= -1e-6) & (mesh.uvs[:, 0] * faces - face <= 1 + 1e-6)).all()
    if faces == 6:  # closed, wound inward: the volume comes out negative
        welded = weld(mesh)
        assert is_watertight(welded)
        assert signed_volume(welded) == pytest.approx(-20 * 5 * 10)


def test_mesh_uv_follows_the_face_cameras_right_and_up(runtime):
    """The image's right/up (R, U of the face camera) run along the quad's u/v: no face is mirrored."""
    sim = make(runtime, faces=6, face_resolution=(4, 2), view_resolution=(2, 2))
    mesh = sim.mesh()
    for k in range(6):
        v, uv = mesh.vertices[4 * k : 4 * k + 4].astype(float), mesh.uvs[4 * k : 4 * k + 4].astype(float)
        local = np.column_stack([uv[:, 0] * 6 - k, uv[:, 1]])
        position = (0, 2.5, 0) + F[k] * DIST[k] + np.outer(local[:, 0] - 0.5, R[k] * SIZE[k, 0])
        position += np.outer(local[:, 1] - 0.5, U[k] * SIZE[k, 1])
        np.testing.assert_allclose(v, position, atol=1e-5, err_msg=NAMES[k])


@pytest.mark.parametrize("suffix", [".obj", ".glb"])
def test_cli_run_writes_npz_png_and_mesh(capsys, tmp_path, suffix):
    out, png, mesh = tmp_path / "x.npz", tmp_path / "x.png", tmp_path / f"x{suffix}"
    code, text = run_cli(
        capsys,
        "run",
        "multiplane_projection",
        "--steps",
        "2",
        "--set",
        "face_resolution=32,16",
        "view_resolution=16,16",
        "--out",
        str(out),
        "--png",
        str(png),
        "--png-size",
        "64x48",
        "--mesh",
        str(mesh),
    )
    assert code == 0, text
    data = np.load(out)
    assert data["face_images"].shape == (5, 16, 32, 4) and data["face_images"][..., :3].max() > 0
    assert png.stat().st_size > 0
    import trimesh

    loaded = trimesh.load(mesh, force="mesh", process=False)
    assert len(loaded.faces) == 10


# }}}

# {{{ view


def gl_face_images(view) -> np.ndarray:
    p = view.sim.params
    w, h = p.face_resolution
    return np.stack([np.frombuffer(texture.read(), np.uint8).reshape(h, w, 4) for texture, _ in view.targets])


@pytest.mark.gl
def test_view_face_framebuffers_equal_the_kernels_faces(runtime, gl, seed):
    from ugpcl.viewer.views import create_view

    scene = get("multiplane_projection")
    sim = scene.create(runtime, seed, eye=(-3.0, 3.0, 2.0), faces=6, face_resolution=(96, 48), view_resolution=(4, 4))
    view = create_view(scene, gl, sim)
    view.upload()
    gl_faces = gl_face_images(view)[..., :3].astype(int)
    cl_faces = sim.state()["face_images"][..., :3].astype(int)
    diff = np.abs(gl_faces - cl_faces)
    # rasterised (uv spheres of 48 x 24 segments, no anti-aliasing) against ray-marched: edges and facets only
    assert diff.mean() < 1.0, diff.mean(axis=(1, 2, 3))
    assert (diff.max(axis=-1) > 24).mean() < 0.01


@pytest.mark.gl
def test_view_from_the_eye_is_the_direct_view(runtime, gl, seed):
    sim = get("multiplane_projection").create(
        runtime, seed, eye=(3.0, 2.0, -1.5), faces=6, face_resolution=(256, 128), view_resolution=(64, 64)
    )
    pixels, _, view, _ = render_eye(gl, sim, (64, 64))
    direct = sim.state()["direct_view"][::-1, :, :3].astype(int)  # image rows from the top
    diff = np.abs(pixels.astype(int) - direct)
    assert diff.mean() < 3.0, diff.mean()
    assert np.percentile(diff, 99) < 40


def render_eye(gl, sim, size):
    from helpers import render_view

    return render_view(gl, "multiplane_projection", sim, size, mode="eye")


@pytest.mark.gl
def test_outside_view_shows_the_textured_room(runtime, gl, seed):
    from helpers import render_view

    sim = get("multiplane_projection").create(runtime, seed, face_resolution=(64, 32), view_resolution=(4, 4))
    pixels, primitives, view, camera = render_view(gl, "multiplane_projection", sim, (96, 64))
    mask = foreground(pixels, view.background)
    assert 0.15 < mask.mean() < 0.95
    # the room's centre (floor) projects inside the drawn area; the image corners are background
    clip = camera.projection() @ camera.view() @ np.array([0.0, 0.0, 0.0, 1.0])
    x, y = ((clip[:2] / clip[3]) + 1) / 2 * (96, 64)
    assert mask[int(64 - y), int(x)]
    assert not mask[0, 0] and not mask[-1, -1]
    assert primitives >= 2 * 5  # the five quads (and the lines)


@pytest.mark.gl
def test_view_keys_move_the_eye_and_switch_the_camera(runtime, gl):
    from ugpcl.viewer.views import create_view

    scene = get("multiplane_projection")
    sim = scene.create(runtime, face_resolution=(8, 4), view_resolution=(4, 4), view_yaw=0.0)
    view = create_view(scene, gl, sim)
    view.eye_forward()
    np.testing.assert_allclose(sim.params.eye, (0.0, 1.46, 0.25), atol=1e-9)
    assert sim.cameras.distance[0] == pytest.approx(4.75)  # the front face camera followed at once
    view.eye_right()
    np.testing.assert_allclose(sim.params.eye, (0.25, 1.46, 0.25), atol=1e-9)
    for _ in range(40):
        view.eye_forward()
    assert sim.params.eye[2] == pytest.approx(5.0 - 0.2)  # stopped inside the front wall
    view.toggle_ceiling()
    assert sim.params.faces == 6
    view.next_mode()
    assert view.mode == "eye"
    view.upload()
    assert len(view.targets) == 6
    keys = {k.key for k in view.keys}
    assert {"c", "up", "down", "left", "right", "[", "]", "6", "f"} <= keys


# }}}


@pytest.mark.oclgrind
def test_kernels_on_oclgrind(oclgrind, seed):
    sim = make(oclgrind, seed, faces=6, face_resolution=(5, 3), view_resolution=(4, 3), shape_count=4)
    state = sim.state()  # RenderFaces, RenderEyeDirect, CompositeEyeView
    assert state["face_images"].shape == (6, 3, 5, 4) and (state["face_images"][..., 3] == 255).all()
    assert (state["composite_view"][..., 3] == 255).all()
