"""``ugpcl bench grass``: ms per GrassExpand (the geometry stage of one frame) and blades/s, OpenCL against the numpy
port (vol.1 ch.6; docs/chapters/06-grass.md)."""

from __future__ import annotations

import numpy as np

from ..geometry import grass as geo
from ..scenes.grass import Params, Simulation
from .timing import seconds_per_call

BLADE_BYTES = 238
"""GrassExpand's least memory traffic per blade (one input triangle): writes blade_pos 7 x 3 and blade_col 7 x 4
floats and the three means (208 bytes); reads the triangle's 3 indices (12) and its share of the per-vertex inputs
pos, nrm, hei, rot, wind (36 bytes a vertex, a grid plane has half as many vertices as triangles: 18). The flops
(about 200 a blade, 7 transforms of 18 of them) are far below what the bandwidth allows: memory-bound."""


def bench(runtime, sizes=None) -> list[dict]:
    """ms per GrassExpand (the geometry stage of one frame) and blades/s, for one plane subdivided to about
    `size` blades (the book's field: 20,000 blades), with the numpy port for comparison up to 200,000 blades;
    the kernel's least traffic (BLADE_BYTES per blade) per second (the numpy rows run on the host: -)."""
    sizes = sizes or ([20000, 2000000] if runtime.is_gpu else [20000, 200000])
    rows = []
    for size in sizes:
        resolution = max(1, round(np.sqrt(size / 2)))
        for backend in ("opencl", "numpy"):
            if backend == "numpy" and size > 200000:
                continue
            params = Params(planes=(1, 1), plane_resolution=resolution, backend=backend)
            sim = Simulation(runtime, params, seed=0)
            seconds = seconds_per_call(sim.grass_expand, runtime.queue, max_calls=200)
            rows.append(
                {
                    "blades": sim.blades,
                    "backend": backend,
                    "ms/frame": seconds * 1e3,
                    "blades/s": sim.blades / seconds,
                    "vertices/s": sim.blades * geo.BLADE_VERTICES / seconds,
                    "expand bytes/s": BLADE_BYTES * sim.blades / seconds if backend == "opencl" else "-",
                }
            )
    return rows
