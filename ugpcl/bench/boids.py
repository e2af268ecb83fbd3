"""``ugpcl bench boids``: ms per step and pair interactions/s of each ForceCS variant (vol.1 ch.3;
docs/chapters/03-boids.md)."""

from __future__ import annotations

from ..scenes.boids import Params, Simulation
from .timing import seconds_per_step

FLOCK_WARMUP_STEPS = 300
"""Steps (dt 1/60) from the book's start before the "flocking" bench rows: the boids have spread through the box."""


FLOPS_PER_PAIR = 21
"""meet() in clkernels/boids.cl for a pair inside every radius: 3 subtractions (diff), 5 for dist², 1 reciprocal,
3 multiplications and 9 additions into the three sums (compares and counts not counted)."""


def bench(runtime, sizes=None) -> list[dict]:
    """ms per step and pair interactions/s (N^2 per step; for the grid too, as the all-pairs work it replaces) for
    each N and ForceCS variant, at the book's start (every boid within every radius of every other: the worst
    case) and once the flock has spread out; at the start, FLOPS_PER_PAIR x N^2 per step as flop/s. The variants:
    tiled (ForceCS, the book's), naive (ForceCS_naive), grid (ForceCS_grid), and on CPU devices lanes (ForceCS_cpu,
    what variant=auto runs there); each row's ``kernel`` names the kernel that ran."""
    sizes = sizes or ([16384, 65536] if runtime.is_gpu else [1024, 4096])
    variants = ("tiled", "naive", "grid") if runtime.is_gpu else ("tiled", "lanes", "naive", "grid")
    rows = []
    for n in sizes:
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
                seconds = seconds_per_step(sim, max_steps=50)
                rows.append(
                    {
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
                )
    return rows
