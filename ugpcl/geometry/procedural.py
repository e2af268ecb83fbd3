"""Procedural modeling (vol.1 ch.1; docs/chapters/01-procedural-modeling.md): the chapter's mesh generators in numpy.

Each function follows one C# script of the book's ``Assets/ProceduralModeling/Scripts`` (named in its docstring).
Coordinates and index order are the book's (Unity: left-handed, y up): the cross product ``(b - a) x (c - a)`` of
every triangle points along its vertex normals, which is what ``ugpcl.geometry.mesh`` calls outward; the viewer's
z mirror shows the meshes as Unity does. Everything is float64 inside and float32 out.

Batches: the curve, frame and tree functions work on many curves at once (a leading axis), so a forest of a
thousand trees is grown generation by generation with array operations instead of one Python call per branch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..random import key_of_seed, philox4x32, uniform01
from .mesh import Mesh, vertex_normals

PI2 = 2.0 * math.pi
ARC_DIVISIONS = 200
"""Samples of a curve's arc-length table (CurveBase.GetLengths: 200 divisions, 201 cumulative lengths)."""
TANGENT_DELTA = 0.001
"""Half-width in t of the central difference of CurveBase.GetTangent."""
PARALLEL_EPS = 1e-10
"""|T[i-1] x T[i]| at or below which two tangents count as parallel and the normal is copied unrotated."""


def _unit(v: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, length, out=np.zeros_like(v), where=length > 0)


def rotate(v: np.ndarray, axis: np.ndarray, angle) -> np.ndarray:
    """``Quaternion.AngleAxis(angle, axis) * v`` with the angle in radians (Rodrigues; the axis is normalised)."""
    k = _unit(np.asarray(axis, np.float64))
    angle = np.asarray(angle, np.float64)[..., None]
    cos, sin = np.cos(angle), np.sin(angle)
    return v * cos + np.cross(k, v) * sin + k * np.sum(k * v, axis=-1, keepdims=True) * (1.0 - cos)


def lerp(a, b, t):
    """Mathf.Lerp: t clamped to [0, 1]."""
    return a + (b - a) * np.clip(t, 0.0, 1.0)


# {{{ Quad.cs, Plane.cs, ParametricPlaneBase.cs


def quad(size: float) -> Mesh:
    """Quad.cs: two triangles (0, 1, 2), (2, 3, 0) of side ``size`` facing -z."""
    h = size * 0.5
    vertices = [(-h, h, 0.0), (h, h, 0.0), (h, -h, 0.0), (-h, -h, 0.0)]
    uvs = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    return Mesh(vertices, [(0, 1, 2), (2, 3, 0)], np.tile([0.0, 0.0, -1.0], (4, 1)), uvs)


def grid_ratios(width_segments: int, height_segments: int) -> tuple[np.ndarray, np.ndarray]:
    """(rx, ry) of every vertex k = y * W + x: x / (W - 1) and y / (H - 1), the vertex's uv."""
    ry, rx = np.meshgrid(
        np.arange(height_segments) / (height_segments - 1),
        np.arange(width_segments) / (width_segments - 1),
        indexing="ij",
    )
    return rx.ravel(), ry.ravel()


def grid_triangles(width_segments: int, height_segments: int) -> np.ndarray:
    """Plane.cs's cells: a = y * W + x, b = a + 1, c = a + 1 + W, d = a + W -> (a, b, c), (c, d, a)."""
    y, x = np.meshgrid(np.arange(height_segments - 1), np.arange(width_segments - 1), indexing="ij")
    a = (y * width_segments + x).ravel()
    b, c, d = a + 1, a + 1 + width_segments, a + width_segments
    return np.stack([np.stack([a, b, c], 1), np.stack([c, d, a], 1)], 1).reshape(-1, 3)


def plane(width_segments: int, height_segments: int, width: float, height: float, depth=None) -> Mesh:
    """Plane.cs: W x H vertices ((rx - 0.5) width, 0, (0.5 - ry) height), normal +y. With ``depth`` (a function of
    (u, v) arrays), ParametricPlaneBase.cs: y = depth(rx, ry), then RecalculateNormals (area-weighted here)."""
    rx, ry = grid_ratios(width_segments, height_segments)
    y = np.zeros_like(rx) if depth is None else depth(rx, ry)
    vertices = np.stack([(rx - 0.5) * width, y, (0.5 - ry) * height], 1)
    faces = grid_triangles(width_segments, height_segments)
    normals = np.tile([0.0, 1.0, 0.0], (len(rx), 1)) if depth is None else vertex_normals(vertices, faces)
    return Mesh(vertices, faces, normals, np.stack([rx, ry], 1))


