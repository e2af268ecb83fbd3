"""``ugpcl bench cellular_growth``: particle-steps/s of the particle-only step, all pairs against the uniform grid,
ms per Divide and the repulsion's flop/s (vol.3 ch.4; docs/chapters/11-cellular-growth.md)."""

from __future__ import annotations

import math

import numpy as np

from ..scenes.cellular_growth import GRID_CELL_MARGIN, MAX_RADIUS, PARTICLE_DTYPE, ParticleParams, ParticleSimulation
from .timing import grid_pairs_2d, seconds_per_call, seconds_per_step


def colony(count: int, spacing: float = 1.0, radius: float = 0.5, seed: int = 0) -> np.ndarray:
    """``count`` live cells on a jittered hexagonal lattice (a grown colony: each touches about six others)."""
    rng = np.random.default_rng(seed)
    side = math.ceil(math.sqrt(count / 0.866)) + 1
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    points = np.column_stack([(i + 0.5 * (j % 2)).ravel() * spacing, j.ravel() * spacing * 0.866])
    points = points[np.argsort(np.linalg.norm(points - points.mean(axis=0), axis=1), kind="stable")][:count]
    records = np.zeros(count, PARTICLE_DTYPE)
    records["position"] = points - points.mean(axis=0) + rng.uniform(-0.05, 0.05, (count, 2)) * spacing
    records["radius"] = radius
    records["threshold"] = 1.0
    records["alive"] = 1
    return records


REPEL_TEST_FLOPS = 8
"""repel() for a live pair, up to its contact test: dir = p - other (2), length(dir) (dot 3, sqrt 1) and the contact
distance (r_a + r_b) * repulsion (2). Flop convention of the benches: an FMA is 2, sqrt and a division 1 each."""

REPEL_CONTACT_FLOPS = 11
"""What a pair in contact adds: normalize(dir) (dot 3, sqrt 1, 2 divisions), (r - l) (1), the product (2) and the
velocity sum (2); the rare wobble of coincident cells is not counted."""


def repel_flops(records: np.ndarray, repulsion: float, grid, all_pairs: bool) -> float:
    """Flops of one UpdateParticles (or UpdateParticles_grid) pass over live cells ``records``: REPEL_TEST_FLOPS per
    pair tested (all count(count-1), or the live pairs in the 3x3 cells of ``grid``, a UniformGrid) and
    REPEL_CONTACT_FLOPS per pair in contact (counted through a host grid of cells of the largest contact distance)."""
    live = records[records["alive"] != 0]
    xy = live["position"].astype(np.float64)
    cell = 2.0 * MAX_RADIUS * repulsion * GRID_CELL_MARGIN
    low = xy.min(axis=0) - cell
    dims = np.ceil((xy.max(axis=0) - low) / cell).astype(int) + 2
    i, j = grid_pairs_2d(xy, low, cell, dims)
    d = np.linalg.norm(xy[i] - xy[j], axis=1)
    contacts = int(np.count_nonzero(d < (live["radius"][i] + live["radius"][j]) * np.float64(repulsion)))
    if all_pairs:
        tests = len(xy) * (len(xy) - 1)
    else:
        tests = len(grid_pairs_2d(xy, grid.origin, grid.cell_size, grid.dims)[0])
    return REPEL_TEST_FLOPS * tests + REPEL_CONTACT_FLOPS * contacts


def bench(runtime, sizes=None) -> list[dict]:
    """Particle-steps/s (capacity x UpdateParticles passes per second) of the particle-only step with every slot alive
    (a hexagonal colony), for the book's all-pairs UpdateParticles and the uniform-grid variant, and ms per Divide
    (GetDividableParticles and its counter reads; the pool is empty, so nothing splits); repel flop/s = repel_flops
    at the state the timed steps end in, per step time (Divide included in the time, not in the flops)."""
    sizes = sizes or ([4096, 16384, 65536, 262144] if runtime.is_gpu else [1024, 4096])
    rows = []
    for count in sizes:
        cells = colony(count)
        base = None
        for search in ("all_pairs", "grid"):
            params = ParticleParams(count=count, search=search, emit_frames=0, divide_interval=3.0)
            sim = ParticleSimulation(runtime, params, seed=0)
            sim.load(cells)
            seconds = seconds_per_step(sim, min_seconds=0.5, max_steps=20)
            base = base or seconds
            records = sim.particle_records()
            flops = repel_flops(records, params.repulsion, sim.grid, search == "all_pairs")
            divide = seconds_per_call(sim.divide, runtime.queue, min_seconds=0.2, max_calls=20)
            rows.append(
                {
                    "capacity": count,
                    "search": search,
                    "ms/step": seconds * 1e3,
                    "particle-steps/s": count / seconds,
                    "speed-up": base / seconds,
                    "ms/Divide": divide * 1e3,
                    "repel flop/s": flops / seconds,
                }
            )
    return rows
