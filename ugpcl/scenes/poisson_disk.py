"""Poisson disk sampling: random points never closer than r that fill a box until no more fit (vol.4 ch.7, Bridson's
"Fast Poisson Disk Sampling in Arbitrary Dimensions"; docs/chapters/18-poisson-disk.md).

``method=bridson`` is the chapter's algorithm on the host (``ugpcl.geometry.poisson_disk``), in any dimension;
each step runs ``steps_per_frame`` of its active-point steps, so the view animates the growth as the sample's
coroutine does (0: the whole sampling in the first step, as ``ugpcl run``). ``method=gpu`` (not in the book, which
notes Bridson's method has no parallel form) is multi-phase dart throwing on the same grid, clkernels/poisson_disk.cl:
per step one round of ``ThrowDarts`` over the 3^n cell phases, k rounds in all; with ``fill``, then (in one step)
rounds of ``MarkUncovered`` and ``FillDarts`` (per phase) until no uncovered box is left; then ``CompactSamples``.

Differences from the book: ``fill=true`` throws darts into the gaps either method leaves (about 0.1 % of the area
after Bridson) until the sampling is maximal (bridson: ``pd.fill_gaps`` on the host; gpu: on the device);
``annulus=volume`` draws candidates uniformly in the n-ball shell (the sample's 3-D radius is sqrt-distributed); the
domain is ``lo`` and ``size`` (the sample's bottomLeft and topRight - bottomLeft); random numbers come from PCG64
(host) and Philox (kernel), never Unity's.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..geometry import poisson_disk as pd
from ..random import key_of_seed
from ..scene import Animation, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

MAX_GRID_CELLS = 1 << 26
"""Largest background grid (cells of r / sqrt(n)): 256 MiB of int32 on the host, 1.3 GiB on the device for the
gpu method. The unit cube at r = 0.001 would need 5e9."""
GPU_DIMS = (2, 3)
"""Dimensions of the dart-throwing kernel (cells of one phase must stay more than r apart: n <= 3)."""
R2_MARGIN = 1.0 + 2.0**-19
"""(1 + 2^-20)^2, rounded up: the kernel rejects darts within r * (1 + 2^-20), so float32 rounding of positions and
squared distances (a few 2^-24 relative) never brings two samples closer than r."""
GROUP = 64
"""Work-group size of the kernels (no local memory: any size works)."""
MAX_FILL_ROUNDS = 48
"""Cap on the device fill's rounds (MarkUncovered + FillDarts). A round splits every box left into 2^n children
down to the kernel's MAX_LEVEL (2^-15 of a cell in 2-D, 2^-10 in 3-D), where one more round settles every box;
seen: 11 - 17 rounds (the square at r = 0.05 .. 0.001, the cube at 0.15 and 0.05). Hitting it leaves the sampling
not quite maximal, which the fill says in a warning and in stats()."""
INT_MAX = np.int32(2**31 - 1)
"""The reset of each cell's box choice (MarkUncovered's atomic_min): larger than every key (30 bits)."""
MIN_LENGTH = 1e-6
"""Smallest size and r: lo + size stays above lo for every |lo| <= 1e6 (one float64 step there is 1.2e-10), and r^2
and the cell size stay far from float32's smallest normal numbers."""


