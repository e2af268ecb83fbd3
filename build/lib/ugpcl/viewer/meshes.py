"""Small render meshes (vertex arrays of position + normal), built in code."""

from __future__ import annotations

import math

import numpy as np


def cube() -> tuple[np.ndarray, np.ndarray]:
    """Unity's built-in Cube: edge 1 centred at the origin, 24 vertices (position, face normal), 36 indices."""
    vertices, indices = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            normal = np.zeros(3)
            normal[axis] = sign
            u = np.roll(normal, 1)  # any unit vector perpendicular to the normal
            v = np.cross(normal, u)  # cross(u, v) = normal: (u, v) corners below run counter-clockwise
            base = len(vertices)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                vertices.append(np.concatenate([0.5 * (normal + a * u + b * v), normal]))
            indices += [base, base + 1, base + 2, base, base + 2, base + 3]  # counter-clockwise seen from outside
    return np.array(vertices, "f4"), np.array(indices, "i4")


def box_edges(center, size) -> np.ndarray:
    """The 12 edges of an axis-aligned box as 24 line vertices (x, y, z)."""
    c, h = np.asarray(center, float), np.asarray(size, float) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    lines = []
    for i in range(8):
        for j in range(i + 1, 8):
            if np.sum(corners[i] != corners[j]) == 1:  # neighbours differ in exactly one axis
                lines += [c + h * corners[i], c + h * corners[j]]
    return np.array(lines, "f4")


def uv_sphere(segments: int = 48, rings: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Unit sphere as (position, normal) float32 vertices and int32 triangle indices."""
    theta = np.linspace(0.0, math.pi, rings + 1)[:, None]  # from the north pole
    phi = np.linspace(0.0, 2.0 * math.pi, segments + 1)[None, :]
    points = np.stack(
        [np.sin(theta) * np.cos(phi), np.cos(theta) * np.ones_like(phi), np.sin(theta) * np.sin(phi)], -1
    ).reshape(-1, 3)
    r, s = np.mgrid[0:rings, 0:segments]
    a = (r * (segments + 1) + s).ravel()
    b, c, d = a + 1, a + segments + 2, a + segments + 1
    indices = np.stack([np.stack([a, c, b], 1), np.stack([a, d, c], 1)], 1).reshape(-1)
    vertices = np.concatenate([points, points], axis=1)  # on a unit sphere the normal is the position
    return vertices.astype("f4"), indices.astype("i4")
