"""``ugpcl bench poisson_disk``: points/s, coverage and packing of the chapter's Bridson (host), scipy's PoissonDisk
and the dart-throwing kernels, each with and without the gap fill (vol.4 ch.7)."""

from __future__ import annotations

import time

import numpy as np

from ..geometry import poisson_disk as pd
from ..scenes.poisson_disk import Params, Simulation


def _measure(rows: list, domain: str, r: float, solver: str, seconds: float, points, lo, hi, traffic=None) -> None:
    """One bench row; ``traffic``: the device's least bytes for the kernels' rows (host rows: -)."""
    rows.append({
        "domain": domain, "r": r, "solver": solver, "points": len(points), "s": seconds,
        "points/s": len(points) / seconds, "uncovered %": 100 * pd.uncovered_fraction(points, lo, hi, r),
        "packing": pd.packing_density(points, lo, hi, r),
        "darts bytes/s": "-" if traffic is None else traffic / seconds,
    })  # fmt: skip


DART_ROUND_BYTES_PER_CELL = 4
"""Least memory traffic of one round of ThrowDarts per cell: the 3^n phase launches read every cell's cell_used
flag once (int32; the +-2 cell window's flags and points come from cache)."""

SAMPLE_BYTES = 56
"""Per sample: ThrowDarts writes its point and flag (16 + 4), CompactSamples reads the point (16) and appends it and
its cell id (16 + 4). CompactSamples also reads every flag once more (DART_ROUND_BYTES_PER_CELL)."""


def darts_bytes(cells: int, rounds: int, samples: int) -> int:
    """The gpu method's least device traffic: ``rounds`` rounds and the compaction over ``cells`` cells."""
    return DART_ROUND_BYTES_PER_CELL * cells * (rounds + 1) + SAMPLE_BYTES * samples


HOST_BENCH_MIN_R = 0.002
"""Below this radius (the default GPU bench's r = 0.001: a million points) the bench times only the kernel."""


def bench(runtime, sizes=None) -> list[dict]:
    """Points/s of the chapter's Bridson (host, numpy), scipy.stats.qmc.PoissonDisk (fill_space) and the dart-throwing
    kernel (k = 30 rounds; compaction and transfer included), each also with fill=true, in the unit square at
    r = 0.01, 0.003, 0.001 and the unit cube at r = 0.02 (sizes: 1/r of the square; the cube keeps its radius). On a
    CPU device the cube is at r = 0.05 (at 0.02 its host samplers take nearly four minutes on two cores).
    uncovered %: share of 200 000 uniform probes farther than r from every sample; packing: N * ball(r/2) / volume.
    Default on a CPU device: r = 0.01 and 0.003 (the host samplers take minutes at r = 0.001; on a GPU that radius
    times the kernel alone). darts bytes/s: the kernels' least traffic (darts_bytes) over the gpu row's time (which
    also holds the set-up, the read-back and the host's sort; host rows: -)."""
    from scipy.stats import qmc

    radii = [1.0 / s for s in sizes] if sizes else ([0.01, 0.003, 0.001] if runtime.is_gpu else [0.01, 0.003])
    cases = [(2, r) for r in radii] + [(3, 0.02 if runtime.is_gpu else 0.05)]
    rows: list[dict] = []
    for dim, r in cases:
        lo, hi = np.zeros(dim), np.ones(dim)
        name = "unit square" if dim == 2 else "unit cube"
        size = (1.0, 1.0, 1.0)
        if r >= HOST_BENCH_MIN_R:  # the host samplers take minutes below it: the kernel's rows only
            start = time.perf_counter()
            points = pd.bridson(lo, hi, r)
            _measure(rows, name, r, "bridson (host)", time.perf_counter() - start, points, lo, hi)
            start = time.perf_counter()
            gaps = pd.fill_gaps(points, lo, hi, r)
            _measure(rows, name, r, "bridson + fill", time.perf_counter() - start + rows[-1]["s"],
                     np.concatenate([points, gaps]), lo, hi)  # fmt: skip
            start = time.perf_counter()
            points = qmc.PoissonDisk(dim, radius=r, l_bounds=lo, u_bounds=hi, rng=0).fill_space()
            _measure(rows, name, r, "scipy PoissonDisk", time.perf_counter() - start, points, lo, hi)
        params = Params(dim=dim, size=size, r=r, method="gpu")
        Simulation(runtime, params, 0).finish()  # warm-up: the build
        runtime.finish()
        start = time.perf_counter()
        sim = Simulation(runtime, params, 0)
        sim.finish()
        points = sim.points()
        seconds = time.perf_counter() - start
        traffic = darts_bytes(int(np.prod(sim.grid_dims)), sim.rounds, len(points))
        _measure(rows, name, r, "gpu (ThrowDarts)", seconds, points, lo, hi, traffic)
        start = time.perf_counter()
        gaps = pd.fill_gaps(points, lo, hi, r)
        _measure(rows, name, r, "gpu + fill", time.perf_counter() - start + rows[-1]["s"],
                 np.concatenate([points, gaps]), lo, hi)  # fmt: skip
    return rows
