"""Triangle meshes on the host: the one ``Mesh`` every geometry scene returns, and the checks tests run on it.

Convention: triangles are counter-clockwise seen from outside (OpenGL front faces), so the cross product
``(b - a) x (c - a)`` points out of a closed surface and ``signed_volume`` of a closed mesh is positive.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np


@dataclass(eq=False)  # numpy fields: == would be ambiguous
class Mesh:
    """Indexed triangles with optional per-vertex normals and texture coordinates."""

    vertices: np.ndarray
    """(V, 3) float32 positions."""
    faces: np.ndarray
    """(F, 3) int32 vertex indices, counter-clockwise seen from outside."""
    normals: np.ndarray | None = None
    """(V, 3) float32 unit normals per vertex, or None."""
    uvs: np.ndarray | None = None
    """(V, 2) float32 texture coordinates per vertex (OpenGL's: v = 0 is the image's bottom row), or None."""
    texture: np.ndarray | None = None
    """(H, W, 3 or 4) uint8 image the uvs address, top row first as in an image file; .glb embeds it."""

    def __post_init__(self) -> None:
        self.vertices = np.ascontiguousarray(self.vertices, np.float32).reshape(-1, 3)
        self.faces = np.ascontiguousarray(self.faces, np.int32).reshape(-1, 3)
        n = len(self.vertices)
        if len(self.faces) and (self.faces.min() < 0 or self.faces.max() >= n):
            raise ValueError(f"Mesh.faces must index 0..{n - 1}, got {self.faces.min()}..{self.faces.max()}")
        if self.normals is not None:
            self.normals = np.ascontiguousarray(self.normals, np.float32).reshape(-1, 3)
        if self.uvs is not None:
            self.uvs = np.ascontiguousarray(self.uvs, np.float32).reshape(-1, 2)
        for name in ("normals", "uvs"):
            value = getattr(self, name)
            if value is not None and len(value) != n:
                raise ValueError(f"Mesh.{name} must have one row per vertex ({n}), got {len(value)}")
        if self.texture is not None:
            self.texture = np.ascontiguousarray(self.texture, np.uint8)
            if self.texture.ndim != 3 or self.texture.shape[2] not in (3, 4) or self.uvs is None:
                raise ValueError(f"Mesh.texture must be (H, W, 3|4) with uvs, got shape {self.texture.shape}")

    @staticmethod
    def merge(meshes) -> Mesh:
        """One mesh holding all of ``meshes``; normals (uvs) are kept only when every part has them."""
        meshes = list(meshes)
        if not meshes:
            return Mesh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32))
        offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])

        def stacked(name):
            parts = [getattr(m, name) for m in meshes]
            return None if any(p is None for p in parts) else np.concatenate(parts)

        faces = np.concatenate([m.faces + offset for m, offset in zip(meshes, offsets, strict=True)])
        return Mesh(stacked("vertices"), faces, stacked("normals"), stacked("uvs"))


def _face_cross(vertices, faces) -> np.ndarray:
    """(b - a) x (c - a) per triangle in float64: outward, length twice the area."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    a, b, c = (v[np.asarray(faces).reshape(-1, 3)[:, k]] for k in range(3))
    return np.cross(b - a, c - a)


def _unit(vectors: np.ndarray) -> np.ndarray:
    """Rows scaled to length 1; zero rows (degenerate triangles, unused vertices) stay zero instead of NaN."""
    length = np.linalg.norm(vectors, axis=1, keepdims=True)
    return np.divide(vectors, length, out=np.zeros_like(vectors), where=length > 0)


def face_normals(vertices, faces) -> np.ndarray:
    """(F, 3) float32 unit normals by the winding; zero for zero-area triangles."""
    return _unit(_face_cross(vertices, faces)).astype(np.float32)


def vertex_normals(vertices, faces) -> np.ndarray:
    """(V, 3) float32 unit normals: the area-weighted sum of the adjacent face normals (zero for unused vertices)."""
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    cross = _face_cross(vertices, faces)  # length = 2 * area, so summing it weights by area
    sums = np.zeros((len(np.asarray(vertices).reshape(-1, 3)), 3))
    for k in range(3):
        np.add.at(sums, faces[:, k], cross)
    return _unit(sums).astype(np.float32)


def triangle_areas(vertices, faces) -> np.ndarray:
    """(F,) float64 triangle areas."""
    return 0.5 * np.linalg.norm(_face_cross(vertices, faces), axis=1)


