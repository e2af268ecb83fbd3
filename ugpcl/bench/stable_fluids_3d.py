"""``ugpcl bench stable_fluids_3d``: the whole step and the pressure solve's Jacobi sweep per grid, variant, sweep
kernel and sweeps per solve (docs/chapters/04-stable-fluids-3d.md, "Benchmark")."""

from __future__ import annotations

from ..scenes.stable_fluids_3d import Params, Simulation
from .stable_fluids_2d import JACOBI_BYTES_PER_CELL
from .timing import seconds_per_call, seconds_per_step

SWEEP_BATCH = 20
"""Jacobi sweeps the bench runs back to back before it finishes the queue, as a solve of gs_iterations sweeps does."""

KERNEL_BYTES_PER_CELL = {
    "fixed": {  # fused_step, prev split into float fields
        "DiffuseFields": 56,  # velocity 16, source 16, density 4 in; velocity 16, density 4 out
        "DiffuseFieldsRows": 56,  # the same sweep in strips
        "ProjectStep1": 24,  # velocity 16 in; divergence 4, pressure 4 (the first sweep's p) out
        "ProjectStep1Rows": 24,  # the same in strips
        "ProjectStep2": 12,  # p 4, div 4 in; p 4 out (the step's first sweep done by ProjectStep1)
        "ProjectStep2Rows": 12,
        "ProjectStep3": 36,  # velocity 16, p 4 in; velocity 16 out
        "SwapAdvectVelocity": 36,  # velocity 16 in; velocity 16, prev_z 4 out
        "SwapAdvectDensity": 24,  # velocity 16, density 4 in; density 4 out
    },
    "book": {  # the book's kernels one by one on the float4 prev (docs/chapters/04-stable-fluids-3d.md has fixed's
        # passes before fused_step: 664 bytes a cell at gs_iterations 2)
        "AddSourceVelocity": 80,  # velocity 16, source 16, prev 16 in; velocity 16, prev 16 out
        "DiffuseVelocity": 48,  # velocity 16, prev 16 in; velocity 16 out
        "ProjectStep1": 48,  # velocity 16, prev 16 in; prev 16 out
        "ProjectStep2": 32,  # prev 16 in; prev 16 out
        "ProjectStep3": 48,  # velocity 16, prev 16 (for its x) in; velocity 16 out
        "SwapVelocity": 48,  # velocity 16, prev 16 (for its w) in; prev 16 out
        "AdvectVelocity": 32,  # prev 16 in; velocity 16 out
        "AddSourceDensity": 56,  # source 16, density 4, prev 16 in; density 4, prev 16 out
        "DiffuseDensity": 24,  # density 4, prev 16 (for its w) in; density 4 out
        "SwapDensity": 36,  # density 4, prev 16 in; prev 16 out
        "AdvectDensity": 36,  # velocity 16, prev 16 (for its w) in; density 4 out
        "AdvectDensityFromExt": 36,  # source 16, prev 16 (for its w) in; density 4 out
    },
}
"""The least memory traffic of each grid kernel a step launches, in bytes per cell: a float4 moves 16 bytes a cell,
a float 4; a float4 read for one of its floats, or written in part, moves the whole 16 (memory moves whole 32-byte
sectors); neighbours come from cache. The SetBoundary* launches (walls only) and AddSourceBrush3D (only when the
emitter changes) are left out. A step with the source on, gs_iterations 2: fixed 316, book 752 (step_bytes)."""


def step_bytes(sim: Simulation) -> int:
    """Least traffic of one step of ``sim``: one untimed step with its grid launches counted, KERNEL_BYTES_PER_CELL
    of each per cell."""
    counts: dict[str, int] = {}
    launch = sim._grid

    def counted(name: str, *args) -> None:
        counts[name] = counts.get(name, 0) + 1
        launch(name, *args)

    sim._grid = counted
    try:
        sim.step()
    finally:
        del sim._grid  # back to the class's method
    costs = KERNEL_BYTES_PER_CELL[sim.params.variant]
    cells = sim.params.width * sim.params.height * sim.params.depth
    return sum(costs[name] * count for name, count in counts.items() if name != "AddSourceBrush3D") * cells


def bench(runtime, sizes=None) -> list[dict]:
    """Per grid n^3, variant, sweep kernel (ProjectStep2 in the book's work-groups, ProjectStep2Rows in its strips;
    fixed only), diffusion sweep (fixed: "strips", step()'s DiffuseFieldsRows, and "8x8x4 groups", DiffuseFields in
    the book's work-groups, beside it at gs_iterations 2) and Jacobi sweeps per solve: ms per step (the whole Update:
    2 diffusions, 2 projections, 2 advections, the queue finished after each step; Draw runs only once solver is
    read, which this loop does not), cell updates/s (cells x steps/s), the step's least traffic (step_bytes) per
    second, and one Jacobi sweep of the pressure solve (one launch, walls included) in us, timed over 20 sweeps back
    to back and one finish as a solve runs them, as sweeps/s and cell updates/s, and as the least traffic a sweep
    needs (stable_fluids_2d.JACOBI_BYTES_PER_CELL, what the fixed variant's sweep moves; the book's float4 prev: 32)
    per second."""
    sizes = sizes or ([64, 128, 256] if runtime.is_gpu else [64, 128])
    diffusions = {"strips": "DiffuseFieldsRows", "8x8x4 groups": "DiffuseFields", "-": None}  # -: the book's kernels
    sweep_kernels = ("ProjectStep2", "ProjectStep2Rows")
    runs = [("fixed", kernel, "strips", sweeps) for kernel in sweep_kernels for sweeps in (2, 20)]
    runs += [("fixed", "ProjectStep2Rows", "8x8x4 groups", 2), ("book", "ProjectStep2", "-", 2)]
    rows = []
    for n in sizes:
        for variant, kernel, diffusion, sweeps in runs:
            sim = Simulation(runtime, Params(width=n, height=n, depth=n, gs_iterations=sweeps, variant=variant), seed=0)
            sim.sweep_kernel = kernel
            sim.diffuse_kernel = diffusions[diffusion]
            seconds = seconds_per_step(sim, min_seconds=1.0, max_steps=50)
            sweep = seconds_per_call(
                lambda sim=sim: sim.project_step2(1), runtime.queue, max_calls=10 * SWEEP_BATCH, batch=SWEEP_BATCH
            )
            cells = n**3
            rows.append(
                {
                    "grid": f"{n}^3",
                    "variant": variant,
                    "sweep kernel": kernel,
                    "diffusion sweep": diffusion,
                    "gs_iterations": sweeps,
                    "ms/step": seconds * 1e3,
                    "cell updates/s": cells / seconds,
                    "step bytes/s": step_bytes(sim) / seconds,
                    "us/Jacobi sweep": sweep * 1e6,
                    "Jacobi sweeps/s": 1.0 / sweep,
                    "Jacobi cell updates/s": cells / sweep,
                    "Jacobi bytes/s": (JACOBI_BYTES_PER_CELL if variant == "fixed" else 32) * cells / sweep,
                }
            )
    return rows
