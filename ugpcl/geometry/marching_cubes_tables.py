"""Marching-cubes tables of vol.1 ch.7 (docs/chapters/07-marching-cubes.md), built here from the algorithm rather
than typed in.

The book uploads Paul Bourke's five tables (``vertexOffset``, ``cubeEdgeFlags``, ``edgeConnection``,
``edgeDirection``, ``triangleConnectionTable``). The corner and edge numbering below is Bourke's and the book's;
the 256 rows of triangles are derived, case by case, from first principles:

1. A corner is *set* when its value <= threshold (the book's ``flagIndex`` bit); an edge is cut when exactly one
   of its corners is set.
2. On each of the cube's 6 faces the cut edges pair up into segments that separate set from unset corners. A face
   with 4 cut edges (set corners on one diagonal) is ambiguous; it is always resolved by the face alone, cutting
   off each *set* corner. Two cells sharing a face see the same four corners, so they draw the same segments
   there: every mesh is closed (Bourke's table, which inverts cases with more than four set corners instead, can
   leave holes at such faces).
3. Each segment is directed so that, seen from outside the cube, the set corners lie on its left; the segments
   then chain into closed loops, and each loop is fanned into triangles from its smallest edge index.
4. Triangle winding: face normals ``(p1 - p0) x (p2 - p0)`` point toward the set (low, "outside") corners, i.e.
   out of the high-density region, as the book's positive-inside fields need (docs/chapters/07-marching-cubes.md,
   orientation).

Facts the tests check: every row has at most 5 triangles (the book's ``[maxvertexcount(15)]``); the per-case
triangle-count histogram for 0..5 triangles is Bourke's [2, 16, 50, 80, 76, 32]; ``CUBE_EDGE_FLAGS[i]`` is the OR
of ``1 << e`` over the edges row i uses. ``python -m ugpcl.geometry.marching_cubes_tables`` rewrites
``clkernels/include/marching_cubes_tables.h``; a test fails when that header is stale.
"""

from __future__ import annotations

import sys

import numpy as np

from ..runtime import INCLUDE_DIR

VERTEX_OFFSET = np.array(
    [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)], np.int32
)
"""Corner k of a cell -> its offset from the cell's lowest corner (book: vertexOffset)."""
EDGE_CONNECTION = np.array(
    [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)], np.int32
)
"""Edge e joins corners (a, b) (book: edgeConnection)."""
EDGE_DIRECTION = VERTEX_OFFSET[EDGE_CONNECTION[:, 1]] - VERTEX_OFFSET[EDGE_CONNECTION[:, 0]]
"""offset[b] - offset[a] of edge e (book: edgeDirection)."""
MAX_TRIANGLES = 5
"""Triangles one cell can make (book: [maxvertexcount(15)] = 3 * 5)."""

HEADER = INCLUDE_DIR / "marching_cubes_tables.h"


def _faces() -> list[tuple[list[int], np.ndarray]]:
    """The 6 faces as (4 corners counter-clockwise seen from outside, outward normal)."""
    faces = []
    for axis in range(3):
        for side in (0, 1):
            corners = [k for k in range(8) if VERTEX_OFFSET[k, axis] == side]
            normal = np.zeros(3)
            normal[axis] = 1.0 if side else -1.0
            first = np.zeros(3)
            first[(axis + 1) % 3] = 1.0
            second = np.cross(normal, first)  # (first, second, normal) is right-handed
            centre = VERTEX_OFFSET[corners].mean(axis=0)
            corners.sort(
                key=lambda k: np.arctan2((VERTEX_OFFSET[k] - centre) @ second, (VERTEX_OFFSET[k] - centre) @ first)
            )
            faces.append((corners, normal))
    return faces


def _edge_index(a: int, b: int) -> int:
    for e, (p, q) in enumerate(EDGE_CONNECTION):
        if {int(p), int(q)} == {a, b}:
            return e
    raise ValueError(f"corners {a} and {b} share no edge")


def _loops(case: int, faces: list[tuple[list[int], np.ndarray]]) -> list[list[int]]:
    """Closed loops of cut edges for one case (steps 2 and 3 of the module docstring); ``faces`` from ``_faces``."""
    is_set = [bool(case >> k & 1) for k in range(8)]
    following: dict[int, int] = {}
    for corners, normal in faces:
        inside = [is_set[c] for c in corners]
        cut = [i for i in range(4) if inside[i] != inside[(i + 1) % 4]]  # face edge i joins corners i and i+1
        if len(cut) == 2:
            pairs = [(cut[0], cut[1])]
        elif len(cut) == 4:  # ambiguous face: one segment around each set corner i (its face edges i-1 and i)
            pairs = [((i - 1) % 4, i) for i in range(4) if inside[i]]
        else:
            continue
        for i, j in pairs:
            ends = [(corners[i], corners[(i + 1) % 4]), (corners[j], corners[(j + 1) % 4])]
            mid_i, mid_j = (VERTEX_OFFSET[list(end)].mean(axis=0) for end in ends)
            set_corner = ends[0][0] if is_set[ends[0][0]] else ends[0][1]
            left = np.cross(mid_j - mid_i, VERTEX_OFFSET[set_corner] - mid_i) @ normal > 0
            start, end = (_edge_index(*ends[0]), _edge_index(*ends[1]))
            if not left:
                start, end = end, start
            if start in following:
                raise AssertionError(f"case {case}: edge {start} starts two segments")
            following[start] = end
    loops, todo = [], set(following)
    while todo:
        start = min(todo)
        loop, edge = [start], following[start]
        todo.remove(start)
        while edge != start:
            loop.append(edge)
            todo.remove(edge)
            edge = following[edge]
        loops.append(loop)
    return loops


