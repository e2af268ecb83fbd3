"""``ugpcl bench stable_fluids_2d``: the whole step and the pressure solve's Jacobi sweep per grid and sweep
configuration (docs/chapters/04-stable-fluids-2d.md, "Benchmark")."""

from __future__ import annotations

import itertools

from ..scenes.stable_fluids_2d import Params, Simulation
from .timing import seconds_per_call, seconds_per_step

LOCAL_SIZE_STREAMING = (64, 4)
"""A work-group shape for large grids on GPUs (`--set local_size=64,4`): on the H100 a 4096^2 ProjectStep2 sweep takes
84.8 us with it against 103.5 us with the book's 32 x 32 (more, smaller groups in flight; rows of 256 bytes). The
other grid kernels keep this shape; the fixed variant's sweeps run ProjectStep2Rows on GPUs."""

SWEEP_BATCH = 20
"""Jacobi sweeps the bench runs back to back before it finishes the queue, as a solve of gs_iterations sweeps does."""


JACOBI_BYTES_PER_CELL = 12
"""A Jacobi sweep's least memory traffic per cell: read p and the divergence, write p (4 bytes each); the
neighbours' p come from cache. The fixed variant's ProjectStep2 moves just that (the book's float4 prev: 32).
The bench's ``% copy bw`` is this traffic's share of the device's copy bandwidth."""


BENCH_SWEEPS = (("ProjectStep2", Params.local_size), ("ProjectStep2", LOCAL_SIZE_STREAMING), ("ProjectStep2Rows", None))
"""The bench's sweep configurations: the book's one-cell kernel with its 32 x 32 groups and with 64 x 4, and the
strips (ROWS_LOCAL)."""


def bench(runtime, sizes=None) -> list[dict]:
    """Per n x n grid (scene coefficients, circle stroke held, gs_iterations 2) and sweep configuration
    (BENCH_SWEEPS; ``local`` = work-items, or strips of 4 x ROWS_PER_ITEM cells): ms per step (the whole Update: 2
    diffusions, 2 projections, 2 advections, 22 launches, the queue finished after each step) and cell updates/s
    (cells x steps/s); one Jacobi sweep of the pressure solve (one launch, walls included) in us, timed over 20
    sweeps back to back and one finish as a solve runs them, as sweeps/s and cell updates/s, and as the least
    traffic a sweep needs (JACOBI_BYTES_PER_CELL) per second."""
    sizes = sizes or ([256, 512, 1024, 2048, 4096] if runtime.is_gpu else [256, 512, 1024])
    rows = []
    for n, (kernel, local_size) in itertools.product(sizes, BENCH_SWEEPS):
        sim = Simulation(runtime, Params(width=n, height=n, stroke_frames=0, local_size=local_size or (32, 32)), seed=0)
        sim.sweep_kernel = kernel
        seconds = seconds_per_step(sim, min_seconds=1.0, max_steps=100)
        sweep = seconds_per_call(
            lambda sim=sim: sim.project_step2(1), runtime.queue, max_calls=50 * SWEEP_BATCH, batch=SWEEP_BATCH
        )
        rows.append(
            {
                "grid": f"{n}^2",
                "sweep kernel": kernel,
                "local": "x".join(map(str, sim.local_size if local_size else sim.rows_local_size)),
                "ms/step": seconds * 1e3,
                "cell updates/s": n * n / seconds,
                "us/Jacobi sweep": sweep * 1e6,
                "Jacobi iterations/s": 1.0 / sweep,
                "Jacobi cell updates/s": n * n / sweep,
                "Jacobi bytes/s": JACOBI_BYTES_PER_CELL * n * n / sweep,
            }
        )
    return rows
