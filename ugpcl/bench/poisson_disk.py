"""``ugpcl bench poisson_disk``: points/s, coverage, maximality and packing of the chapter's Bridson (host), scipy's
PoissonDisk and the dart-throwing kernels, with and without the gap fill (vol.4 ch.7)."""

from __future__ import annotations

import time

import numpy as np

from ..geometry import poisson_disk as pd
from ..scenes.poisson_disk import Params, Simulation

MAX_LATTICE_PROBES = 4_000_000
"""The maximality check's lattice: step r / 2 per axis, coarser where that would exceed this many probes."""


def farthest_probe(points, lo, hi, r: float, probes: int = 200_000, seed: int = 1) -> float:
    """Largest distance from a probe to its nearest sample, over uniform random probes and a lattice of step r / 2
    (at most MAX_LATTICE_PROBES) that includes the box's faces: <= r for a maximal sampling."""
    from scipy.spatial import cKDTree

    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    dim = len(lo)
    per_axis = min(int(np.ceil((hi - lo).max() / (r / 2))) + 1, int(MAX_LATTICE_PROBES ** (1 / dim)))
    axes = [np.linspace(a, b, per_axis) for a, b in zip(lo, hi, strict=True)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    random = np.random.Generator(np.random.PCG64(seed)).uniform(lo, hi, (probes, dim))
    distance, _ = cKDTree(np.asarray(points, np.float64)).query(np.concatenate([lattice, random]), workers=-1)
    return float(distance.max())


def _measure(
    rows: list, domain: str, r: float, solver: str, seconds: float, points, lo, hi, traffic=None, settled: bool = True
) -> None:
    """One bench row; ``traffic``: the device's least bytes for the kernels' rows (host rows: -); ``settled``: the
    device fill left no box uncovered (it reports that itself)."""
    farthest = farthest_probe(points, lo, hi, r)
    rows.append({
        "domain": domain, "r": r, "solver": solver, "points": len(points), "s": seconds,
        "points/s": len(points) / seconds, "uncovered %": 100 * pd.uncovered_fraction(points, lo, hi, r),
        "farthest probe / r": farthest / r, "maximal": "yes" if farthest <= r and settled else "no",
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
"""Below this radius (the default GPU bench's r = 0.001: a million points) the bench times only the kernels."""


def _timed_gpu(runtime, params: Params) -> tuple[float, Simulation, np.ndarray]:
    """Seconds from a new Simulation to its points on the host (build excluded: a warm-up run first)."""
    Simulation(runtime, params, 0).finish()  # warm-up: the build
    runtime.finish()
    start = time.perf_counter()
    sim = Simulation(runtime, params, 0)
    sim.finish()
    points = sim.points()
    return time.perf_counter() - start, sim, points


def bench(runtime, sizes=None) -> list[dict]:
    """Points/s of the chapter's Bridson (host, numpy), with the host's gap fill, scipy.stats.qmc.PoissonDisk
    (fill_space), the dart-throwing kernel (k = 30 rounds; compaction and transfer included) and the same with
    fill=true (the device fill: MarkUncovered and FillDarts rounds until no box is left; end to end), in the unit
    square at r = 0.01, 0.003, 0.001 and the unit cube at r = 0.02 (sizes: 1/r of the square, and then the square
    alone). On a CPU device the cube is at r = 0.05 (at 0.02 its host samplers take nearly four minutes on two
    cores). uncovered %: share of 200 000 uniform probes farther than r from every sample; farthest probe / r: over
    those and a lattice of step r/2 (at most 4 M probes); maximal: that is <= 1 and the device fill left no box;
    packing: N * ball(r/2) / volume. Default on a CPU device: r = 0.01 and 0.003 (the host samplers take minutes at
    r = 0.001; on a GPU that radius times the kernels alone). darts bytes/s: ThrowDarts' and CompactSamples' least
    traffic (darts_bytes) over the gpu row's time (which also holds the set-up, the read-back and the host's sort;
    other rows: -)."""
    from scipy.stats import qmc

    radii = [1.0 / s for s in sizes] if sizes else ([0.01, 0.003, 0.001] if runtime.is_gpu else [0.01, 0.003])
    cases = [(2, r) for r in radii] + ([] if sizes else [(3, 0.02 if runtime.is_gpu else 0.05)])
    rows: list[dict] = []
    for dim, r in cases:
        lo, hi = np.zeros(dim), np.ones(dim)
        name = "unit square" if dim == 2 else "unit cube"
        size = (1.0, 1.0, 1.0)
        if r >= HOST_BENCH_MIN_R:  # the host samplers take minutes below it: the kernels' rows only
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
        seconds, sim, points = _timed_gpu(runtime, Params(dim=dim, size=size, r=r, method="gpu"))
        traffic = darts_bytes(int(np.prod(sim.grid_dims)), sim.rounds, len(points))
        _measure(rows, name, r, "gpu (ThrowDarts)", seconds, points, lo, hi, traffic)
        seconds, sim, points = _timed_gpu(runtime, Params(dim=dim, size=size, r=r, method="gpu", fill=True))
        _measure(rows, name, r, "gpu + fill (FillDarts)", seconds, points, lo, hi, settled=sim.fill_boxes[-1] == 0)
    return rows
