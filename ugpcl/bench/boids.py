"""``ugpcl bench boids``: ms per step and pair interactions/s of each ForceCS variant (vol.1 ch.3;
docs/chapters/03-boids.md)."""

from __future__ import annotations

import math

from ..scenes.boids import Params, Simulation
from .timing import seconds_per_step

FLOCK_WARMUP_STEPS = 300
"""Steps (dt 1/60) before the "flocking" rows (from the book's start: the boids have spread through the box) and
the "spread" rows (from start=spread: the boids have gathered into streams)."""

ALL_PAIRS_MAX_N = 262144
"""The largest N the all-pairs variants are timed at: their flock's 300 steps take seconds there, minutes at 1M."""

SPREAD_NEIGHBOURS = 30
"""The spread rows' number density: about this many boids within radius 2 (the book's cohesion and alignment
radius) of each, 0.9 per unit^3, as the boids scene's at_scale box (1,048,576 boids in 105^3)."""

FLOPS_PER_PAIR = 21
"""meet() in clkernels/boids.cl for a pair inside every radius: 3 subtractions (diff), 5 for dist², 1 reciprocal,
3 multiplications and 9 additions into the three sums (compares and counts not counted). The tiled ForceCS
(meet_in_tile) spends exactly these, as 3 FADD (diff), FMUL + 2 FFMA (dist²), 1 MUFU.RCP (rcp.approx.ftz on NVIDIA),
3 FFMA (separation) and 6 FADD (alignment, cohesion), besides 4 compares (3 rules, 1 for its skip test) and 1 add
for the one count it keeps (cohesion's), none of them counted."""


def spread_params(n: int) -> Params:
    """N boids with the grid, start=spread in a cube holding SPREAD_NEIGHBOURS boids per ball of radius 2."""
    edge = (n * (4.0 / 3.0) * math.pi * 2.0**3 / SPREAD_NEIGHBOURS) ** (1.0 / 3.0)
    return Params(max_object_num=n, variant="grid", start="spread", wall_size=(edge, edge, edge))


def row(n: int, phase: str, variant: str, sim, seconds: float) -> dict:
    return {
        "N": n,
        "state": phase,
        "variant": variant,
        "kernel": sim.force_kernel(),
        "ms/step": seconds * 1e3,
        "interactions/s": n * n / seconds,
        "steps/s": 1.0 / seconds,
        # at the start every pair is inside every radius: meet() does all its work
        **({"pair flop/s": FLOPS_PER_PAIR * n * n / seconds} if phase == "start" else {}),
    }


def bench(runtime, sizes=None) -> list[dict]:
    """ms per step and pair interactions/s (N^2 per step; for the grid too, as the all-pairs work it replaces) for
    each N and ForceCS variant, at the book's start (every boid within every radius of every other: the worst
    case) and once the flock has spread out (N <= ALL_PAIRS_MAX_N); at the start, FLOPS_PER_PAIR x N^2 per step as
    flop/s. The variants: tiled (ForceCS, the book's), naive (ForceCS_naive), grid (ForceCS_grid), and on CPU
    devices lanes (ForceCS_cpu, what variant=auto runs there); each row's ``kernel`` names the kernel that ran.
    Then, for every N, the grid from start=spread (spread_params) after FLOCK_WARMUP_STEPS steps: the "spread"
    rows."""
    sizes = sizes or ([16384, 65536, 1 << 20, 1 << 22] if runtime.is_gpu else [1024, 4096])
    variants = ("tiled", "naive", "grid") if runtime.is_gpu else ("tiled", "lanes", "naive", "grid")
    rows = []
    for n in sizes:
        if n <= ALL_PAIRS_MAX_N:
            sims = {v: Simulation(runtime, Params(max_object_num=n, variant=v), seed=0) for v in variants}
            # the flock is grown by the variant auto runs on this device (the fastest all-pairs kernel there)
            lead = next(v for v, sim in sims.items() if sim.force_kernel() == sim.auto_kernel)
            for phase in ("start", "flocking"):
                if phase == "flocking":
                    for _ in range(FLOCK_WARMUP_STEPS):
                        sims[lead].step()
                    state = sims[lead].state()
                    for variant, sim in sims.items():
                        if variant != lead:
                            sim.set_boids(state["position"], state["velocity"])
                for variant, sim in sims.items():
                    rows.append(row(n, phase, variant, sim, seconds_per_step(sim, max_steps=50)))
            del sims  # the device memory of N boids per variant, before the spread run's
        sim = Simulation(runtime, spread_params(n), seed=0)
        for _ in range(FLOCK_WARMUP_STEPS):
            sim.step()
        rows.append(row(n, "spread", "grid", sim, seconds_per_step(sim, max_steps=50)))
    return rows