@dataclass(frozen=True)
class Params(BaseParams):
    dim: int = param(2, 2, 6)
    """Dimension n of the domain (the sample: 2 and 3; method=gpu: 2 or 3)."""
    lo: tuple[float, float, float] = param((0.0, 0.0, 0.0), -1e6, 1e6)
    """Domain min corner (bottomLeft / bottomLeftBack); 2-D uses x, y; beyond 3-D every further axis takes x's."""
    size: tuple[float, float, float] = param((1.0, 1.0, 1.0), MIN_LENGTH, 1e6)
    """Domain extent per axis (topRight - bottomLeft), same axes as lo (at least 1e-6: lo + size > lo in float64)."""
    r: float = param(10.0, MIN_LENGTH, 1e6)
    """Smallest distance between two samples, domain units (minimumDistance; at least 1e-6: r^2 stays normal)."""
    k: int = param(30, 1, 1000)
    """Candidates per active point (iterationPerPoint; the sample maps <= 0 to 30); method=gpu: rounds of darts."""
    method: str = param("bridson", choices=("bridson", "gpu"))
    """bridson: the chapter's algorithm on the host; gpu: multi-phase dart throwing, ThrowDarts (not in the book)."""
    annulus: str = param("area", choices=pd.ANNULI, used_only_when={"method": "bridson"})
    """Candidate distance r..2r: area = sqrt(U[r^2, 4r^2]) as the sample; volume = uniform in the n-ball shell."""
    fill: bool = False
    """After sampling, throw darts into the uncovered gaps until none is left (maximal; not in the book; gpu: on the
    device, MarkUncovered and FillDarts)."""
    steps_per_frame: int = param(0, 0, 1 << 20, live=True)
    """Sampler steps per simulation step: active points (bridson) or dart rounds (gpu); 0: all in the first step.
    The view animates with 2 (the sample: one active point per 0.01 s)."""
    radius_rate: float = param(0.5, 0.0, 2.0, live=True)
    """Drawn radius = r * radius_rate / 2 (radiusRate; 1 draws touching discs)."""
    record_steps: bool = param(False, used_only_when={"method": "bridson"})
    """Keep the active list's length after every step (active_count in the .npz; bridson)."""
    compare_scipy: bool = False
    """Also sample with scipy.stats.qmc.PoissonDisk (scipy_points in the .npz; fill_space, the same r and k)."""

    limits = (f"prod(ceil(size*sqrt(dim)/r) + 1) <= {MAX_GRID_CELLS}", "r <= size*sqrt(dim) with method=gpu")
    """The background grid, cells of r / sqrt(dim) over every axis of the domain (``grid_shape``), fits; the gpu
    method throws each dart uniformly in its whole cell, so the box holds a whole cell on every axis (a box much
    smaller than a cell would catch no dart)."""

    def check(self) -> None:
        if self.method == "gpu" and self.dim not in GPU_DIMS:
            raise ValueError(f"method=gpu needs dim 2 or 3, got dim={self.dim}")
        lo, hi = self.domain
        cells = math.prod(pd.grid_shape(hi - lo, self.r))
        if cells > MAX_GRID_CELLS:
            raise self.broken(self.limits[0], f"{cells} cells")
        if self.method == "gpu" and (hi - lo).min() * math.sqrt(self.dim) < self.r:
            raise self.broken(self.limits[1], f"a cell of {pd.cell_size(self.r, self.dim):g}")

    @property
    def domain(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) float64 of length dim."""
        lo = np.array([self.lo[min(a, 2)] if a < 3 else self.lo[0] for a in range(self.dim)])
        size = np.array([self.size[min(a, 2)] if a < 3 else self.size[0] for a in range(self.dim)])
        return lo, lo + size


class Simulation(BaseSimulation):
    """Reset: the grid and the first sample (bridson) or empty cells (gpu); each step: ``steps_per_frame`` sampler
    steps (``sample_step``), then, once the sampler is done, the gap fill when ``fill`` is set."""

    Params = Params

    def _reset(self) -> None:
        p = self.params
        self.lo, self.hi = p.domain
        self.gaps = np.zeros((0, p.dim))
        """The fill's samples (bridson: fill_gaps; gpu: those FillDarts wrote), in points() after the sampler's."""
        self.filled = False
        self.fill_boxes: list[int] = []
        """gpu fill: the boxes MarkUncovered kept in each round (the last is 0 when the fill finished)."""
        self.active_counts: list[int] = []
        self.seconds = 0.0
        """Wall time of the sampler (and fill) so far: the view's status line."""
        if p.method == "bridson":
            self.stepper = pd.BridsonStepper(self.lo, self.hi, p.r, p.k, self.seed, p.annulus)
        else:
            self._reset_gpu()

    # {{{ the gpu method: ThrowDarts, MarkUncovered, FillDarts, CompactSamples

    def _reset_gpu(self) -> None:
        p, rt = self.params, self.runtime
        self.program = rt.program("poisson_disk", DIM=p.dim)
        self.throw_darts = self.program.kernel("ThrowDarts")
        self.compact_samples = self.program.kernel("CompactSamples")
        self.mark_uncovered_kernel = self.program.kernel("MarkUncovered")
        self.fill_darts_kernel = self.program.kernel("FillDarts")
        extent = self.hi - self.lo
        self.cell = pd.cell_size(p.r, p.dim)
        dims = [math.ceil(e / self.cell) for e in extent] + [1] * (3 - p.dim)
        self.dims = cltypes.make_int4(*dims, 0)
        self.grid_dims = dims
        self.cell_count = math.prod(dims)
        self.cell_used = rt.zeros(self.cell_count, np.int32)
        self.cell_pts = rt.zeros(self.cell_count * 4, np.float32)
        self.samples_d = rt.empty(self.cell_count * 4, np.float32)
        self.sample_cells_d = rt.empty(self.cell_count, np.int32)
        self.counter = rt.zeros(2, np.int32)
        self.extent = cltypes.make_float4(*extent, *[0.0] * (4 - p.dim))
        self.key = cltypes.make_uint2(*key_of_seed(self.seed))
        self.rounds = 0
        self._compacted: tuple | None = None
        self.max_level = 30 // p.dim
        """The kernel's MAX_LEVEL: the finest fill boxes are 2^-max_level of a cell per axis."""
        phases = np.stack(np.meshgrid(*[np.arange(3)] * p.dim, indexing="ij"), -1).reshape(-1, p.dim)
        self.phases = [tuple(int(v) for v in ph) + (0,) * (3 - p.dim) for ph in phases[:, ::-1]]  # x fastest
        self.phase_dims = [
            [max(0, -(-(d - ph) // 3)) for d, ph in zip(dims, phase, strict=True)] for phase in self.phases
        ]
        """Cells of each phase per axis: those at phase + 3 i."""

    def throw_round(self) -> None:
        """One round: ThrowDarts over each phase in turn (the launches in between are the only synchronisation)."""
        p = self.params
        r2_reject = np.float32(p.r * p.r * R2_MARGIN)
        for phase, phase_dims in zip(self.phases, self.phase_dims, strict=True):
            n = math.prod(phase_dims)
            self.throw_darts.over(
                n, GROUP, self.cell_used, self.cell_pts, self.dims, cltypes.make_int4(*phase, 0),
                cltypes.make_int4(*phase_dims, 0), np.int32(n), np.uint32(self.rounds), self.key,
                np.float32(self.cell), self.extent, r2_reject,
            )  # fmt: skip
        self.rounds += 1

    def mark_uncovered(self, fill_round: int, level: int, split: bool, boxes_in, n_in: int) -> int:
        """MarkUncovered: the boxes of this fill round (level 0: the empty cells whole; else the children of the last
        round's boxes, or those boxes again when not ``split``) that no single sample covers, into
        ``self.boxes_out`` (grown and the round run again when they do not fit: the same boxes, any order), and each
        cell's chosen box in ``self.choice``. Returns how many were kept."""
        p = self.params
        capacity = self.boxes_out.size // 2
        while True:
            self.choice.fill(INT_MAX)
            self.counter.fill(0)
            self.mark_uncovered_kernel.over(
                n_in, GROUP, self.cell_used, self.cell_pts, self.dims, boxes_in, np.int32(n_in), np.int32(level),
                np.int32(split), self.boxes_out, self.counter, np.int32(capacity), self.choice,
                np.uint32(fill_round), self.key, np.float32(self.cell), self.extent, np.float32(p.r * p.r * R2_MARGIN),
            )  # fmt: skip
            kept, refused = (int(v) for v in self.counter.get())
            if not refused:
                return kept
            capacity = kept + refused  # the pool was too small: the same boxes again into one that fits them
            self.boxes_out = self.runtime.empty(2 * capacity, np.int32)

    def fill_darts(self, fill_round: int, level: int, n: int) -> None:
        """FillDarts over the n boxes of ``self.boxes_out``, once per phase (as ThrowDarts: no two darts of one
        launch within r of each other, and each launch sees the samples the earlier ones kept)."""
        p = self.params
        for phase in self.phases:
            self.fill_darts_kernel.over(
                n, GROUP, self.cell_used, self.cell_pts, self.dims, cltypes.make_int4(*phase, 0), self.boxes_out,
                np.int32(n), np.int32(level), self.choice, np.uint32(fill_round), self.key, np.float32(self.cell),
                self.extent, np.float32(p.r * p.r * R2_MARGIN),
            )  # fmt: skip

    def fill_gpu(self) -> None:
        """The fill on the device: round t = 0 marks the empty cells no sample covers whole, each later round splits
        the boxes left into 2^n children (down to max_level, then keeps them), and every round throws darts into one
        box per cell, until a round keeps no box (maximal) or MAX_FILL_ROUNDS ran (said in a warning)."""
        rt = self.runtime
        self.choice = rt.empty(self.cell_count, np.int32)
        # (cell id, packed sub-cell) pairs, two lists: a round reads the last one's and writes the other
        boxes_in, self.boxes_out = rt.empty(2 * self.cell_count, np.int32), rt.empty(2 * self.cell_count, np.int32)
        n, level = self.cell_count, 0
        for fill_round in range(MAX_FILL_ROUNDS):
            split = fill_round > 0 and level < self.max_level
            level += split
            n = self.mark_uncovered(fill_round, level, split, None if fill_round == 0 else boxes_in, n)
            self.fill_boxes.append(n)
            if n == 0:
                break
            self.fill_darts(fill_round, level, n)
            boxes_in, self.boxes_out = self.boxes_out, boxes_in
        if n:
            warnings.warn(
                f"poisson_disk fill: {n} boxes of {2.0**-level:g} of a cell still not covered after {MAX_FILL_ROUNDS} "
                "rounds (MAX_FILL_ROUNDS): the sampling may not be maximal there",
                RuntimeWarning, stacklevel=2,
            )  # fmt: skip
        del self.choice, self.boxes_out  # the fill's buffers live only while it runs
        points, _, from_fill = self.compact()
        self.gaps = points[from_fill]

    def compact(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CompactSamples, then a sort by cell id (append order varies): (points (N, dim) float64, cell ids, True
        where FillDarts placed the sample)."""
        if self._compacted is None or self._compacted[0] != (self.rounds, len(self.fill_boxes)):
            self.counter.fill(0)
            self.compact_samples.over(
                self.cell_count, GROUP, self.cell_used, self.cell_pts, np.int32(self.cell_count), self.samples_d,
                self.sample_cells_d, self.counter,
            )  # fmt: skip
            n = int(self.counter.get()[0])
            cells = self.sample_cells_d[:n].get()
            order = np.argsort(cells, kind="stable")
            local = self.samples_d[: 4 * n].get().reshape(-1, 4)[order]
            points = self.lo + local[:, : self.params.dim].astype(np.float64)
            self._compacted = ((self.rounds, len(self.fill_boxes)), points, cells[order], local[:, 3] == 1.0)
        return self._compacted[1:]

    # }}}

    # {{{ stepping

    @property
    def sampled(self) -> bool:
        """The sampler is done: the active list is empty (bridson) or k rounds ran (gpu)."""
        return self.stepper.done if self.params.method == "bridson" else self.rounds >= self.params.k

    @property
    def done(self) -> bool:
        return self.sampled and (self.filled or not self.params.fill)

    def sample_step(self) -> bool:
        """One sampler step: an active point and its k candidates (bridson) or one round of darts (gpu); then the
        fill once the sampler is done. False when there was nothing left to do."""
        if self.done:
            return False
        start = time.perf_counter()
        if not self.sampled:
            if self.params.method == "bridson":
                self.stepper.step()
                if self.params.record_steps:
                    self.active_counts.append(len(self.stepper.active))
            else:
                self.throw_round()
        elif not self.filled:
            if self.params.method == "bridson":
                self.gaps = pd.fill_gaps(self.sampler_points(), self.lo, self.hi, self.params.r, self.seed)
            else:
                self.fill_gpu()
            self.filled = True
        self.seconds += time.perf_counter() - start
        return True

    def finish(self) -> None:
        """Run the sampler (and the fill) to the end."""
        while self.sample_step():
            pass

    def _step(self, dt: float) -> None:
        n = self.params.steps_per_frame
        if n == 0:
            self.finish()
        else:
            for _ in range(n):
                if not self.sample_step():
                    break

    # }}}

    # {{{ results

    def sampler_points(self) -> np.ndarray:
        """The sampler's samples without the fill's: insertion order (bridson) or by cell (gpu)."""
        if self.params.method == "bridson":
            return self.stepper.points
        points, _, from_fill = self.compact()
        return points[~from_fill]

    def points(self) -> np.ndarray:
        """Every sample, (N, dim) float64: the sampler's, then the fill's."""
        return np.concatenate([self.sampler_points(), self.gaps])

    def active(self) -> np.ndarray:
        """Indices of the active samples (bridson; empty for gpu)."""
        return np.array(self.stepper.active if self.params.method == "bridson" else [], np.int32)

    def current(self) -> int:
        """The sample the last bridson step threw candidates around (-1 before the first and for gpu)."""
        return self.stepper.current if self.params.method == "bridson" else -1

    def grid(self) -> np.ndarray:
        """GetGrid's array (ceil(extent / cell) + 1 per axis): each sample's index in its cell, -1 elsewhere."""
        points = self.points()
        grid = np.full(pd.grid_shape(self.hi - self.lo, self.params.r), -1, np.int32)
        cells = np.floor((points - self.lo) / pd.cell_size(self.params.r, self.params.dim)).astype(np.int64)
        grid[tuple(cells.T)] = np.arange(len(points), dtype=np.int32)
        return grid

    def sampler_steps(self) -> int:
        return self.stepper.steps if self.params.method == "bridson" else self.rounds

    def scipy_points(self) -> np.ndarray:
        """scipy.stats.qmc.PoissonDisk on the same box, r and k (fill_space)."""
        from scipy.stats import qmc

        p = self.params
        engine = qmc.PoissonDisk(p.dim, radius=p.r, ncandidates=p.k, l_bounds=self.lo, u_bounds=self.hi, rng=self.seed)
        return engine.fill_space()

    may_be_infinite = ("nn_dist",)  # a lone sample (the first step) has no nearest other sample: inf

    def state(self) -> dict[str, np.ndarray]:
        points = self.points()
        state = {
            "points": points,
            "grid": self.grid(),
            "sampler_steps": np.int32(self.sampler_steps()),  # the sampler's "steps": the CLI records its own steps
            "nn_dist": pd.nearest_distances(points),
            "active": self.active(),
            "filled": np.int32(len(self.gaps)),
        }
        if self.params.record_steps:
            state["active_count"] = np.array(self.active_counts, np.int32)
        if self.params.compare_scipy:
            state["scipy_points"] = self.scipy_points()
        return state

    def stats(self) -> dict:
        points = self.points()
        return {
            **super().stats(),
            "method": self.params.method,
            "samples": len(points),
            "gap samples": len(self.gaps),
            "active": len(self.active()),
            "sampler steps": self.sampler_steps(),
            "done": self.done,
            "packing density": round(pd.packing_density(points, self.lo, self.hi, self.params.r), 4),
        } | self.fill_stats()

    def fill_stats(self) -> dict:
        """gpu fill: its rounds, and the boxes it left uncovered (0: maximal)."""
        if not self.fill_boxes:
            return {}
        return {"fill rounds": len(self.fill_boxes), "fill boxes left": self.fill_boxes[-1]}

    # }}}


SCENES = [
    Scene(
        "poisson_disk",
        Simulation,
        "Poisson disk sampling by Bridson's algorithm, 2-D discs (vol.4 ch.7)",
        defaults={"lo": (100.0, -100.0, 0.0), "size": (200.0, 200.0, 1.0), "r": 5.0, "radius_rate": 1.0},
        preview={"steps": 1},
        animation=Animation(
            "Bridson's sampler fills the box from one point, 36 active-point steps a frame",
            start=0,
            overrides={"steps_per_frame": 36},
        ),
    ),
    Scene(
        "poisson_disk_3d",
        Simulation,
        "Poisson disk sampling by Bridson's algorithm in a cube, spheres (vol.4 ch.7)",
        defaults={"dim": 3, "lo": (-100.0, -100.0, -100.0), "size": (200.0, 200.0, 200.0), "r": 10.0},
        view="View3D",
        preview={"steps": 1},
    ),
    Scene(
        "poisson_disk_gpu",
        Simulation,
        "Poisson disk sampling by multi-phase dart throwing on the GPU, 2-D discs (vol.4 ch.7)",
        defaults={
            "lo": (100.0, -100.0, 0.0),
            "size": (200.0, 200.0, 1.0),
            "r": 5.0,
            "radius_rate": 1.0,
            "method": "gpu",
        },  # fmt: skip
        preview={"steps": 1},
    ),
]
