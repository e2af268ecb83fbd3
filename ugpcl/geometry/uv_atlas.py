"""Paint layouts: texture coordinates in which every surface point owns its own texels, and the bake that turns a
mesh into per-texel position and normal textures (vol.1 ch.10; docs/chapters/10-projection-spray.md).

The sample paints in Unity's lightmap UVs (UV2), which Unity's cube and sphere ship with. Here:

* ``unit_cube``: the six faces as islands of a 3 x 2 atlas, ``gutter`` texels inside each cell's border;
* ``uv_sphere``: longitude/latitude rings with an equirectangular layout inside a ``gutter``-texel border;
* ``per_triangle_layout``: any mesh made paintable: triangles in pairs, one pair per square cell of a grid, each a
  right triangle in its cell's corner, so no two triangles share a texel and every gap is at least ``gutter``
  texels wide (the triangles' shapes are distorted; their texel density varies with their area);
* ``bake``: rasterise the triangles in uv space at texel centres ((i + 0.5) / tex), no v flip: object-space position
  (a = 1) and interpolated normal (a = 1) per covered texel, (0, 0, 0, 0) elsewhere, and the triangle each texel
  belongs to.

Textures are (tex, tex, 4) float32 in GL row order (row 0 at v near 0), as ``clkernels/include/image.h`` reads them.
"""

from __future__ import annotations

import math

import numpy as np

from .mesh import Mesh, drop_degenerate, vertex_normals


