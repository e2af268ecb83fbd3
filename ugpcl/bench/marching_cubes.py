"""``ugpcl bench marching_cubes``: ms for SampleField and for each OpenCL meshing path, voxels/s, against
scikit-image's marching_cubes on the same field (vol.1 ch.7; docs/chapters/07-marching-cubes.md)."""

from __future__ import annotations

import numpy as np

from ..scenes.marching_cubes import Params, Simulation
from .timing import seconds_per_call


def bench(runtime, sizes=None) -> list[dict]:
    """Marching cubes of the three spheres (repository radii, t = 0.3) on N^3 cells: ms for SampleField ((N+1)^3 field
    evaluations) and for each OpenCL path on that field, voxels (cells) per second of the meshing alone and of field +
    mesh, against scikit-image's marching_cubes (lorensen) meshing the same float32 field in the same run (where
    scikit-image, a test dependency, is installed); the field's write traffic and the meshing's least read traffic (4
    bytes per grid point each) per second. "kernels": the *_cpu kernels (CPU devices) or the one-cell kernels.
    "ms draw read": what the viewer's upload takes from the device, PackVertices and the read of the frame's
    triangles (72 bytes each) into pinned host memory (``Simulation.draw_vertices``), the GL upload excluded."""
    try:
        from skimage.measure import marching_cubes as skimage_marching_cubes
    except ImportError:
        skimage_marching_cubes = None

    sizes = sizes or ([64, 128, 256, 512] if runtime.is_gpu else [64, 128, 256])
    rows = []
    for n in sizes:
        sim = Simulation(runtime, Params(segment_num=n, shape="spheres-repo", time=0.3, animate=False), seed=0)
        queue, cells = runtime.queue, n**3
        field_s = seconds_per_call(sim.sample_field, queue, max_calls=50)
        for path in ("append", "scan"):
            sim.update(path=path)
            mesh_s = seconds_per_call(sim.polygonize, queue, max_calls=50)
            read_s = seconds_per_call(sim.draw_vertices, queue, max_calls=50)
            rows.append(
                {
                    "N": n,
                    "mesher": f"OpenCL {path}",
                    "kernels": "cpu" if sim.cpu_kernels else "one-cell",
                    "ms field": field_s * 1e3,
                    "ms mesh": mesh_s * 1e3,
                    "ms draw read": read_s * 1e3,
                    "triangles": sim.pool.count(),
                    "voxels/s mesh": cells / mesh_s,
                    "voxels/s field+mesh": cells / (field_s + mesh_s),
                    "field bytes/s": 4 * (n + 1) ** 3 / field_s,
                    "mesh bytes/s": 4 * (n + 1) ** 3 / mesh_s,
                }
            )
        if skimage_marching_cubes is None:
            continue
        field, level = sim.field_array(), float(np.float32(sim.params.threshold))
        mesh_s = seconds_per_call(
            lambda f=field, lv=level: skimage_marching_cubes(f, lv, method="lorensen"), queue, max_calls=5
        )
        faces = skimage_marching_cubes(field, level, method="lorensen")[1]
        rows.append(
            {
                "N": n,
                "mesher": "scikit-image",
                "kernels": "-",
                "ms field": "-",
                "ms mesh": mesh_s * 1e3,
                "ms draw read": "-",
                "triangles": len(faces),
                "voxels/s mesh": cells / mesh_s,
                "voxels/s field+mesh": "-",
            }
        )
    return rows
