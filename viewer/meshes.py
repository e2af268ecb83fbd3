"""Small render meshes (vertex arrays of position + normal), built in code."""

from __future__ import annotations

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
