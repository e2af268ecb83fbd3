"""CPU side of vol.1 ch.6 (docs/chapters/06-grass.md): the meshes the geometry shaders run on, the noise maps,
the plane field.

* ``plane_mesh``: Unity's built-in Plane (10x10 units in local XZ, normal +Y, UV 0..1) with ``resolution`` cells
  per side (Unity's has 10). Cell (i, j) with corners a=(i,j), b=(i+1,j), c=(i,j+1), d=(i+1,j+1) gives triangles
  (a, c, b) and (b, c, d) (ours: Unity's order is unknown; docs/chapters/06-grass.md, "What differs from the
  book"), so the blade direction p2 - p0 is +X for one and +Z for the other.
* ``quad_mesh``: Unity's built-in Quad (XY plane, [-0.5, 0.5]^2, front face toward -Z), triangles (0,3,1), (3,0,2).
* ``noise_maps``: seeded, tileable fbm value noise standing in for HeightMap.png, Rotation.png and Wind.jpg (which
  cannot be shipped); each map's values are ranked onto a Beta distribution with the original's mean and std.
* ``sample_bilinear``: GL's LINEAR + REPEAT lookup without mipmaps (``textureLod(map, uv, 0)``), for the host-side
  "vertex shader" that gives every vertex its three map values.
* ``plane_models``: PlaneDeployer.cs: width x height planes 10 units apart, each yawed by 0/90/180/270 degrees.
* ``expand_grass`` / ``expand_pyramid``: the two geometry shaders in numpy (``backend=numpy``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .transforms import translation

PLANE_SIZE = 10.0
"""Edge length of Unity's built-in Plane, object units (also PlaneDeployer's spacing)."""
BLADE_VERTICES = 7
"""Vertices of one blade strip (book: [maxvertexcount(7)]): 5 triangles."""
PYRAMID_VERTICES = 12
"""Vertices the pyramid shader emits per triangle (book: [maxvertexcount(12)]): 4 separate triangles."""
LERP_THIRDS = (0.0, 0.33333, 0.66666, 1.0)
"""Colour weights of the blade's four levels (book: lerp(_BottomColor, _TopColor, 0.33333f / 0.66666f))."""


@dataclass(frozen=True)
class MapSpec:
    """How one stand-in noise map is made: size after Unity's 512 import limit, lattice cells of the coarsest
    octave (x, y), and the measured statistics of the book's texture it replaces (docs/chapters/06-grass.md,
    "What differs from the book")."""

    shape: tuple[int, int]
    cells: tuple[int, int]
    mean: float
    std: float


NOISE_MAPS = {
    "height": MapSpec((384, 512), (4, 3), 0.453, 0.104),  # HeightMap.png 640x480: soft clouds
    "rot": MapSpec((512, 512), (4, 4), 0.371, 0.153),  # Rotation.png 2048^2: clouds, 21.6 % of texels > 0.5
    "wind": MapSpec((384, 512), (2, 6), 0.684, 0.277),  # Wind.jpg 554x415: mostly white, dark streaks along x
}
NOISE_OCTAVES = 5
"""fbm octaves (each doubles the lattice and halves the amplitude)."""


# {{{ meshes


def plane_mesh(resolution: int = 10) -> dict[str, np.ndarray]:
    """Unity's Plane with ``resolution`` cells per side: pos, nrm (V, 3), uv (V, 2) float32; tri (T, 3) uint32."""
    n = resolution + 1
    j, i = np.mgrid[0:n, 0:n]  # vertex (i, j) has index j * n + i
    step = PLANE_SIZE / resolution
    pos = np.column_stack([i.ravel() * step - PLANE_SIZE / 2, np.zeros(n * n), j.ravel() * step - PLANE_SIZE / 2])
    nrm = np.tile([0.0, 1.0, 0.0], (n * n, 1))
    uv = np.column_stack([i.ravel(), j.ravel()]) / resolution
    cj, ci = np.mgrid[0:resolution, 0:resolution]
    a = (cj * n + ci).ravel()
    b, c = a + 1, a + n
    d = c + 1
    tri = np.column_stack([a, c, b, b, c, d]).reshape(-1, 3)  # per cell: (a, c, b) then (b, c, d)
    return {
        "pos": pos.astype(np.float32),
        "nrm": nrm.astype(np.float32),
        "uv": uv.astype(np.float32),
        "tri": tri.astype(np.uint32),
    }


def quad_mesh() -> dict[str, np.ndarray]:
    """Unity's Quad: 4 vertices in the XY plane, normal -Z, triangles (0, 3, 1) and (3, 0, 2)."""
    pos = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [-0.5, 0.5, 0.0], [0.5, 0.5, 0.0]], np.float32)
    return {
        "pos": pos,
        "nrm": np.tile(np.array([0.0, 0.0, -1.0], np.float32), (4, 1)),
        "uv": pos[:, :2] + 0.5,
        "tri": np.array([[0, 3, 1], [3, 0, 2]], np.uint32),
    }


