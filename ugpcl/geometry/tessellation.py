"""The tessellation chapter's host side (vol.4 ch.6 "Tessellation & Displacement"; docs/chapters/17-tessellation.md):
the sample scene FuidTessellation (sic) (Unity's built-in Plane, its transform, the camera and the light) and the
formulas of the GLSL tessellation stages in numpy, for the headless state and the tests: ``tess_factors`` (the TCS:
Unity's UnityEdgeLengthBasedTessCull for the scene camera), ``displace_plane_grid`` (a uniform grid displaced as the
TES displaces its vertices) and ``fractional_odd_triangles`` (what the fixed tessellator makes of a level)."""

from __future__ import annotations

import math

import numpy as np

from .transforms import euler_matrix, perspective

# {{{ the scene: Unity's built-in Plane, its transform, the camera and the light of FuidTessellation (sic)

PLANE_QUADS = 10
"""Unity's Plane: 10 x 10 quads of 1 unit on x, z in [-5, 5] (11 x 11 vertices, 200 triangles)."""
PLANE_POSITION = (0.0, 1.23, -2.18)
PLANE_EULER = (48.0, 180.0, 0.0)
"""Plane transform in the scene (degrees, Unity's order: z, then x, then y); world normal (0, 0.669, -0.743)."""
CAMERA_POSITION = (0.0, 0.0, -10.0)
"""Scene camera: at (0, 0, -10) looking along +z, vertical FOV 60, clip planes 0.3 and 1000 (Unity's defaults)."""
CAMERA_FOV, CAMERA_NEAR, CAMERA_FAR = 60.0, 0.3, 1000.0
LIGHT_EULER = (80.0, 0.0, 0.0)
"""Directional light rotation; it shines along (0, -0.985, 0.174) with white colour x intensity LIGHT_INTENSITY."""
LIGHT_INTENSITY = 3.2
MAX_TESS_LEVEL = 64.0
"""GL_MAX_TESS_GEN_LEVEL's guaranteed minimum (D3D11: 64); fractional_odd spacing uses up to 63 segments."""


def plane_model() -> np.ndarray:
    """Object-to-world matrix of the plane (scale 1)."""
    model = np.identity(4)
    model[:3, :3] = euler_matrix(*PLANE_EULER)[:3, :3]
    model[:3, 3] = PLANE_POSITION
    return model


def light_direction() -> np.ndarray:
    """Direction the light travels (its forward axis), world space."""
    return euler_matrix(*LIGHT_EULER)[:3, :3] @ np.array([0.0, 0.0, 1.0])


def plane_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Unity's Plane: vertices (121, 12) float32 = position xyz, normal xyz, tangent xyzw, uv; triangles (200, 3).

    uv = ((5 - x)/10, (5 - z)/10): Unity's plane maps its texture opposite to x and z (a texture on an unrotated
    Plane reads upside down), which is why the scene turns it 180 degrees about y; the painting then reads upright
    and lands near the cursor. The tangent follows +u; the normal is +y."""
    n = PLANE_QUADS + 1
    z, x = np.meshgrid(np.linspace(5.0, -5.0, n), np.linspace(5.0, -5.0, n), indexing="ij")  # row j: v = j/10
    vertices = np.zeros((n * n, 12), np.float32)
    vertices[:, 0], vertices[:, 2] = x.ravel(), z.ravel()
    vertices[:, 4] = 1.0  # normal +y
    vertices[:, 6], vertices[:, 9] = -1.0, -1.0  # tangent = d(position)/du = -x; w = -1: binormal = +v = -z
    vertices[:, 10], vertices[:, 11] = (5.0 - x.ravel()) / 10.0, (5.0 - z.ravel()) / 10.0
    triangles = []
    for j in range(PLANE_QUADS):
        for i in range(PLANE_QUADS):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            triangles += [(a, c, b), (b, c, d)]
    return vertices, np.asarray(triangles, np.int32)


def scene_camera(aspect: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(view, projection, eye) of the scene camera: Unity's left-handed world kept, z mirrored into GL's eye space
    (eye space = (x - cx, y - cy, -(z - cz)) since the camera looks along +z)."""
    view = np.diag([1.0, 1.0, -1.0, 1.0])
    view[:3, 3] = -view[:3, :3] @ np.asarray(CAMERA_POSITION)
    return view, perspective(CAMERA_FOV, aspect, CAMERA_NEAR, CAMERA_FAR), np.asarray(CAMERA_POSITION, float)


# }}}

# {{{ the tessellation formulas in numpy (what the TCS and TES compute)


def frustum_side_planes(view_proj: np.ndarray) -> np.ndarray:
    """Left, right, bottom, top planes (a, b, c, d) of a view-projection matrix, inward, |(a, b, c)| = 1 (Unity's
    unity_CameraWorldClipPlanes[0..3]); a point is inside where a*x + b*y + c*z + d >= 0."""
    m = np.asarray(view_proj, float)
    planes = np.array([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1]])
    return planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)