def signed_volume(mesh: Mesh) -> float:
    """Sum of the signed tetrahedra (origin, a, b, c): the enclosed volume of a closed outward-wound mesh.

    Negative when the mesh is wound inward; on an open mesh the value depends on the origin.
    """
    v = mesh.vertices.astype(np.float64)
    a, b, c = (v[mesh.faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)


def _row_ids(rows: np.ndarray) -> np.ndarray:
    """(N,) ids 0..K-1 with equal ids for equal rows (np.unique(axis=0)'s inverse, without its slow row sort)."""
    order = np.lexsort(rows.T)
    starts = np.concatenate([[0], np.any(np.diff(rows[order], axis=0) != 0, axis=1)])
    ids = np.empty(len(rows), np.int64)
    ids[order] = np.cumsum(starts)
    return ids


def weld(mesh: Mesh, tol: float = 1e-6) -> Mesh:
    """Merge coincident vertices into the lowest-numbered one of each group.

    Vertices within ``tol`` of each other on every axis are merged, and so, transitively, are their neighbours;
    two vertices more than ``2 tol`` apart merge only through such a chain. Welded normals are the renormalised
    mean of the group; uvs are the kept vertex's (a uv seam cannot survive a weld). Triangles that lose a corner
    to the weld (two indices equal) are removed.
    """
    if not tol > 0:
        raise ValueError(f"weld: tol must be > 0, got {tol}")
    v = mesh.vertices.astype(np.float64)
    group = np.arange(len(v))
    # Cells of 2 tol on 8 grids, shifted by tol along each subset of the axes: two vertices within tol on every
    # axis share a cell on at least one of them. A pass gives each cell's vertices the smallest group among them;
    # passes repeat until chains across cells have settled.
    shifts = [np.array(s) for s in itertools.product((0.0, 0.5), repeat=3)]
    while len(v):
        before = group
        for shift in shifts:
            cell = _row_ids(np.floor(v / (2 * tol) + shift).astype(np.int64))
            smallest = np.full(cell.max() + 1, len(v))
            np.minimum.at(smallest, cell, group)
            group = smallest[cell]
        if np.array_equal(group, before):
            break
    kept = np.unique(group)  # each group's lowest vertex, in the original order
    remap = np.searchsorted(kept, group)

    faces = remap[mesh.faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])]
    normals = None
    if mesh.normals is not None:
        normals = np.zeros((len(kept), 3))
        np.add.at(normals, remap, mesh.normals.astype(np.float64))
        normals = _unit(normals)
    uvs = None if mesh.uvs is None else mesh.uvs[kept]
    return Mesh(mesh.vertices[kept], faces, normals, uvs)


def drop_degenerate(mesh: Mesh, eps: float = 1e-12) -> Mesh:
    """The mesh without triangles of area <= ``eps``; vertices are kept as they are, so indices stay valid."""
    faces = mesh.faces[triangle_areas(mesh.vertices, mesh.faces) > eps]
    return Mesh(mesh.vertices, faces, mesh.normals, mesh.uvs)


def _directed_edges(faces: np.ndarray) -> np.ndarray:
    """(3F, 2) int64 edges a->b, b->c, c->a of every triangle."""
    f = faces.astype(np.int64)
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])


def is_watertight(mesh: Mesh) -> bool:
    """Closed and consistently wound: every edge is shared by exactly two triangles that run it in opposite directions.

    Equivalently each directed edge occurs once and so does its reverse. An empty mesh is not watertight.
    """
    edges = _directed_edges(mesh.faces)
    if len(edges) == 0 or np.any(edges[:, 0] == edges[:, 1]):
        return False
    n = np.int64(len(mesh.vertices))
    code = edges[:, 0] * n + edges[:, 1]
    reverse = edges[:, 1] * n + edges[:, 0]
    unique = np.unique(code)
    return len(unique) == len(code) and bool(np.all(np.isin(reverse, unique, assume_unique=False)))


def normals_agree_with_winding(mesh: Mesh) -> float:
    """Fraction of the non-degenerate faces whose winding normal points the way the mean of their vertex normals does.

    1.0 for a mesh whose normals and winding agree, 0.0 when every face is wound backwards.
    """
    if mesh.normals is None:
        raise ValueError("normals_agree_with_winding needs a mesh with normals")
    cross = _face_cross(mesh.vertices, mesh.faces)
    real = np.linalg.norm(cross, axis=1) > 0
    if not real.any():
        raise ValueError("normals_agree_with_winding needs at least one triangle of non-zero area")
    mean_normal = mesh.normals[mesh.faces].astype(np.float64).sum(axis=1)
    return float(np.mean(np.einsum("ij,ij->i", cross[real], mean_normal[real]) > 0))
