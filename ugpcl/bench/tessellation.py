"""``ugpcl bench tessellation``: the fluid's frame per grid and variant, and its least memory traffic
(docs/chapters/17-tessellation.md). The tessellated plane is drawn by GL and not timed."""

from __future__ import annotations

from ..scenes.tessellation import Params, Simulation
from .timing import seconds_per_step

FLUID_KERNEL_BYTES = {
    "AddSourceBrush": 16,  # source written (float4)
    "AddSourceVelocity": 32,  # source.xy read, velocity read and written, prev.xy written
    "DiffuseVelocity": 24,  # velocity_in and prev.xy read, velocity_out written
    "ProjectStep1": {"book": 28, "fixed": 36},  # velocity and prev.z read, prev written; fixed: + divergence, pressure
    "ProjectStep2": {"book": 32, "fixed": 12},  # a Jacobi sweep: prev in and out (float4), or p, div in and p out
    "ProjectStep2Rows": 12,  # the same sweep in strips (fixed only; what GPUs run)
    "ProjectStep3": {"book": 20, "fixed": 24},  # velocity and p read, velocity written; fixed: + prev.x written
    "SwapVelocity": 16,  # velocity read, prev.xy written
    "AdvectVelocity": 16,  # prev.xy read, velocity written
    "AddSourceDensity": 16,  # source.z read, density read and written, prev.z written
    "DiffuseDensity": 12,  # density_in and prev.z read, density_out written
    "SwapDensity": 8,  # density read, prev.z written
    "AdvectDensity": 16,  # velocity and prev.z read, density written
    "AdvectDensityFromExt": 16,  # source.xy and prev.z read, density written
    "Draw": 28,  # velocity and density read, solver (float4) written
}
"""Least memory traffic per cell of each grid kernel of the 2D fluid (clkernels/stable_fluids_2d.cl): the floats of
its own cell it must read and write (the neighbours' from cache; a kernel that keeps part of a float4 writes only
the rest), by the fluid's variant where the layouts differ. The wall launches (SetBoundary*) are not counted."""


def frame_bytes(sim) -> int:
    """Least traffic of one frame of ``sim``'s fluid: one untimed step with the fluid's grid launches counted,
    FLUID_KERNEL_BYTES of each per cell."""
    fluid, counts = sim.fluid, {}
    launch = fluid._grid

    def counted(name: str, *args) -> None:
        counts[name] = counts.get(name, 0) + 1
        launch(name, *args)

    fluid._grid = counted
    try:
        sim.step()
    finally:
        del fluid._grid  # back to the class's method
    variant = fluid.params.variant
    per_cell = 0
    for name, count in counts.items():
        cost = FLUID_KERNEL_BYTES[name]
        per_cell += count * (cost[variant] if isinstance(cost, dict) else cost)
    return per_cell * fluid.w * fluid.h


def bench(runtime, sizes=None) -> list[dict]:
    """Per grid x grid fluid and variant (fixed: vol.1's solver, 22 launches a frame; book: vol.4's stripped copy,
    no pressure sweeps and no AdvectVelocity), circle stroke held: ms per frame (the fluid's step and the stroke's
    bookkeeping, the queue finished after each frame) and fluid cell updates/s; fluid bytes/s = the frame's least
    traffic (frame_bytes: FLUID_KERNEL_BYTES over the launches of one frame) per second. The plane is tessellated
    by GL."""
    sizes = sizes or ([256, 512, 1024] if runtime.is_gpu else [128, 256])
    rows = []
    for n in sizes:
        for variant in ("fixed", "book"):
            sim = Simulation(runtime, Params(grid=n, variant=variant), seed=0)
            seconds = seconds_per_step(sim, min_seconds=1.0, max_steps=100)
            rows.append(
                {
                    "grid": f"{n}^2",
                    "variant": variant,
                    "ms/frame": seconds * 1e3,
                    "cell updates/s": n * n / seconds,
                    "fluid bytes/s": frame_bytes(sim) / seconds,
                }
            )
    return rows