def edge_factor(a: np.ndarray, b: np.ndarray, eye, screen_height: float, edge_length: float) -> np.ndarray:
    """UnityCalcEdgeTessFactor: max(|a - b| * screen height / (edge length * distance of the midpoint), 1)."""
    length = np.linalg.norm(a - b, axis=-1)
    distance = np.linalg.norm(0.5 * (a + b) - np.asarray(eye), axis=-1)
    return np.maximum(length * screen_height / (edge_length * distance), 1.0)


def tess_factors(corners: np.ndarray, eye, view_proj, screen_height: float, edge_length: float, displacement: float):
    """UnityEdgeLengthBasedTessCull per triangle: corners (T, 3, 3) world space -> (T, 4) = outer[0..2] (edge
    opposite each corner), inner; all 0 when the triangle lies farther than 1.5 * displacement outside one side
    plane of the frustum."""
    p0, p1, p2 = corners[:, 0], corners[:, 1], corners[:, 2]
    out = np.zeros((len(corners), 4))
    out[:, 0] = edge_factor(p1, p2, eye, screen_height, edge_length)
    out[:, 1] = edge_factor(p2, p0, eye, screen_height, edge_length)
    out[:, 2] = edge_factor(p0, p1, eye, screen_height, edge_length)
    out[:, 3] = out[:, :3].mean(axis=1)
    planes = frustum_side_planes(view_proj)
    distances = np.einsum("tkc,pc->tkp", corners, planes[:, :3]) + planes[:, 3]  # (T, corner, plane)
    culled = np.any(np.all(distances < -1.5 * displacement, axis=1), axis=1)
    out[culled] = 0.0
    return out


def sample_texture(texture: np.ndarray, uv: np.ndarray, linear: bool) -> np.ndarray:
    """GL texture lookup with CLAMP_TO_EDGE of an (h, w) array (row 0 = v near 0): LINEAR (bilinear between texel
    centres at (i + 0.5)/w) or NEAREST (the original's Point filter)."""
    h, w = texture.shape
    t = np.asarray(texture, np.float64)
    x, y = uv[..., 0] * w - 0.5, uv[..., 1] * h - 0.5
    if not linear:
        i = np.clip(np.floor(uv[..., 0] * w).astype(int), 0, w - 1)
        j = np.clip(np.floor(uv[..., 1] * h).astype(int), 0, h - 1)
        return t[j, i]
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0

    def tap(i, j):
        return t[np.clip(j, 0, h - 1), np.clip(i, 0, w - 1)]

    return (1 - fy) * ((1 - fx) * tap(x0, y0) + fx * tap(x0 + 1, y0)) + fy * (
        (1 - fx) * tap(x0, y0 + 1) + fx * tap(x0 + 1, y0 + 1)
    )


def displace_plane_grid(
    density: np.ndarray, level: int, displacement: float, negative: bool = False, linear: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plane as a uniform (10*level + 1)^2 grid displaced as the TES displaces its vertices: p = p0 + n * d,
    d = density(uv) * displacement (subtracted when negative). Returns world-space vertices (V, 3), triangles (T, 3)
    and the undisplaced world normal (3,)."""
    n = PLANE_QUADS * level + 1
    z, x = np.meshgrid(np.linspace(5.0, -5.0, n), np.linspace(5.0, -5.0, n), indexing="ij")
    uv = np.stack([(5.0 - x) / 10.0, (5.0 - z) / 10.0], axis=-1)
    d = sample_texture(density, uv, linear) * displacement * (-1.0 if negative else 1.0)
    local = np.stack([x, d, z], axis=-1).reshape(-1, 3)  # the normal is +y in object space
    model = plane_model()
    world = local @ model[:3, :3].T + model[:3, 3]
    j, i = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a, b, c, e = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
    triangles = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3), np.stack([b, c, e], -1).reshape(-1, 3)])
    return world.astype(np.float32), triangles.astype(np.int32), model[:3, :3] @ np.array([0.0, 1.0, 0.0])


def plane_corners() -> np.ndarray:
    """World-space corners (200, 3, 3) of the plane's triangles (what the TCS's p0, p1, p2 are)."""
    vertices, triangles = plane_mesh()
    model = plane_model()
    world = vertices[:, :3].astype(np.float64) @ model[:3, :3].T + model[:3, 3]
    return world[triangles]


def fractional_odd_triangles(level: float) -> int:
    """Triangles a triangle patch becomes with every level = ``level`` under fractional_odd spacing: m = the odd
    integer >= level (1..63) segments per edge -> (3 m^2 - 1) / 2 triangles; level <= 0 discards the patch."""
    if level <= 0:
        return 0
    m = min(63, max(1, math.ceil(level)))
    m += 1 - m % 2
    return (3 * m * m - 1) // 2


# }}}
