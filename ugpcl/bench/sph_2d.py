"""``ugpcl bench sph_2d``: the book's all-pairs loops against the uniform grid, per particle count, with the pair
flops the kernels spend (PAIR_TEST_FLOPS, PAIR_SUM_FLOPS) for the share column."""

from __future__ import annotations

import math

import numpy as np

from ..scenes.sph_2d import Params, Simulation
from .timing import grid_pairs_2d, seconds_per_step


def bench_params(n: int, search: str) -> Params:
    """The scene at N particles: box and disc scaled by sqrt(N / 8192) to keep the scene's number density."""
    scale = math.sqrt(n / 8192)
    return Params(particle_num=n, search=search, range=(16.0 * scale, 9.0 * scale), ball_radius=5.0 * scale)


PAIR_TEST_FLOPS = 11
"""One pair tested by both DensityCS and ForceCS (or their _grid twins): in each, diff = x_j - x_i (2) and
dot(diff, diff) (3); DensityCS also adds the term to its sum (1; 0 outside h). Flop convention of the benches: an
FMA is 2, sqrt and a division 1 each, compares and fmax 0."""

PAIR_SUM_FLOPS = 27
"""What a pair inside h adds to its tests: calculate_density (4); in force_term sqrt (1), calculate_grad_pressure
with the mean pressure and its sum (13) and calculate_lap_velocity with its sum (9)."""


def pair_flops(positions, h: float, origin, cell_size: float, dims, all_pairs: bool) -> float:
    """Flops of one sub-step's DensityCS + ForceCS (or their _grid twins) at these positions: PAIR_TEST_FLOPS per
    pair the kernels test (all N(N-1), or the grid's 3x3-cell candidates) and PAIR_SUM_FLOPS per pair within h."""
    i, j = grid_pairs_2d(positions, origin, cell_size, dims)
    d = positions[i] - positions[j]
    within = int(np.count_nonzero(np.einsum("ij,ij->i", d, d) < np.float64(h) ** 2))
    n = len(positions)
    tests = n * (n - 1) if all_pairs else len(i)
    return float(PAIR_TEST_FLOPS * tests + PAIR_SUM_FLOPS * within)


def bench(runtime, sizes=None) -> list[dict]:
    """ms per frame (4 sub-steps) and particle sub-steps/s for the book's all-pairs loops and the uniform grid, from
    the scene's start (box and disc scaled with N to keep the number density); pair tests/s = 2 N^2 per sub-step
    (all pairs); speed-up = grid over all pairs at the same N; pair flop/s = pair_flops (tests and pairs within h
    counted on the host at the state the timed frames end in) per second."""
    sizes = sizes or ([8192, 32768, 262144] if runtime.is_gpu else [8192, 32768])
    rows = []
    for n in sizes:
        per_frame = {}
        for search in ("all_pairs", "grid"):
            sim = Simulation(runtime, bench_params(n, search), seed=0)
            seconds = seconds_per_step(sim, min_seconds=1.0, max_steps=20)
            per_frame[search] = seconds
            substeps = sim.params.iterations
            grid = sim.grid()  # the grid kernels' cells (cell >= h); for all pairs it only finds the pairs within h
            positions = sim.particles_array()["position"].astype(np.float64)
            flops = pair_flops(positions, sim.params.smoothlen, grid.origin, grid.cell_size, grid.dims,
                               search == "all_pairs")  # fmt: skip
            rows.append(
                {
                    "N": n,
                    "search": search,
                    "ms/frame": seconds * 1e3,
                    "particle-steps/s": n * substeps / seconds,
                    "pair tests/s": 2.0 * n * n * substeps / seconds if search == "all_pairs" else "-",
                    "speed-up": per_frame["all_pairs"] / seconds,  # a figure (x all pairs), not a label
                    "pair flop/s": flops * substeps / seconds,
                }
            )
    return rows
