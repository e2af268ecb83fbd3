"""``ugpcl bench procedural_modeling``: meshes too large for the book's C# loops (a terrain plane, a forest), built
by numpy and by the kernels, with the kernels' least memory traffic for the share column."""

from __future__ import annotations

import time

from ..geometry import procedural as pm
from ..scenes.procedural_modeling import PlaneParams, PlaneSimulation, TreeParams, TreeSimulation
from .timing import seconds_per_call

FOREST_TREES = 1000
"""Trees of the forest bench."""

GRID_VERTEX_BYTES = 44
"""Least memory traffic per vertex of GridVertices + GridNormals: positions (12) and uvs (8) written, positions
read back (12: the neighbours' from cache) and normals written (12); GridTriangles adds GRID_CELL_BYTES per cell.
About 100 flops a vertex (one Perlin octave, six cross products for the normal) stay below what the bandwidth
allows: memory-bound."""

GRID_CELL_BYTES = 24
"""GridTriangles per cell: the two triangles' six int32 indices written."""

TUBE_VERTEX_BYTES = 48
"""TubeRings per ring vertex: position (12), normal (12), tangent (16) and uv (8) written; each ring's inputs
(centre, tangent, normal, binormal, radius, v: TUBE_RING_BYTES) are read once for its radial_segments + 1 vertices."""

TUBE_RING_BYTES = 56
"""TubeRings per ring: the four float3 frame vectors, the radius and v read (4 x 12 + 4 + 4)."""

TUBE_QUAD_BYTES = 24
"""TubeTriangles per quad: the two triangles' six int32 indices written."""


def bench(runtime, sizes=None) -> list[dict]:
    """Meshes too large for the book's C# loops: a terrain plane of N x N vertices (Perlin heights, recalculated
    normals; N from --size, default 2048) and a forest of 1000 trees (about 6M vertices): ms and vertices/s of the
    numpy generator and of the kernels (device arrays, no read-back); the forest's skeleton (branch frames, grown
    on the host for both) is timed apart. kernels bytes/s: the kernels' least traffic (GRID_VERTEX_BYTES and
    GRID_CELL_BYTES; TUBE_VERTEX_BYTES, TUBE_RING_BYTES and TUBE_QUAD_BYTES) per second."""
    rows = []
    queue = runtime.queue
    for n in sizes or [2048]:
        sim = PlaneSimulation(runtime, PlaneParams(width_segments=n, height_segments=n, surface="terrain"), seed=0)
        start = time.perf_counter()
        sim.build()
        numpy_s = time.perf_counter() - start
        sim.make_grid_buffers()
        kernel_s = seconds_per_call(sim.launch_grid, queue, min_seconds=1.0, max_calls=50)
        traffic = GRID_VERTEX_BYTES * n * n + GRID_CELL_BYTES * (n - 1) * (n - 1)
        rows.append(_bench_row(f"terrain {n}x{n}", n * n, numpy_s, kernel_s, 0.0, traffic))
    params = TreeParams(trees=FOREST_TREES, builder="numpy")
    start = time.perf_counter()
    forest = TreeSimulation(runtime, params, seed=0)  # grows the skeleton, then meshes it with numpy
    total_s = time.perf_counter() - start
    start = time.perf_counter()
    pm.tree_mesh(forest.branches, params.radial_segments)
    numpy_s = time.perf_counter() - start
    forest.make_ring_buffers()
    kernel_s = seconds_per_call(forest.launch_rings, queue, min_seconds=1.0, max_calls=50)
    vertices = len(forest.mesh().vertices)
    rings, quads = forest.ring_buffers["count"], len(forest.branches) * params.height_segments * params.radial_segments
    traffic = (
        TUBE_VERTEX_BYTES * rings * (params.radial_segments + 1) + TUBE_RING_BYTES * rings + TUBE_QUAD_BYTES * quads
    )
    rows.append(_bench_row(f"forest {FOREST_TREES} trees", vertices, numpy_s, kernel_s, total_s - numpy_s, traffic))
    return rows


def _bench_row(
    workload: str, vertices: int, numpy_s: float, kernel_s: float, skeleton_s: float, kernel_bytes: int
) -> dict:
    return {
        "workload": workload,
        "vertices": vertices,
        "ms numpy": numpy_s * 1e3,
        "ms kernels": kernel_s * 1e3,
        "vertices/s numpy": vertices / numpy_s,
        "vertices/s kernels": vertices / kernel_s,
        "x numpy": numpy_s / kernel_s,
        "ms skeleton (host)": skeleton_s * 1e3,
        "kernels bytes/s": kernel_bytes / kernel_s,
    }