def build_triangle_table() -> np.ndarray:
    """(256, 16) int8: per case up to 5 triangles as edge-index triples, then -1 (book: triangleConnectionTable)."""
    table = np.full((256, 16), -1, np.int8)
    faces = _faces()
    for case in range(256):
        triangles = [(loop[0], loop[i], loop[i + 1]) for loop in _loops(case, faces) for i in range(1, len(loop) - 1)]
        if len(triangles) > MAX_TRIANGLES:
            raise AssertionError(f"case {case}: {len(triangles)} triangles")
        # winding: the loops circle the set corners counter-clockwise seen from them; fanning keeps that order,
        # which points (p1 - p0) x (p2 - p0) toward the set corners (checked on the cube in the tests)
        table[case, : 3 * len(triangles)] = np.ravel(triangles)
    return table


def edge_flags(triangles: np.ndarray) -> np.ndarray:
    """(256,) int32: bit e set when row i uses edge e (book: cubeEdgeFlags)."""
    flags = np.zeros(256, np.int32)
    for case, row in enumerate(triangles):
        for e in row[row >= 0]:
            flags[case] |= 1 << int(e)
    return flags


TRIANGLE_CONNECTION_TABLE = build_triangle_table()
CUBE_EDGE_FLAGS = edge_flags(TRIANGLE_CONNECTION_TABLE)


def header_text() -> str:
    """clkernels/include/marching_cubes_tables.h, as generated from the arrays above."""

    def rows(array, fmt: str, per_line: int) -> str:
        if array.ndim == 2:  # one {a, b, c} per row
            items = ["{" + ", ".join(fmt.format(int(v)) for v in row) + "}" for row in array]
        else:
            items = [fmt.format(int(v)) for v in array]
        return "\n".join("    " + ", ".join(items[i : i + per_line]) + "," for i in range(0, len(items), per_line))

    tri = "\n".join(
        "    {" + ", ".join(f"{int(v):2d}" for v in row) + "}," + f"  // {case}"
        for case, row in enumerate(TRIANGLE_CONNECTION_TABLE)
    )
    return f"""\
// marching_cubes_tables.h: the marching-cubes tables of vol.1 ch.7 (docs/chapters/07-marching-cubes.md).
// GENERATED by `python -m ugpcl.geometry.marching_cubes_tables` from ugpcl/geometry/marching_cubes_tables.py
// (the one source of truth; tests/test_marching_cubes.py fails when this file is stale). Do not edit by hand.
// Corner/edge numbering is Paul Bourke's and the book's; the triangle rows are derived there (ambiguous faces cut
// around each corner whose value <= threshold, so neighbouring cells always agree and meshes are closed).
// OpenCL __constant has no 4096-literal limit, so the book's five ComputeBuffers become arrays here.
#ifndef UGPCL_MARCHING_CUBES_TABLES_H
#define UGPCL_MARCHING_CUBES_TABLES_H

#define MC_MAX_TRIANGLES {MAX_TRIANGLES}  // book: [maxvertexcount(15)] / 3

// corner k -> offset from the cell's lowest corner (book: vertexOffset)
__constant int vertexOffset[8][3] = {{
{rows(VERTEX_OFFSET, "{:d}", 8)}
}};

// edge e -> its corners (a, b) (book: edgeConnection)
__constant int edgeConnection[12][2] = {{
{rows(EDGE_CONNECTION, "{:d}", 12)}
}};

// edge e -> offset[b] - offset[a] (book: edgeDirection)
__constant int edgeDirection[12][3] = {{
{rows(EDGE_DIRECTION, "{:2d}", 6)}
}};

// case -> 12-bit mask of cut edges (book: cubeEdgeFlags)
__constant int cubeEdgeFlags[256] = {{
{rows(CUBE_EDGE_FLAGS, "0x{:03x}", 16)}
}};

// case -> up to 5 triangles (edge triples), -1 terminated (book: triangleConnectionTable, stored as char)
__constant char triangleConnectionTable[256][16] = {{
{tri}
}};

#endif
"""


def main(argv: list[str] | None = None) -> int:
    HEADER.write_text(header_text())
    print(f"wrote {HEADER}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