def mountain_depth(power: float, depth: float):
    """MountainPlane.cs: Distance(u) Distance(v) depth with Distance(t) = (0.5 - |0.5 - t|)^power."""

    def distance(t):
        return (0.5 - np.abs(0.5 - t)) ** power

    return lambda u, v: distance(u) * distance(v) * depth


def perlin_permutation(seed: int) -> np.ndarray:
    """The lattice hash of ``perlin``: a permutation of 0..255 drawn from ``seed``, repeated to 512 entries (int32)."""
    perm = np.random.default_rng(seed).permutation(256).astype(np.int32)
    return np.concatenate([perm, perm])


PERLIN_GRADIENTS = np.array([[1, 1], [-1, 1], [1, -1], [-1, -1], [1, 0], [-1, 0], [0, 1], [0, -1]], np.float64)
"""Gradient of a lattice corner: entry hash & 7 (the kernel's perlin_grad has the same table)."""


def perlin(x, y, perm: np.ndarray) -> np.ndarray:
    """Improved 2D gradient noise (Perlin 2002: quintic fade, permutation hash) mapped to [0, 1] as Unity's
    Mathf.PerlinNoise is (its own table is not published, so the values are not Unity's)."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    fx, fy = np.floor(x), np.floor(y)
    xi, yi = fx.astype(np.int64) & 255, fy.astype(np.int64) & 255
    xf, yf = x - fx, y - fy
    u, v = (t * t * t * (t * (t * 6 - 15) + 10) for t in (xf, yf))

    def grad(h, dx, dy):
        g = PERLIN_GRADIENTS[h & 7]
        return g[..., 0] * dx + g[..., 1] * dy

    aa, ab = perm[perm[xi] + yi], perm[perm[xi] + yi + 1]
    ba, bb = perm[perm[xi + 1] + yi], perm[perm[xi + 1] + yi + 1]
    bottom = grad(aa, xf, yf) + u * (grad(ba, xf - 1, yf) - grad(aa, xf, yf))
    top = grad(ab, xf, yf - 1) + u * (grad(bb, xf - 1, yf - 1) - grad(ab, xf, yf - 1))
    return 0.5 * (bottom + v * (top - bottom) + 1.0)


def terrain_depth(u_scale: float, v_scale: float, u_offset: float, v_offset: float, depth: float, perm: np.ndarray):
    """TerrainPlane.cs: PerlinNoise(u uScale + uOffset, v vScale + vOffset) depth."""
    return lambda u, v: perlin(u * u_scale + u_offset, v * v_scale + v_offset, perm) * depth


# }}}

# {{{ Cylinder.cs, BadCylinder.cs


def cylinder(height: float, radius: float, segments: int, open_ended: bool = True, bad: bool = False) -> Mesh:
    """Cylinder.cs (``bad``: BadCylinder.cs, whose caps share the side's vertices and so their normals).

    ``open_ended`` true *adds* the caps (the book's name says the opposite). The seam vertex is duplicated for the
    uvs, which leaves the last side quad (and the last triangle of each cap fan) with zero area, as in the book."""
    top, bottom = height * 0.5, -height * 0.5
    n = segments + 1
    length = 2 * n  # len: the divisor that makes an index go round the circle

    def generate_cap(side: bool):
        ratio = np.arange(n) / (n - 1)
        cos, sin = np.cos(ratio * PI2), np.sin(ratio * PI2)
        x, z = cos * radius, sin * radius
        # interleaved: top vertex then bottom vertex at each angle
        vertices = np.stack([np.stack([x, np.full(n, top), z], 1), np.stack([x, np.full(n, bottom), z], 1)], 1)
        uvs = np.stack([np.stack([ratio, np.ones(n)], 1), np.stack([ratio, np.zeros(n)], 1)], 1)
        if side:
            normals = np.repeat(np.stack([cos, np.zeros(n), sin], 1)[:, None], 2, axis=1)
        else:
            normals = np.broadcast_to([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]], (n, 2, 3))
        return vertices.reshape(-1, 3), uvs.reshape(-1, 2), normals.reshape(-1, 3)

    parts = [generate_cap(side=True)]
    idx = 2 * np.arange(n)
    a, b, c, d = idx, idx + 1, (idx + 2) % length, (idx + 3) % length
    second = np.stack([c, d, b], 1) if bad else np.stack([d, b, c], 1)
    triangles = [np.stack([np.stack([a, c, b], 1), second], 1).reshape(-1, 3)]
    if open_ended:
        offset = 0 if bad else length  # the good cylinder's caps get vertices (and normals) of their own
        if not bad:
            parts.append(generate_cap(side=False))
        parts.append((np.array([[0.0, top, 0.0], [0.0, bottom, 0.0]]), np.array([[0.5, 1.0], [0.5, 0.0]]), None))
        it, ib = offset + length, offset + length + 1
        i = np.arange(0, length, 2)
        triangles.append(np.stack([np.full_like(i, it), (i + 2) % length + offset, i + offset], 1))
        i = np.arange(1, length, 2)
        triangles.append(np.stack([np.full_like(i, ib), i + offset, (i + 2) % length + offset], 1))
    centre_normals = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    vertices = np.concatenate([p[0] for p in parts])
    uvs = np.concatenate([p[1] for p in parts])
    normals = np.concatenate([centre_normals if p[2] is None else p[2] for p in parts])
    return Mesh(vertices, np.concatenate(triangles), normals, uvs)


# }}}

# {{{ Curve/CurveBase.cs, Curve/CatmullRomCurve.cs


class CatmullRomCurve:
    """CatmullRomCurve.cs (tension 0.5, three.js's port) over CurveBase.cs, for a batch of curves at once.

    ``points``: (l, 3) control points of one curve, or (n, l, 3) for n curves with l points each (l >= 2). The
    methods take parameters of shape (k,) and return (k, 3) for one curve or (n, k, 3) for a batch."""

    def __init__(self, points, closed: bool = False, arc_divisions: int = ARC_DIVISIONS):
        points = np.asarray(points, np.float64)
        self.single = points.ndim == 2
        self.points = points[None] if self.single else points
        if self.points.shape[1] < 2:
            raise ValueError(f"a Catmull-Rom curve needs at least 2 control points, got {self.points.shape[1]}")
        self.closed = closed
        self.coefficients = self._cubics()
        # GetLengths: the polyline through GetPoint(p / divisions), summed (in blocks of curves to bound memory)
        t = np.arange(arc_divisions + 1) / arc_divisions
        self.arc_lengths = np.concatenate(
            [
                self._arc_lengths(rows, t)
                for rows in np.array_split(np.arange(len(self.points)), len(self.points) // 4096 + 1)
            ]
        )

    def _cubics(self) -> np.ndarray:
        """(n, pieces, 4, 3) coefficients c0..c3 of each piece p1 -> p2 (CubicPoly.initCatmullRom, tension 0.5)."""
        P, count = self.points, self.points.shape[1]
        i = np.arange(count if self.closed else count - 1)
        p0, p1, p2, p3 = (P[:, (i + k) % count].copy() for k in (-1, 0, 1, 2))
        if not self.closed:  # no neighbour beyond an end: mirror the end's neighbour through the end
            p0[:, 0] = 2 * P[:, 0] - P[:, 1]
            p3[:, i + 2 >= count] = (2 * P[:, count - 1] - P[:, count - 2])[:, None]
        t0, t1 = 0.5 * (p2 - p0), 0.5 * (p3 - p1)
        return np.stack([p1, t0, -3 * p1 + 3 * p2 - 2 * t0 - t1, 2 * p1 - 2 * p2 + t0 + t1], axis=2)

    def _piece(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """GetPoint's (piece index, weight in it) of t; t = 1 on an open curve is the last piece at weight 1."""
        pieces = self.coefficients.shape[1]
        p = pieces * t
        i = np.floor(p).astype(np.int64)
        i = i % pieces if self.closed else np.clip(i, 0, pieces - 1)
        return i, p - np.floor(p) if self.closed else p - i

    def _arc_lengths(self, rows: np.ndarray, t: np.ndarray) -> np.ndarray:
        i, w = self._piece(t)
        powers = w[:, None] ** np.arange(4)
        samples = np.empty((len(rows), len(t), 3))
        for q in np.unique(i):  # the same t for every curve: one small matrix product per piece
            at = i == q
            samples[:, at] = np.einsum("nkc,mk->nmc", self.coefficients[rows, q], powers[at])
        steps = np.linalg.norm(np.diff(samples, axis=1), axis=-1)
        return np.concatenate([np.zeros((len(rows), 1)), np.cumsum(steps, axis=1)], axis=1)

    def _out(self, values: np.ndarray) -> np.ndarray:
        return values[0] if self.single else values

    def _params(self, t) -> np.ndarray:
        return np.broadcast_to(np.asarray(t, np.float64), (len(self.points), np.size(t)))

    def _point(self, t: np.ndarray) -> np.ndarray:
        """GetPoint(t) for t of shape (n, k): c0 + c1 w + c2 w^2 + c3 w^3 of t's piece."""
        i, w = self._piece(t)
        c = self.coefficients[np.arange(len(t))[:, None], i]
        w = w[..., None]
        return c[..., 0, :] + w * (c[..., 1, :] + w * (c[..., 2, :] + w * c[..., 3, :]))

    def _tangent(self, t: np.ndarray) -> np.ndarray:
        """GetTangent(t): central difference over t +- TANGENT_DELTA, clamped to [0, 1], normalised."""
        t1, t2 = np.maximum(t - TANGENT_DELTA, 0.0), np.minimum(t + TANGENT_DELTA, 1.0)
        return _unit(self._point(t2) - self._point(t1))

    def u_to_t(self, u) -> np.ndarray:
        """GetUtoTmapping: the t at arc-length fraction u (binary search in the table, linear inside a division)."""
        u = self._params(u)
        lengths = self.arc_lengths
        divisions = lengths.shape[1] - 1
        target = u * lengths[:, -1:]
        # one binary search for every curve: row r's table, scaled to [0, 1], shifted to [2r, 2r + 1]
        rows = np.arange(len(lengths))[:, None]
        total = np.where(lengths[:, -1:] > 0, lengths[:, -1:], 1.0)
        keys = (lengths / total + 2 * rows).ravel()
        i = np.searchsorted(keys, (target / total + 2 * rows).ravel(), side="left").reshape(u.shape)
        i = np.clip(i - rows * (divisions + 1), 0, divisions)
        exact = lengths[rows, i] == target
        before = np.maximum(i - 1, 0)
        lo, hi = lengths[rows, before], lengths[rows, np.minimum(before + 1, divisions)]
        fraction = np.divide(target - lo, hi - lo, out=np.zeros_like(target), where=hi > lo)
        return np.where(exact, i / divisions, (before + fraction) / divisions)

    def point(self, t) -> np.ndarray:
        return self._out(self._point(self._params(t)))

    def point_at(self, u) -> np.ndarray:
        """GetPointAt(u): the point at arc-length fraction u."""
        return self._out(self._point(self.u_to_t(u)))


def trefoil_knot(points: int = 12, scale: float = 0.4) -> tuple:
    """Control points of a trefoil knot through ``points`` points, ``scale`` times (sin t + 2 sin 2t,
    cos t - 2 cos 2t, -sin 3t) (ugpcl's tube curve: closed and non-planar, its frames must twist)."""
    return tuple(
        tuple(scale * v for v in (np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)))
        for t in np.arange(points) * 2 * np.pi / points
    )


@dataclass
class Frames:
    """FrenetFrame.cs for segments + 1 points along each curve: tangent, normal, binormal ((n,) S + 1, 3)."""

    tangent: np.ndarray
    normal: np.ndarray
    binormal: np.ndarray


def compute_frames(
    curve: CatmullRomCurve, segments: int, closed: bool = False, normal=None, binormal=None, variant: str = "fixed"
) -> Frames:
    """CurveBase.ComputeFrenetFrames: tangents at u = i / segments, the normal carried along by the minimal
    rotation between consecutive tangents (parallel transport: no twist), binormal = T x N.

    Without ``normal``/``binormal`` the first normal is made from the world axis least aligned with the first
    tangent (ties: z over y over x). Given ones are used as they are, not re-orthogonalised (the tree passes its
    parent's frame, so its branches' frames are skewed, as in the book). ``closed``: the normal's twist between
    the two ends is spread over the curve; ``variant="book"`` converts that angle with Deg2Rad where the book
    meant Rad2Deg, which leaves the twist almost uncorrected."""
    T = _unit(curve._tangent(curve.u_to_t(np.arange(segments + 1) / segments)))
    n = len(T)
    if normal is None:
        magnitude = np.abs(T[:, 0])
        axis = np.eye(3)[2 - np.argmin(magnitude[:, ::-1], axis=1)]  # the last of equal minima wins
        vec = _unit(np.cross(T[:, 0], axis))
        normal = np.cross(T[:, 0], vec)
        binormal = np.cross(T[:, 0], normal)
    N, B = np.empty_like(T), np.empty_like(T)
    N[:, 0] = np.broadcast_to(normal, (n, 3))
    B[:, 0] = np.broadcast_to(binormal, (n, 3))
    for i in range(1, segments + 1):
        axis = np.cross(T[:, i - 1], T[:, i])
        theta = np.arccos(np.clip(np.sum(T[:, i - 1] * T[:, i], axis=-1), -1.0, 1.0))
        turned = np.linalg.norm(axis, axis=-1, keepdims=True) > PARALLEL_EPS
        N[:, i] = np.where(turned, rotate(N[:, i - 1], axis, theta), N[:, i - 1])
        B[:, i] = _unit(np.cross(T[:, i], N[:, i]))
    if closed:
        theta = np.arccos(np.clip(np.sum(N[:, 0] * N[:, segments], axis=-1), -1.0, 1.0)) / segments
        flip = np.sum(T[:, 0] * np.cross(N[:, 0], N[:, segments]), axis=-1) > 0
        theta = np.where(flip, -theta, theta)
        if variant == "book":
            theta = np.radians(np.radians(theta))  # AngleAxis(Deg2Rad * theta) reads its radians as degrees
        for i in range(1, segments + 1):
            N[:, i] = rotate(N[:, i], T[:, i], theta * i)
            B[:, i] = np.cross(T[:, i], N[:, i])
    if curve.single:
        T, N, B = T[0], N[0], B[0]
    return Frames(T, N, B)


# }}}

# {{{ Tubular.cs


def ring_vertices(centers, normals, binormals, radii, radial_segments: int) -> tuple[np.ndarray, np.ndarray]:
    """GenerateSegment's inner loop for M rings: vertex j = 0..R at angle 2 pi j / R, direction
    normalize(cos N + sin B), position centre + radius direction. Returns positions and normals (M (R + 1), 3)."""
    angle = np.arange(radial_segments + 1) / radial_segments * PI2
    direction = _unit(
        np.cos(angle)[None, :, None] * np.asarray(normals)[:, None] + np.sin(angle)[None, :, None] * binormals[:, None]
    )
    positions = np.asarray(centers)[:, None] + np.asarray(radii, np.float64).reshape(-1, 1, 1) * direction
    return positions.reshape(-1, 3), direction.reshape(-1, 3)


def tube_triangles(tubes: int, segments: int, radial_segments: int) -> np.ndarray:
    """Tubular.cs's sides for ``tubes`` tubes of segments + 1 rings each, stored one after the other:
    a = (R+1)(j-1) + (i-1), b = (R+1) j + (i-1), c = (R+1) j + i, d = (R+1)(j-1) + i -> (a, d, b), (b, d, c)."""
    r1 = radial_segments + 1
    j, i = np.meshgrid(np.arange(1, segments + 1), np.arange(1, radial_segments + 1), indexing="ij")
    a, b = r1 * (j - 1) + (i - 1), r1 * j + (i - 1)
    c, d = r1 * j + i, r1 * (j - 1) + i
    one = np.stack([np.stack([a, d, b], -1), np.stack([b, d, c], -1)], -2).reshape(-1, 3)
    offsets = np.arange(tubes) * (segments + 1) * r1
    return (one[None] + offsets[:, None, None]).reshape(-1, 3)


@dataclass
class Tube:
    """Tubular.cs's output: the mesh, per-vertex tangents (T, 0) and the rings' centres and frames (the overlay)."""

    mesh: Mesh
    tangents: np.ndarray
    centers: np.ndarray
    frames: Frames


def tubular(
    curve: CatmullRomCurve,
    tubular_segments: int,
    radial_segments: int,
    radius: float,
    closed: bool = False,
    variant: str = "fixed",
) -> Tube:
    """Tubular.cs: rings i = 0..S-1 at u = i / S plus a last one at u = 1 (open) or a copy of ring 0 (closed)."""
    frames = compute_frames(curve, tubular_segments, closed, variant=variant)
    rings = np.append(np.arange(tubular_segments), 0 if closed else tubular_segments)
    centers = curve.point_at(rings / tubular_segments)
    positions, normals = ring_vertices(
        centers, frames.normal[rings], frames.binormal[rings], np.full(len(rings), radius), radial_segments
    )
    v, u = np.meshgrid(
        np.arange(tubular_segments + 1) / tubular_segments,
        np.arange(radial_segments + 1) / radial_segments,
        indexing="ij",
    )
    faces = tube_triangles(1, tubular_segments, radial_segments)
    tangents = np.zeros((len(positions), 4))
    tangents[:, :3] = np.repeat(frames.tangent[rings], radial_segments + 1, axis=0)
    mesh = Mesh(positions, faces, normals, np.stack([u.ravel(), v.ravel()], 1))
    return Tube(mesh, tangents.astype(np.float32), centers.astype(np.float32), frames)


# }}}

# {{{ ProceduralTree.cs


@dataclass
class TreeBranches:
    """Every TreeBranch of one or more trees, one row per branch, generation by generation (all roots first).

    The book builds a tree depth-first by recursion and meshes it in post-order; the order of the branches is not
    the book's concern (every branch is its own tube), and breadth-first lets a whole forest grow in array steps."""

    tree: np.ndarray
    """(B,) which tree the branch belongs to."""
    generation: np.ndarray
    """(B,) generations left: the root has ``generations``, the tips 0."""
    parent: np.ndarray
    """(B,) row of the parent branch, -1 for a root."""
    start: np.ndarray
    """(B, 3) ``from``."""
    end: np.ndarray
    """(B, 3) ``to``."""
    length: np.ndarray
    offset: np.ndarray
    """(B,) summed nominal lengths of the ancestors (the book's uv.y offset)."""
    positions: np.ndarray
    """(B, S + 1, 3) TreeSegment.Position: the ring centres."""
    radii: np.ndarray
    """(B, S + 1) TreeSegment.Radius, from_radius to to_radius."""
    frames: Frames
    """(B, S + 1, 3) each TreeSegment.Frame."""
    max_length: np.ndarray
    """(trees,) TraverseMaxLength: the longest sum of lengths from the root to a tip."""

    def __len__(self) -> int:
        return len(self.tree)


def tree_draws(tree, index, level: int, random_seed: int, seed: int) -> np.ndarray:
    """The five numbers in [0, 1) of a branch, in the book's order: growth angle about N, about B, bend along N,
    along B, branch count. Counter-based (Philox: tree, index in its generation, generation, randomSeed; key the
    run's seed), so a tree is the same alone or in a forest."""
    counter = np.stack([tree, index, np.full_like(tree, 2 * level), np.full_like(tree, random_seed)], axis=1).astype(
        np.uint32
    )
    key = key_of_seed(seed)
    first = uniform01(philox4x32(counter, key))
    counter[:, 2] += 1
    second = uniform01(philox4x32(counter, key))
    return np.concatenate([first, second[:, :1]], axis=1).astype(np.float64)


def grow_trees(data, trees: int = 1, seed: int = 0, origins=None) -> TreeBranches:
    """ProceduralTree.cs's TreeBranch constructor for ``trees`` trees at once. ``data`` holds TreeData's fields and
    the root's ``generations``, ``length``, ``radius`` (the scene's Params); ``origins`` (trees, 3) places them."""
    G, S = data.generations, data.height_segments
    tree = np.arange(trees)
    start = np.zeros((trees, 3)) if origins is None else np.asarray(origins, np.float64).reshape(trees, 3)
    # the root: TreeBranch(generations, length, radius, data) = (.., Vector3.up, Vector3.right, Vector3.back, ..)
    tangent = np.tile([0.0, 1.0, 0.0], (trees, 1))
    normal = np.tile([1.0, 0.0, 0.0], (trees, 1))
    binormal = np.tile([0.0, 0.0, -1.0], (trees, 1))
    length, radius = np.full(trees, float(data.length)), np.full(trees, float(data.radius))
    offset, parent = np.zeros(trees), np.full(trees, -1)
    levels, first_row = [], 0
    for level in range(G + 1):
        generation = G - level
        n = len(tree)
        r = tree_draws(tree, np.arange(n) - np.searchsorted(tree, tree), level, data.random_seed, seed)
        to_radius = np.zeros(n) if generation == 0 else radius * data.radius_attenuation
        # the branching angle grows towards the tips
        scale = lerp(1.0, data.growth_angle_scale, 1.0 - generation / G)
        angle_n = scale * lerp(data.growth_angle_min, data.growth_angle_max, r[:, 0])
        angle_b = scale * lerp(data.growth_angle_min, data.growth_angle_max, r[:, 1])
        # to = from + (qn * qb) * tangent * length: qb turns first
        direction = rotate(rotate(tangent, binormal, np.radians(angle_b)), normal, np.radians(angle_n))
        end = start + direction * length[:, None]
        # BuildSegments: a 4-point Catmull-Rom curve bent sideways, its frames started from the given N and B
        chord = np.linalg.norm(end - start, axis=1)[:, None]
        bend_n = lerp(-data.bend_degree, data.bend_degree, r[:, 2])[:, None]
        bend_b = lerp(-data.bend_degree, data.bend_degree, r[:, 3])[:, None]
        bend = chord * (normal * bend_n + binormal * bend_b)
        points = np.stack([start, lerp(start, end, 0.25) + bend, lerp(start, end, 0.75) + bend, end], axis=1)
        curve = CatmullRomCurve(points)
        frames = compute_frames(curve, S, normal=normal, binormal=binormal)
        u = np.arange(S + 1) / S
        levels.append(
            {
                "tree": tree,
                "generation": np.full(n, generation),
                "parent": parent,
                "start": start,
                "end": end,
                "length": length,
                "offset": offset,
                "positions": curve.point_at(u),
                "radii": lerp(radius[:, None], to_radius[:, None], u[None]),
                "frames": frames,
            }
        )
        if generation == 0:
            break
        # the children: count = Range(branchesMin, branchesMax + 1), spread from the middle to the end of the branch
        count = np.floor(lerp(data.branches_min, data.branches_max + 1, r[:, 4])).astype(np.int64)
        of = np.repeat(np.arange(n), count)
        i = np.arange(len(of)) - np.repeat(np.cumsum(count) - count, count)
        siblings = count[of]
        ratio = np.where(siblings == 1, 1.0, lerp(0.5, 1.0, i / np.maximum(siblings - 1, 1)))
        segment = np.floor(ratio * S).astype(np.int64)
        level_positions = levels[-1]["positions"]
        start = level_positions[of, segment]
        tangent, normal, binormal = (getattr(frames, k)[of, segment] for k in ("tangent", "normal", "binormal"))
        offset = offset[of] + length[of]
        length = length[of] * lerp(1.0, data.length_attenuation, ratio)
        radius = radius[of] * lerp(1.0, data.radius_attenuation, ratio)
        tree, parent = tree[of], of + first_row
        first_row += n

    def joined(key):
        return np.concatenate([level[key] for level in levels])

    frames = Frames(
        *(np.concatenate([getattr(lv["frames"], k) for lv in levels]) for k in ("tangent", "normal", "binormal"))
    )
    branches = TreeBranches(
        joined("tree"),
        joined("generation"),
        joined("parent"),
        joined("start"),
        joined("end"),
        joined("length"),
        joined("offset"),
        joined("positions"),
        joined("radii"),
        frames,
        np.zeros(trees),
    )
    # TraverseMaxLength, bottom-up: a branch's length plus the longest of its children's
    below = np.zeros(len(branches))
    total = branches.length.copy()
    for level_rows in reversed(np.split(np.arange(len(branches)), np.cumsum([len(lv["tree"]) for lv in levels])[:-1])):
        total[level_rows] = branches.length[level_rows] + below[level_rows]
        has_parent = branches.parent[level_rows] >= 0
        np.maximum.at(below, branches.parent[level_rows][has_parent], total[level_rows][has_parent])
    branches.max_length = total[:trees]
    return branches


@dataclass
class TreeRings:
    """The rings of every branch, flattened (M = B (S + 1) rings): what the mesh build (and TubeRings) reads."""

    centers: np.ndarray
    tangents: np.ndarray
    normals: np.ndarray
    binormals: np.ndarray
    radii: np.ndarray
    v: np.ndarray
    """uv.y of the ring: (offset + length i / S) / max_length of its tree."""


def tree_rings(branches: TreeBranches) -> TreeRings:
    S = branches.positions.shape[1] - 1
    max_length = branches.max_length[branches.tree][:, None]
    v = branches.offset[:, None] / max_length + branches.length[:, None] / max_length * (np.arange(S + 1) / S)
    f = branches.frames
    return TreeRings(
        *(a.reshape(-1, 3) for a in (branches.positions, f.tangent, f.normal, f.binormal)),
        branches.radii.ravel(),
        v.ravel(),
    )


def tree_mesh(branches: TreeBranches, radial_segments: int) -> tuple[Mesh, np.ndarray]:
    """ProceduralTree.Build's mesh: one tube of S + 1 rings per branch, uv = (j / R, ring's v); and the tangents."""
    rings = tree_rings(branches)
    positions, normals = ring_vertices(rings.centers, rings.normals, rings.binormals, rings.radii, radial_segments)
    u = np.tile(np.arange(radial_segments + 1) / radial_segments, len(rings.v))
    v = np.repeat(rings.v, radial_segments + 1)
    S = branches.positions.shape[1] - 1
    faces = tube_triangles(len(branches), S, radial_segments)
    tangents = np.zeros((len(positions), 4), np.float32)
    tangents[:, :3] = np.repeat(rings.tangents, radial_segments + 1, axis=0)
    return Mesh(positions, faces, normals, np.stack([u, v], 1)), tangents


def forest_origins(trees: int, spacing: float) -> np.ndarray:
    """Tree positions on a square grid of ``spacing``, centred on the origin, row by row."""
    side = math.ceil(math.sqrt(trees))
    k = np.arange(trees)
    return np.stack([(k % side - (side - 1) / 2) * spacing, np.zeros(trees), (k // side - (side - 1) / 2) * spacing], 1)


# }}}

# {{{ LSystem.cs


def lsystem_segments(depth: int, length: float, attenuation: float, angle: float) -> tuple[np.ndarray, np.ndarray]:
    """LSystem.DrawFractal: a line (0, 0, 0) -> (0, length, 0) in the current matrix, then twice the same one
    level down, translated to the line's end and turned about z by -angle and +angle (degrees), length times
    attenuation. Returns the 2^depth - 1 segments (n, 2, 3) in heap order (children of k: 2k + 1, 2k + 2) and
    the level of each (0 = trunk)."""
    origin, heading = np.zeros((1, 3)), np.zeros(1)
    segments, levels = [], []
    turn = math.radians(angle)
    for level in range(depth):
        direction = np.stack([-np.sin(heading), np.cos(heading), np.zeros_like(heading)], 1)
        end = origin + length * attenuation**level * direction
        segments.append(np.stack([origin, end], 1))
        levels.append(np.full(len(origin), level))
        origin = np.repeat(end, 2, axis=0)
        heading = np.stack([heading - turn, heading + turn], 1).ravel()
    return np.concatenate(segments).astype(np.float32), np.concatenate(levels).astype(np.int32)


def lsystem_expand(axiom: str, rules: dict[str, str], n: int) -> str:
    """The chapter's string rewriting: every symbol replaced by its rule (unchanged without one), n times.
    ``lsystem_expand("a", {"a": "ab", "b": "a"}, 3) == "abaab"``."""
    text = axiom
    for _ in range(n):
        text = "".join(rules.get(symbol, symbol) for symbol in text)
    return text


# }}}
