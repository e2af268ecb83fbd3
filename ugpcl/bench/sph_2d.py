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


ALL_PAIRS_MAX_N = 262144
"""The largest N the all-pairs loops are timed at (0.36 s a frame on the H200 there; 16x that at 1,048,576)."""

PAIR_TEST_FLOPS = 11
"""One pair tested by both DensityCS and ForceCS (or their _grid twins): in each, diff = x_j - x_i (2) and
dot(diff, diff) (3); DensityCS also adds the term to its sum (1; 0 outside h). Flop convention of the benches: an
FMA is 2, sqrt and a division 1 each, compares and fmax 0."""

PAIR_SUM_FLOPS = 27
"""What a pair inside h adds to its tests: calculate_density (4); in force_term sqrt (1), calculate_grad_pressure
with the mean pressure and its sum (13) and calculate_lap_velocity with its sum (9)."""

COUNTED_PARTICLES = 1 << 17
"""Above this many particles pair_flops finds the pairs within h for about this many (whole strips of cell rows
spread over the box) and scales them to N: the host's pair lists of a million particles would take gigabytes."""

STRIP_ROWS = 4
"""Cell rows per strip of pair_flops."""


def pair_flops(positions, h: float, origin, cell_size: float, dims, all_pairs: bool) -> float:
    """Flops of one sub-step's DensityCS + ForceCS (or their _grid twins) at these positions: PAIR_TEST_FLOPS per
    pair the kernels test (all N(N-1), or the grid's 3x3-cell candidates: from the cell counts) and PAIR_SUM_FLOPS
    per pair within h. Those are listed strip by strip of STRIP_ROWS cell rows (each strip's particles with the rows
    on either side, which hold all their candidates); above COUNTED_PARTICLES only every k-th strip, scaled to N."""
    n, (nx, ny) = len(positions), (int(dims[0]), int(dims[1]))
    cell = np.floor((positions[:, :2] - np.asarray(origin, np.float64)[:2]) / cell_size)
    cell = np.clip(np.nan_to_num(cell), 0, [nx - 1, ny - 1]).astype(np.int64)  # clamped as grid.h's
    counts = np.bincount(cell[:, 1] * nx + cell[:, 0], minlength=nx * ny).reshape(ny, nx)
    padded = np.pad(counts, 1)
    around = sum(padded[1 + dy : 1 + dy + ny, 1 + dx : 1 + dx + nx] for dy in (-1, 0, 1) for dx in (-1, 0, 1))
    tests = n * (n - 1) if all_pairs else int((counts * around).sum()) - n  # each particle's 3x3 cells, less itself
    row, within, counted = cell[:, 1], 0, 0
    for first in range(0, ny, STRIP_ROWS * math.ceil(n / COUNTED_PARTICLES)):
        near = (row >= first - 1) & (row <= first + STRIP_ROWS)  # the strip and one row on either side
        own = (row[near] >= first) & (row[near] < first + STRIP_ROWS)
        points = positions[near]
        i, j = grid_pairs_2d(points, origin, cell_size, dims)
        d = points[i[own[i]]] - points[j[own[i]]]
        within += int(np.count_nonzero(np.einsum("ij,ij->i", d, d) < np.float64(h) ** 2))
        counted += int(own.sum())
    return float(PAIR_TEST_FLOPS * tests + PAIR_SUM_FLOPS * within * n / max(counted, 1))  # n / counted: 1 if all


def bench(runtime, sizes=None) -> list[dict]:
    """ms per frame (4 sub-steps) and particle sub-steps/s for the book's all-pairs loops (up to ALL_PAIRS_MAX_N)
    and the uniform grid, from the scene's start (box and disc scaled with N to keep the number density); pair
    tests/s = 2 N^2 per sub-step (all pairs); speed-up = grid over all pairs at the same N; pair flop/s = pair_flops
    (tests and pairs within h counted on the host at the state the timed frames end in) per second."""
    sizes = sizes or ([8192, 32768, 262144, 1048576] if runtime.is_gpu else [8192, 32768])
    rows = []
    for n in sizes:
        per_frame = {}
        for search in ("all_pairs", "grid") if n <= ALL_PAIRS_MAX_N else ("grid",):
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
                    # a figure (x all pairs), not a label
                    "speed-up": per_frame["all_pairs"] / seconds if "all_pairs" in per_frame else "-",
                    "pair flop/s": flops * substeps / seconds,
                }
            )
    return rows
