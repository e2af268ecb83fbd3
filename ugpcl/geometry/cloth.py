"""Host geometry of the cloth (vol.4 ch.3; docs/chapters/14-cloth.md): the triangles of its W x H particle grid
(the exported mesh and the view) and its three spring families as vertex pairs (the debug view's lines). Vertex
y * W + x is the particle of column x and row y, as the kernels store them."""

from __future__ import annotations

import numpy as np


def grid_triangles(width: int, height: int) -> np.ndarray:
    """(2 (W-1)(H-1), 3) int32 vertex indices of the cloth mesh, vertex y * W + x: two triangles per cell."""
    y, x = np.mgrid[0 : height - 1, 0 : width - 1]
    a = (y * width + x).ravel()
    b, c, d = a + 1, a + width + 1, a + width  # (x+1, y), (x+1, y+1), (x, y+1)
    return np.stack([np.stack([a, b, c], 1), np.stack([a, c, d], 1)], 1).reshape(-1, 3).astype(np.int32)


def spring_pairs(width: int, height: int) -> dict[str, np.ndarray]:
    """The three spring families as (n, 2) int32 vertex-index pairs, each spring once (debug view): structural
    (x, y)-(x+1, y) and (x, y)-(x, y+1), shear (both diagonals of each cell), bend (x, y)-(x+-2, y+2)."""
    index = np.arange(width * height).reshape(height, width)

    def pairs(dx: int, dy: int) -> np.ndarray:
        x0, x1 = max(0, -dx), width - max(0, dx)
        a = index[0 : height - dy, x0:x1]
        b = index[dy:height, x0 + dx : x1 + dx]
        return np.stack([a.ravel(), b.ravel()], 1)

    return {
        "structural": np.concatenate([pairs(1, 0), pairs(0, 1)]).astype(np.int32),
        "shear": np.concatenate([pairs(1, 1), pairs(-1, 1)]).astype(np.int32),
        "bend": np.concatenate([pairs(2, 2), pairs(-2, 2)]).astype(np.int32),
    }