def strip_triangles(blades: int) -> np.ndarray:
    """The 7-vertex strips of ``blades`` blades as a triangle list (5 per blade): for k = 0..4, (k, k+1, k+2) when
    k is even and (k+1, k, k+2) when odd, so every triangle keeps the strip's winding (GL's rule)."""
    k = np.arange(5)
    local = np.where((k % 2 == 0)[:, None], np.column_stack([k, k + 1, k + 2]), np.column_stack([k + 1, k, k + 2]))
    offsets = np.arange(blades, dtype=np.int64)[:, None, None] * BLADE_VERTICES
    return (local[None] + offsets).reshape(-1, 3).astype(np.uint32)


# }}}

# {{{ transforms


def rotation_y(quarter_turns: int) -> np.ndarray:
    """Unity's Quaternion.Euler(0, 90 * quarter_turns, 0) as a matrix, with exact 0/1 entries."""
    cos, sin = ((1, 0), (0, 1), (-1, 0), (0, -1))[quarter_turns % 4]
    return np.array([[cos, 0, sin, 0], [0, 1, 0, 0], [-sin, 0, cos, 0], [0, 0, 0, 1]], float)


def plane_models(width: int, height: int, rng: np.random.Generator) -> np.ndarray:
    """PlaneDeployer.cs: plane (i, j) at (10 (i - width/2), 0, 10 (j - height/2)) with integer division, yawed by
    a random multiple of 90 degrees; (width*height, 4, 4) float32, row-major, i-major order."""
    turns = rng.integers(0, 4, width * height)
    models = [
        translation(PLANE_SIZE * (i - width // 2), 0.0, PLANE_SIZE * (j - height // 2)) @ rotation_y(int(t))
        for (i, j), t in zip(((i, j) for i in range(width) for j in range(height)), turns, strict=True)
    ]
    return np.array(models, np.float32)


# }}}

# {{{ noise maps


def value_noise(shape: tuple[int, int], cells: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Tileable value noise: random values on a (cells_y, cells_x) lattice that wraps, smoothstep-interpolated."""
    h, w = shape
    cx, cy = cells
    lattice = rng.random((cy, cx))
    x = (np.arange(w) + 0.5) * cx / w
    y = (np.arange(h) + 0.5) * cy / h
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    fx, fy = fx * fx * (3 - 2 * fx), fy * fy * (3 - 2 * fy)
    x0, x1, y0, y1 = x0 % cx, (x0 + 1) % cx, y0 % cy, (y0 + 1) % cy
    top = lattice[y0][:, x0] * (1 - fx) + lattice[y0][:, x1] * fx
    bottom = lattice[y1][:, x0] * (1 - fx) + lattice[y1][:, x1] * fx
    return top * (1 - fy)[:, None] + bottom * fy[:, None]


def fbm(spec: MapSpec, rng: np.random.Generator) -> np.ndarray:
    total = np.zeros(spec.shape)
    for octave in range(NOISE_OCTAVES):
        cells = (spec.cells[0] << octave, spec.cells[1] << octave)
        total += value_noise(spec.shape, cells, rng) * 0.5**octave
    return total


def beta_shape(mean: float, std: float) -> tuple[float, float]:
    """Beta(a, b) with the given mean and standard deviation (method of moments)."""
    total = mean * (1 - mean) / std**2 - 1
    return mean * total, (1 - mean) * total


def noise_map(spec: MapSpec, rng: np.random.Generator) -> np.ndarray:
    """fbm whose texel values are replaced, rank for rank, by sorted Beta samples: the clouds keep their shape and
    the histogram gets the original texture's mean and std. (H, W) float32 in [0, 1], row 0 = v = 0."""
    field = fbm(spec, rng)
    values = np.sort(rng.beta(*beta_shape(spec.mean, spec.std), field.size))
    out = np.empty(field.size)
    out[np.argsort(field, axis=None, kind="stable")] = values
    return out.reshape(spec.shape).astype(np.float32)


def noise_maps(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The three stand-in maps, keyed height / rot / wind (book: _HeightMap, _RotationMap, _WindMap)."""
    return {name: noise_map(spec, rng) for name, spec in NOISE_MAPS.items()}


def sample_bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """GL ``textureLod(image, uv, 0).r`` with LINEAR filtering and REPEAT wrapping: texel centres at (k + 0.5)/size."""
    h, w = image.shape
    x = np.asarray(uv[:, 0], np.float64) * w - 0.5
    y = np.asarray(uv[:, 1], np.float64) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    x0, y0 = x0.astype(np.int64) % w, y0.astype(np.int64) % h
    x1, y1 = (x0 + 1) % w, (y0 + 1) % h
    img = image.astype(np.float64)
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


# }}}

# {{{ the geometry shaders in numpy (backend=numpy)


def _transform(models: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply (N, 4, 4) models to (N, K, 3) points (w = 1)."""
    return np.einsum("nij,nkj->nki", models[:, :3, :3], points) + models[:, None, :3, 3]


def expand_grass(mesh, samples, models, p, time: float) -> dict[str, np.ndarray]:
    """Grass.shader's geom() for every triangle of every plane, float32 like the kernel. ``samples`` holds the
    per-vertex height/rot/wind; ``p`` the GrassParams fields; returns blade_pos, blade_col, blade_h/rot/wind."""
    tri = mesh["tri"].astype(np.int64)
    planes = len(models)
    f = np.float32
    p0, p1, p2 = (mesh["pos"][tri[:, k]] for k in range(3))
    normal = (mesh["nrm"][tri[:, 0]] + mesh["nrm"][tri[:, 1]] + mesh["nrm"][tri[:, 2]]) / f(3)  # not normalised
    centre = (p0 + p1 + p2) / f(3)
    h, r, w = ((samples[k][tri[:, 0]] + samples[k][tri[:, 1]] + samples[k][tri[:, 2]]) / f(3) for k in samples)
    edge = p2 - p0
    direction = edge / np.linalg.norm(edge, axis=1, keepdims=True) * np.where(r > f(0.5), f(1), f(-1))[:, None]
    height = h * f(p.height)
    bh, mh, th = height * f(p.bottom_height), height * f(p.middle_height), height * f(p.top_height)
    bw, mw, tw = f(p.width * p.bottom_width), f(p.width * p.middle_width), f(p.width * p.top_width)
    v = np.empty((len(tri), BLADE_VERTICES, 3), np.float32)
    v[:, 0] = centre - direction * bw
    v[:, 1] = centre + direction * bw
    v[:, 2] = centre - direction * mw + normal * bh[:, None]
    v[:, 3] = centre + direction * mw + normal * bh[:, None]
    v[:, 4] = v[:, 3] - direction * tw + normal * mh[:, None]
    v[:, 5] = v[:, 3] + direction * tw + normal * mh[:, None]
    v[:, 6] = v[:, 5] + direction * tw + normal * th[:, None]
    sway = f(p.wind_power) * w * f(np.sin(f(time) * f(p.wind_time_scale)))
    bends = np.array([0, 0, p.bottom_bend, p.bottom_bend, p.middle_bend, p.middle_bend, p.top_bend], np.float32)
    v[:, :, 0] += sway[:, None] * bends[None, :]  # object-space +X (the book's dir = (1, 0, 0, 1))
    pos = _transform(np.repeat(models.astype(np.float32), len(tri), axis=0), np.tile(v, (planes, 1, 1)))
    bottom, top = np.asarray(p.bottom_color, np.float32), np.asarray(p.top_color, np.float32)
    level = np.array([0, 0, 1, 1, 2, 2, 3])
    col = np.array([bottom + (top - bottom) * f(LERP_THIRDS[k]) for k in level], np.float32)
    blades = planes * len(tri)
    return {
        "blade_pos": pos.astype(np.float32),
        "blade_col": np.broadcast_to(col, (blades, BLADE_VERTICES, 4)).copy(),
        "blade_h": np.tile(h, planes).astype(np.float32),
        "blade_rot": np.tile(r, planes).astype(np.float32),
        "blade_wind": np.tile(w, planes).astype(np.float32),
    }


def expand_pyramid(mesh, model, height: float, top_color, bottom_color) -> dict[str, np.ndarray]:
    """SimpleGeometryShader's geom(): base + 3 sides per triangle, apex = centroid + (0, 0, -height)."""
    tri = mesh["tri"].astype(np.int64)
    p0, p1, p2 = (mesh["pos"][tri[:, k]] for k in range(3))
    apex = np.float32(0.33333) * (p0 + p1 + p2) + np.array([0, 0, -height], np.float32)  # book: * 0.33333f
    v = np.stack([p0, p1, p2, p0, p1, apex, p1, p2, apex, p2, p0, apex], axis=1)
    pos = _transform(np.repeat(model[None].astype(np.float32), len(tri), axis=0), v)
    col = np.tile(np.asarray(bottom_color, np.float32), (len(tri), PYRAMID_VERTICES, 1))
    col[:, 5::3] = top_color  # the apex of each side triangle
    return {"pyr_pos": pos.astype(np.float32), "pyr_col": col}


# }}}