def unit_cube(tex: int, gutter: int) -> Mesh:
    """Unity's cube (edge 1, centred): 24 vertices, outward normals, face k in atlas cell (k % 3, k // 3)."""
    faces = [  # normal, u axis, v axis with u x v = normal (counter-clockwise seen from outside)
        ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
        ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
        ((0, 1, 0), (1, 0, 0), (0, 0, -1)),
        ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
        ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
        ((0, 0, -1), (-1, 0, 0), (0, 1, 0)),
    ]
    g = gutter / tex
    vertices, normals, uvs, triangles = [], [], [], []
    for k, (n, u, v) in enumerate(faces):
        n, u, v = (np.asarray(a, float) for a in (n, u, v))
        x0, y0 = (k % 3) / 3, (k // 3) / 2
        base = len(vertices)
        for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            vertices.append(n / 2 + su * u / 2 + sv * v / 2)
            normals.append(n)
            uvs.append((x0 + g + (su + 1) / 2 * (1 / 3 - 2 * g), y0 + g + (sv + 1) / 2 * (1 / 2 - 2 * g)))
        triangles += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return Mesh(np.array(vertices), np.array(triangles), np.array(normals), np.array(uvs))


def uv_sphere(tex: int, gutter: int, radius: float = 0.5, segments: int = 32, rings: int = 16) -> Mesh:
    """Unity's sphere: ``segments`` x ``rings``, u = longitude, v = latitude (0 at -y), inside a gutter border; the
    seam column is doubled and the pole triangles of zero area are dropped."""
    g = gutter / tex
    lon = np.linspace(0.0, 2 * np.pi, segments + 1)
    lat = np.linspace(0.0, np.pi, rings + 1)
    phi, theta = np.meshgrid(lon, lat)  # (rings + 1, segments + 1)
    normals = np.stack([np.sin(theta) * np.cos(phi), -np.cos(theta), np.sin(theta) * np.sin(phi)], -1).reshape(-1, 3)
    u, v = np.meshgrid(np.linspace(0, 1, segments + 1), np.linspace(0, 1, rings + 1))
    uvs = g + (1 - 2 * g) * np.stack([u, v], -1).reshape(-1, 2)
    row = segments + 1
    i, j = np.meshgrid(np.arange(segments), np.arange(rings))
    a = (j * row + i).ravel()
    b, c, d = a + 1, a + row + 1, a + row
    triangles = np.concatenate([np.column_stack([a, c, b]), np.column_stack([a, d, c])])
    mesh = Mesh(normals * radius, triangles, normals, uvs)
    return drop_degenerate(mesh)


def per_triangle_layout(mesh: Mesh, tex: int, gutter: int) -> Mesh:
    """``mesh`` unwelded (three vertices per triangle, normals kept or made) with uvs of its own: triangles 2k and
    2k + 1 fill the lower-left and upper-right corners of cell k of a square grid, ``gutter`` texels from the cell's
    sides and ``gutter`` texels either side of its diagonal. ValueError when ``tex`` leaves a triangle legs shorter
    than 2 texels."""
    faces = mesh.faces
    normals = mesh.normals if mesh.normals is not None else vertex_normals(mesh.vertices, faces)
    cells = (len(faces) + 1) // 2
    per_row = max(1, math.ceil(math.sqrt(cells)))
    cell = tex // per_row
    leg = cell - 3 * gutter
    if leg < 2:
        need = per_row * (3 * gutter + 2)
        raise ValueError(f"tex must be >= {need} for a per-triangle layout of {len(faces)} triangles, got {tex}")
    k = np.arange(len(faces))
    x0 = (k // 2 % per_row) * cell
    y0 = (k // 2 // per_row) * cell
    m, far = gutter, cell - gutter
    lower = np.array([[m, m], [m + leg, m], [m, m + leg]], float)  # hypotenuse on x + y = cell - gutter
    upper = np.array([[far, far - leg], [far, far], [far - leg, far]], float)  # on x + y = cell + gutter
    corners = np.where((k % 2 == 0)[:, None, None], lower, upper) + np.stack([x0, y0], -1)[:, None, :]
    return Mesh(
        mesh.vertices[faces].reshape(-1, 3),
        np.arange(3 * len(faces)).reshape(-1, 3),
        normals[faces].reshape(-1, 3),
        (corners / tex).reshape(-1, 2),
    )


def bake(mesh: Mesh, tex: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(pos_tex, nrm_tex, owner, hits): the mesh rasterised in its uvs at texel centres. ``owner`` (tex, tex) int32 is
    the last triangle covering each texel (-1: none), ``hits`` how many triangles cover it (2 on a shared edge)."""
    if mesh.uvs is None:
        raise ValueError("bake needs a mesh with uvs")
    normals = mesh.normals if mesh.normals is not None else vertex_normals(mesh.vertices, mesh.faces)
    pos = np.zeros((tex, tex, 4), np.float32)
    nrm = np.zeros((tex, tex, 4), np.float32)
    owner = np.full((tex, tex), -1, np.int32)
    hits = np.zeros((tex, tex), np.int32)
    uv = mesh.uvs.astype(np.float64) * tex - 0.5  # texel (i, j) centre sits at integer (i, j)
    for t, (a, b, c) in enumerate(mesh.faces):
        p = uv[[a, b, c]]
        area = (p[1, 0] - p[0, 0]) * (p[2, 1] - p[0, 1]) - (p[2, 0] - p[0, 0]) * (p[1, 1] - p[0, 1])
        if area == 0.0:
            continue
        lo = np.maximum(np.ceil(p.min(axis=0) - 1e-9).astype(int), 0)
        hi = np.minimum(np.floor(p.max(axis=0) + 1e-9).astype(int), tex - 1)
        if np.any(hi < lo):
            continue
        ys, xs = np.mgrid[lo[1] : hi[1] + 1, lo[0] : hi[0] + 1]
        # barycentric weights of corners b and c from the 2-D edge functions
        wb = ((xs - p[0, 0]) * (p[2, 1] - p[0, 1]) - (p[2, 0] - p[0, 0]) * (ys - p[0, 1])) / area
        wc = ((p[1, 0] - p[0, 0]) * (ys - p[0, 1]) - (xs - p[0, 0]) * (p[1, 1] - p[0, 1])) / area
        wa = 1.0 - wb - wc
        inside = (wa >= -1e-9) & (wb >= -1e-9) & (wc >= -1e-9)
        if not inside.any():
            continue
        w = np.stack([wa[inside], wb[inside], wc[inside]], -1)
        iy, ix = ys[inside], xs[inside]
        pos[iy, ix, :3] = w @ mesh.vertices[[a, b, c]].astype(np.float64)
        nrm[iy, ix, :3] = w @ normals[[a, b, c]].astype(np.float64)
        pos[iy, ix, 3] = nrm[iy, ix, 3] = 1.0
        owner[iy, ix] = t
        hits[iy, ix] += 1
    return pos, nrm, owner, hits


def tile_bounds(pos_tex: np.ndarray, tile: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounding sphere of the covered texels' object-space positions in each ``tile`` x ``tile`` tile, row-major
    from the bottom row: (centres (N, 3), radii (N,)); a tile without covered texels has radius -1."""
    tex = pos_tex.shape[0]
    n = -(-tex // tile)
    padded = np.zeros((n * tile, n * tile, 4), np.float32)
    padded[:tex, :tex] = pos_tex
    blocks = padded.reshape(n, tile, n, tile, 4).transpose(0, 2, 1, 3, 4).reshape(n * n, tile * tile, 4)
    covered = blocks[..., 3] >= 0.5
    xyz = blocks[..., :3].astype(np.float64)
    lo = np.where(covered[..., None], xyz, np.inf).min(axis=1)
    hi = np.where(covered[..., None], xyz, -np.inf).max(axis=1)
    empty = ~covered.any(axis=1)
    lo[empty], hi[empty] = 0.0, 0.0
    radii = np.linalg.norm(hi - lo, axis=1) / 2
    radii[empty] = -1.0
    return (lo + hi) / 2, radii
