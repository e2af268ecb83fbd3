"""Projection spray's host geometry (vol.1 ch.10; docs/chapters/10-projection-spray.md): the presets' paintable
objects (the sample's cube and sphere, the stencil plate with its star cut-out and the wall behind it, the procedural
figure), the spray's shape texture (simplex noise on its rim), its pose and projection matrices, and the blocks of
its depth map that the triangles' boxes cover."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .mesh import Mesh, vertex_normals
from .transforms import perspective, translation
from .uv_atlas import per_triangle_layout, unit_cube, uv_sphere

SPRAY_NEAR = 0.01
"""The spray's near clip plane (the sample sets it in code)."""
OFFSET = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])
"""Clip xyz -> 0.5 xyz + 0.5 w: clip space to the spray's uv (the sample's projector offset)."""


@dataclass
class Drawable:
    """A paintable object: its mesh with a paint layout (uvs), its place, and whether it spins with the Rotater."""

    name: str
    mesh: Mesh
    local: np.ndarray = field(default_factory=lambda: np.identity(4))
    """Object -> parent matrix (uniform scale only: normals go through its 3x3)."""
    rotates: bool = True


@dataclass(frozen=True)
class Preset:
    spray_position: tuple[float, float, float]
    """Start of the spray (aim fixed and mouse), and its orbit's radius and height (aim orbit)."""
    aim_center: tuple[float, float, float]
    """What the spray looks at (aim fixed) and the centre of the aim circle (aim orbit)."""


PRESETS = {
    "cube_sphere": Preset((-4.0, 8.0, -8.0), (0.0, 0.0, 0.0)),  # the sample's spray at (-4, 8, -8)
    "stencil": Preset((0.0, 0.0, -5.0), (0.0, 0.0, 0.0)),
    "figure": Preset((0.0, 1.3, -2.6), (0.0, 0.9, 0.0)),
}
STENCIL_PLATE_Z, STENCIL_PLATE_SIZE = -2.5, 2.4
"""The stencil plate: halfway between the spray (z = -5) and the wall (z = 0), wider than the spray's cone there."""
STAR_RADII, STAR_POINTS = (0.45, 0.2), 5
"""The cut-out: a five-pointed star, outer and inner radius (its shadow on the wall is twice as large)."""
WALL_SIZE = (4.0, 3.0)


# {{{ the presets' objects


def placed(scale: float, offset) -> np.ndarray:
    """The local matrix that scales uniformly by ``scale`` and moves it to ``offset``."""
    return translation(*offset) @ np.diag([scale, scale, scale, 1.0])


def planar_mesh(points2d: np.ndarray, triangles: np.ndarray, z: float) -> Mesh:
    """A flat mesh in the plane z = const facing -z (towards the spray), uvs planar over its bounding box."""
    lo, hi = points2d.min(axis=0), points2d.max(axis=0)
    vertices = np.column_stack([points2d, np.full(len(points2d), z)])
    faces = np.asarray(triangles, np.int64)
    cross = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    faces = np.where((cross[:, 2] > 0)[:, None], faces[:, [0, 2, 1]], faces)  # normal -z
    normals = np.tile([0.0, 0.0, -1.0], (len(points2d), 1))
    return Mesh(vertices, faces, normals, (points2d - lo) / (hi - lo))


def star(outer: float, inner: float, points: int) -> np.ndarray:
    angle = np.pi / 2 + np.arange(2 * points) * np.pi / points
    radius = np.where(np.arange(2 * points) % 2 == 0, outer, inner)
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])


def stencil_plate() -> Mesh:
    """The plate with the star cut out, triangulated by the ear clipper of vol.4 ch.5."""
    from .ear_clipping import triangulate

    h = STENCIL_PLATE_SIZE / 2
    outer = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    result = triangulate([outer, star(*STAR_RADII, STAR_POINTS)])
    return planar_mesh(result.vertices, result.triangles, STENCIL_PLATE_Z)


def wall() -> Mesh:
    w, h = WALL_SIZE[0] / 2, WALL_SIZE[1] / 2
    return planar_mesh(np.array([[-w, -h], [w, -h], [w, h], [-w, h]]), [[0, 1, 2], [0, 2, 3]], 0.0)


def figure_mesh(tex: int, gutter: int) -> Mesh:
    from .skinned_figure import Figure

    vertices, triangles, _ = Figure().mesh()
    mesh = Mesh(vertices, triangles, vertex_normals(vertices, triangles))
    return per_triangle_layout(mesh, tex, gutter)


