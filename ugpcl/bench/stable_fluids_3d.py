"""``ugpcl bench stable_fluids_3d``: the whole step and the pressure solve's Jacobi sweep per grid, sweep kernel and
sweeps per solve (docs/chapters/04-stable-fluids-3d.md, "Benchmark")."""

from __future__ import annotations

from ..scenes.stable_fluids_3d import Params, Simulation
from .stable_fluids_2d import JACOBI_BYTES_PER_CELL
from .timing import seconds_per_call, seconds_per_step

SWEEP_BATCH = 20
"""Jacobi sweeps the bench runs back to back before it finishes the queue, as a solve of gs_iterations sweeps does."""


def bench(runtime, sizes=None) -> list[dict]:
    """Per grid n^3, sweep kernel (ProjectStep2 in the book's work-groups, ProjectStep2Rows in its strips) and Jacobi
    sweeps per solve: ms per step (the whole Update: 2 diffusions, 2 projections, 2 advections, the queue finished
    after each step; Draw runs only once solver is read, which this loop does not), cell updates/s (cells x
    steps/s), and one Jacobi sweep of the pressure solve (one launch, walls included) in us, timed over 20 sweeps
    back to back and one finish as a solve runs them, as sweeps/s and cell updates/s, and as the least traffic a
    sweep needs (stable_fluids_2d.JACOBI_BYTES_PER_CELL, what the fixed variant's sweep moves; the book's float4
    prev: 32) per second."""
    sizes = sizes or ([64, 128, 256] if runtime.is_gpu else [64, 128])
    rows = []
    for n in sizes:
        for kernel in ("ProjectStep2", "ProjectStep2Rows"):
            for sweeps in (2, 20):
                sim = Simulation(runtime, Params(width=n, height=n, depth=n, gs_iterations=sweeps), seed=0)
                sim.sweep_kernel = kernel
                seconds = seconds_per_step(sim, min_seconds=1.0, max_steps=50)
                sweep = seconds_per_call(
                    lambda sim=sim: sim.project_step2(1), runtime.queue, max_calls=10 * SWEEP_BATCH, batch=SWEEP_BATCH
                )
                cells = n**3
                rows.append(
                    {
                        "grid": f"{n}^3",
                        "sweep kernel": kernel,
                        "gs_iterations": sweeps,
                        "ms/step": seconds * 1e3,
                        "cell updates/s": cells / seconds,
                        "us/Jacobi sweep": sweep * 1e6,
                        "Jacobi sweeps/s": 1.0 / sweep,
                        "Jacobi cell updates/s": cells / sweep,
                        "Jacobi bytes/s": JACOBI_BYTES_PER_CELL * cells / sweep,
                    }
                )
    return rows