def island_gutter(tex: int, edge_texels: int) -> int:
    """Texels between an island and its cell's border: 16 or twice the dilation (the sample's lightmap padding),
    at most tex / 24 so that small test textures keep islands of a few texels."""
    return max(1, min(max(16, 2 * edge_texels), tex // 24))


def preset_drawables(preset: str, tex: int, edge_texels: int) -> list[Drawable]:
    """The objects of ``preset`` with paint layouts for ``tex``-texel textures dilated by ``edge_texels``; the figure's
    per-triangle layout raises ValueError when its triangles do not fit the texture."""
    gutter = island_gutter(tex, edge_texels)
    if preset == "cube_sphere":
        cube, sphere = unit_cube(tex, gutter), uv_sphere(tex, gutter)
        return [Drawable("cube", cube, placed(10.0, (0, -5, 0))), Drawable("sphere", sphere, placed(2.0, (0, 1, 0)))]
    if preset == "stencil":
        return [Drawable("wall", wall(), rotates=False), Drawable("plate", stencil_plate(), rotates=False)]
    return [Drawable("figure", figure_mesh(tex, edge_texels // 2 + 1))]


# }}}

# {{{ spray shape and pose


def snoise2d(v: np.ndarray) -> np.ndarray:
    """Ashima's 2-D simplex noise (webgl-noise, MIT; Keijiro's SimplexNoise2D.cginc), about [-1, 1]."""
    c = np.array([0.211324865405187, 0.366025403784439, -0.577350269189626, 0.024390243902439])
    mod289 = lambda x: x - np.floor(x / 289.0) * 289.0  # noqa: E731
    permute = lambda x: mod289((x * 34.0 + 1.0) * x)  # noqa: E731
    i = np.floor(v + (v[..., 0] + v[..., 1])[..., None] * c[1])
    x0 = v - i + (i[..., 0] + i[..., 1])[..., None] * c[0]
    i1 = np.where((x0[..., 0] > x0[..., 1])[..., None], [1.0, 0.0], [0.0, 1.0])
    x1 = x0 + c[0] - i1
    x2 = x0 + c[2]
    i = mod289(i)
    p = permute(
        permute(i[..., 1, None] + np.stack([np.zeros_like(i1[..., 1]), i1[..., 1], np.ones_like(i1[..., 1])], -1))
        + i[..., 0, None]
        + np.stack([np.zeros_like(i1[..., 0]), i1[..., 0], np.ones_like(i1[..., 0])], -1)
    )
    corners = np.stack([x0, x1, x2], -2)
    m = np.maximum(0.5 - np.sum(corners**2, -1), 0.0) ** 4
    x = 2.0 * np.modf(p * c[3])[0] - 1.0
    x = np.where(x < -1.0, x + 2.0, x)  # fract of a negative number
    h = np.abs(x) - 0.5
    a0 = x - np.floor(x + 0.5)
    m *= 1.79284291400159 - 0.85373472095314 * (a0 * a0 + h * h)
    g = a0 * corners[..., 0] + h * corners[..., 1]
    return 130.0 * np.sum(m * g, -1)


SHAPE_BLOCK_TEXELS = 1 << 20
"""Texels of the spray shape computed at a time: the noise's float64 temporaries (about 360 bytes a texel) stay
near 360 MB at any ``shape_res``."""


def spray_shape(res: int, edge: float, freq: float, amp: float) -> np.ndarray:
    """The spray's footprint (the sample's SprayPaintTexGen): rgb = 1, alpha = a soft disc of radius ~0.5 whose rim
    wobbles with simplex noise around the circle; (res, res, 4) float32, alpha 1 at the centre."""
    centres = (np.arange(res) + 0.5) / res - 0.5
    shape = np.ones((res, res, 4), np.float32)
    rows = max(1, SHAPE_BLOCK_TEXELS // res)
    for start in range(0, res, rows):  # each row on its own: blocks of rows give the same texels
        xy = np.stack(np.meshgrid(centres, centres[start : start + rows]), -1)
        d = np.linalg.norm(xy, axis=-1)
        direction = xy / np.maximum(d, 1e-12)[..., None]
        radius = 0.5 - amp + amp * snoise2d(direction * freq)
        lo, hi = radius * (1.0 - edge), radius
        t = np.clip((d - lo) / np.maximum(hi - lo, 1e-12), 0.0, 1.0)
        alpha = np.where(d >= hi, 0.0, 1.0 - t * t * (3.0 - 2.0 * t))
        shape[start : start + rows, :, 3] = np.where(d <= lo, 1.0, alpha)
    return shape


def look_rotation(position, target) -> np.ndarray:
    """Unity's LookAt with world up: the spray's local -> world matrix, local +z towards ``target``."""
    position, target = np.asarray(position, float), np.asarray(target, float)
    forward = target - position
    forward /= np.linalg.norm(forward)
    up = np.array([0.0, 1.0, 0.0])
    right = np.cross(up, forward)
    if np.linalg.norm(right) < 1e-9:  # aiming straight up or down: LookAt is singular, take world +z as up
        right = np.cross([0.0, 0.0, 1.0], forward)
    right /= np.linalg.norm(right)
    m = np.identity(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(forward, right), forward, position
    return m


def box_blocks(boxes: np.ndarray, block: int, blocks_x: int) -> np.ndarray:
    """(n, 2) int32 (item, block) pairs: every ``block`` x ``block`` cell of a grid ``blocks_x`` cells wide that meets
    box k = (x0, y0, x1, y1) (inclusive pixel bounds; x1 < x0 or y1 < y0: empty), block = by * blocks_x + bx, in
    item order and row-major within an item."""
    lo, hi = boxes[:, :2] // block, boxes[:, 2:] // block
    size = np.where((boxes[:, 2:] >= boxes[:, :2]).all(axis=1)[:, None], hi - lo + 1, 0)  # (n, 2) blocks in x, y
    counts = size[:, 0] * size[:, 1]
    item = np.repeat(np.arange(len(boxes)), counts)
    within = np.arange(len(item)) - np.repeat(np.cumsum(counts) - counts, counts)
    x = lo[item, 0] + within % size[item, 0]
    y = lo[item, 1] + within // size[item, 0]
    return np.stack([item, y * blocks_x + x], axis=1).astype(np.int32)


def spray_matrices(pose: np.ndarray, angle: float, spray_range: float) -> tuple[np.ndarray, np.ndarray]:
    """(M_proj, W2D) of a spray at ``pose``: world -> spray uv (Offset P V, V looking down -z) and world -> local."""
    w2d = np.linalg.inv(pose)
    view = np.diag([1.0, 1.0, -1.0, 1.0]) @ w2d
    return OFFSET @ perspective(angle, 1.0, SPRAY_NEAR, spray_range) @ view, w2d


# }}}
