"""Poisson disk sampling on the host: Bridson's "Fast Poisson Disk Sampling in Arbitrary Dimensions" as vol.4 ch.7
builds it (docs/chapters/18-poisson-disk.md), a gap-filling pass that makes its result maximal, and the measures the
chapter page and the bench report (uncovered fraction, packing density).

The chapter's steps (7.3.2 - 7.3.6), one dimension-generic class instead of the sample's 2-D and 3-D copies:

1. ``grid_shape``: cells of r / sqrt(n), ``ceil(extent / cell) + 1`` per axis (GetGrid; the +1 holds a 3-D point
   on the max face); at most one sample per cell, since the cell's diagonal is r.
2. ``BridsonStepper.__init__``: the first point, uniform in the box (GetFirstPoint).
3. ``BridsonStepper.step``: a random active point (7.3.4), k candidates in its r .. 2r annulus (GetNextPoint),
   each kept when it is inside the domain and no sample in the +-w cells around it is within r; **all k** are
   tried even after one is kept; the active point is dropped when none was kept (7.3.6).
4. ``bridson``: steps until the active list is empty (Sampling).

Random numbers come from ``numpy.random.Generator(PCG64(seed))`` in a fixed order per step: the active index, the
k radii, then the k directions (2-D: angles; 3-D: cos(theta), then phi; n >= 4: k x n normals). Unity's generator
cannot be reproduced, so results match the sample statistically, never point for point.
"""

from __future__ import annotations

import math

import numpy as np

ANNULI = ("area", "volume")
"""How a candidate's distance from its active point is drawn: ``area`` rho = sqrt(U[r^2, 4 r^2]) as the sample's
GetRandPosInSphere in 2-D and 3-D (uniform by area in 2-D, biased to the inner shell in 3-D); ``volume``
rho = U[r^n, (2r)^n]^(1/n), uniform in the n-ball shell."""


# {{{ the background grid (7.3.2)


def cell_size(r: float, dim: int) -> float:
    """The grid's cell edge r / sqrt(n): its diagonal is r, so a cell holds at most one sample (fig. 7.3)."""
    return r / math.sqrt(dim)


def grid_shape(extent, r: float) -> tuple[int, ...]:
    """GetGrid: ``CeilToInt(extent / cell) + 1`` cells per axis."""
    cell = cell_size(r, len(extent))
    return tuple(int(math.ceil(e / cell)) + 1 for e in extent)


def neighbour_window(dim: int) -> int:
    """Half-width of the cell scan around a candidate: the sample's +-2 (2-D) and +-3 (3-D), the prose's "+-n";
    ceil(sqrt(n)) beyond 3-D, the least that still reaches every sample within r (|dq| <= r = sqrt(n) cells)."""
    return dim if dim <= 3 else math.ceil(math.sqrt(dim))


def window_offsets(dim: int, w: int) -> np.ndarray:
    """Every cell offset in [-w, w]^dim, (2w + 1)^dim rows."""
    axes = np.meshgrid(*[np.arange(-w, w + 1)] * dim, indexing="ij")
    return np.stack([a.ravel() for a in axes], axis=1)


# }}}


def annulus_offsets(rng: np.random.Generator, r: float, count: int, dim: int, annulus: str = "area") -> np.ndarray:
    """``count`` offsets at distance r .. 2r (GetRandPosInSphere), drawn in the module's fixed order."""
    if annulus == "area":
        rho = np.sqrt(rng.uniform(r * r, 4.0 * r * r, count))
    elif annulus == "volume":
        rho = rng.uniform(r**dim, (2.0 * r) ** dim, count) ** (1.0 / dim)
    else:
        raise ValueError(f"annulus must be one of {'|'.join(ANNULI)}, got {annulus!r}")
    if dim == 2:
        theta = rng.uniform(0.0, 2.0 * math.pi, count)
        direction = np.column_stack([np.cos(theta), np.sin(theta)])
    elif dim == 3:
        cos_theta = rng.uniform(-1.0, 1.0, count)
        phi = rng.uniform(0.0, 2.0 * math.pi, count)
        sin_theta = np.sqrt(1.0 - cos_theta**2)
        direction = np.column_stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta])
    else:  # a normalised Gaussian is uniform on the sphere in any dimension
        normal = rng.standard_normal((count, dim))
        direction = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    return rho[:, None] * direction


def inside(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The sample's domain test: half-open [lo, hi) in 2-D (Rect.Contains), closed [lo, hi] beyond (Bounds.Contains)."""
    above = (points >= lo).all(axis=-1)
    below = (points < hi) if points.shape[-1] == 2 else (points <= hi)
    return above & below.all(axis=-1)


class BridsonStepper:
    """Bridson's algorithm one active-point step at a time (the sample's StepSampling coroutine): the viewer draws
    between steps; ``run()`` goes to the end. State: ``points`` (insertion order), ``grid`` (sample index or -1),
    ``active`` (sample indices, order kept on removal as the sample's RemoveAt), ``steps``."""

    def __init__(self, lo, hi, r: float, k: int = 30, seed: int = 0, annulus: str = "area"):
        self.lo, self.hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
        self.dim = len(self.lo)
        if self.lo.shape != self.hi.shape or self.dim < 2 or not (self.hi > self.lo).all():
            raise ValueError(f"need lo < hi per axis in 2 or more dimensions, got lo={lo}, hi={hi}")
        if not (r > 0 and k >= 1):
            raise ValueError(f"need r > 0 and k >= 1, got r={r}, k={k}")
        if annulus not in ANNULI:
            raise ValueError(f"annulus must be one of {'|'.join(ANNULI)}, got {annulus!r}")
        self.r, self.k, self.annulus = float(r), int(k), annulus
        self.cell = cell_size(self.r, self.dim)
        # The grid inside a border of w empty cells: the window never needs clamping and is one list of flat offsets.
        w = neighbour_window(self.dim)
        shape = np.array(grid_shape(self.hi - self.lo, self.r))
        padded = np.full(shape + 2 * w, -1, np.int32)
        self.grid = padded[(slice(w, -w),) * self.dim]
        """GetGrid's array: sample index or -1 (a view into the padded one)."""
        self._flat, self._shape = padded.reshape(-1), shape
        strides = np.array(padded.strides) // padded.itemsize
        self._window = window_offsets(self.dim, w) @ strides
        self._base = w * strides.sum()
        self._strides = strides
        self.rng = np.random.Generator(np.random.PCG64(seed))
        self._points = np.empty((1024, self.dim))
        self.count, self.steps = 0, 0
        self.active: list[int] = []
        self.current = -1
        """The sample the last step threw candidates around (-1 before the first step)."""
        self.added = 0
        """Samples the last step kept."""
        self._add(self.rng.uniform(self.lo, self.hi))  # GetFirstPoint

    @property
    def points(self) -> np.ndarray:
        return self._points[: self.count]

    @property
    def done(self) -> bool:
        return not self.active

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """GetGridIndex: floor((p - lo) / cell) per axis."""
        return np.floor((points - self.lo) / self.cell).astype(np.int64)

    def _add(self, p: np.ndarray) -> None:
        if self.count == len(self._points):
            self._points = np.concatenate([self._points, np.empty_like(self._points)])
        self._points[self.count] = p
        self.grid[tuple(self.cell_of(p))] = self.count
        self.active.append(self.count)
        self.count += 1

    def step(self) -> bool:
        """One active point, k candidates. False (and nothing drawn) once the active list is empty."""
        if not self.active:
            return False
        index = int(self.rng.integers(len(self.active)))
        self.current = self.active[index]
        candidates = self._points[self.current] + annulus_offsets(self.rng, self.r, self.k, self.dim, self.annulus)
        free = self.free_of_samples(candidates)
        kept: list[np.ndarray] = []
        r2 = self.r * self.r
        for p in candidates[free]:  # in order, each also against those kept before it in this step
            if all(((p - q) ** 2).sum() > r2 for q in kept):
                kept.append(p)
                self._add(p)
        if not kept:
            del self.active[index]
        self.added = len(kept)
        self.steps += 1
        return True

    def free_of_samples(self, candidates: np.ndarray) -> np.ndarray:
        """GetNextPoint's tests against the samples stored before this step: inside the domain and no sample of the
        +-w cells (clamped to the grid) within r (distance <= r rejects)."""
        ok = inside(candidates, self.lo, self.hi)
        cells = np.clip(self.cell_of(candidates), 0, self._shape - 1)  # those outside are rejected anyway
        ids = self._flat[(self._base + cells @ self._strides)[:, None] + self._window]  # (k, window cells)
        which, slot = np.nonzero(ids >= 0)  # (candidate, sample) pairs of the occupied cells only
        near = ((self._points[ids[which, slot]] - candidates[which]) ** 2).sum(axis=1) <= self.r * self.r
        blocked = np.bincount(which[near], minlength=len(candidates)) > 0
        return ok & ~blocked

    def run(self, max_steps: int | None = None) -> BridsonStepper:
        """Step until the active list is empty (or ``max_steps`` more steps ran)."""
        n = 0
        while self.active and (max_steps is None or n < max_steps):
            self.step()
            n += 1
        return self


def bridson(lo, hi, r: float, k: int = 30, seed: int = 0, annulus: str = "area") -> np.ndarray:
    """The chapter's Sampling: every sample, (N, n) float64 in insertion order."""
    return BridsonStepper(lo, hi, r, k, seed, annulus).run().points.copy()


# {{{ filling the gaps: maximal sampling (not in the book)


def _farthest_corner2(q: np.ndarray, box_lo: np.ndarray, box_hi: np.ndarray) -> np.ndarray:
    """Squared distance from points q (..., n) to the farthest corner of boxes (..., n)."""
    return (np.maximum(np.abs(q - box_lo), np.abs(q - box_hi)) ** 2).sum(axis=-1)


def _first_come(points: np.ndarray, r: float) -> np.ndarray:
    """Which of ``points`` to keep, in order, so that no two kept are within r: each is kept unless an earlier kept
    one is within r (pairs sorted by their later member, so the earlier one's fate is settled first)."""
    from scipy.spatial import cKDTree

    keep = np.ones(len(points), bool)
    pairs = cKDTree(points).query_pairs(r, output_type="ndarray")
    for i, j in pairs[np.lexsort((pairs[:, 0], pairs[:, 1]))]:
        if keep[i]:
            keep[j] = False
    return keep


def fill_gaps(points, lo, hi, r: float, seed: int = 0, max_depth: int = 24) -> np.ndarray:
    """Darts thrown into the uncovered parts of the domain until none is left: the new samples, (M, n) float64.

    Bridson's sampler stops when every active point failed k times, which leaves about 0.1 % of the area farther
    than r from every sample (a gap a further sample fits in). The pass starts from the background grid's cells
    that hold no sample, clipped to the domain. Each round drops the cells one disc of radius r covers whole,
    throws one dart into each of the rest (kept if farther than r from every sample, earlier darts of the round
    included), and splits what is left into 2^n children (Ebeida et al. 2011, "Efficient maximal Poisson-disk
    sampling"). After ``max_depth`` splits the cells are 2^-max_depth of a grid cell: what remains is below any
    probe's resolution."""
    from scipy.spatial import cKDTree

    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    points = np.asarray(points, np.float64).reshape(-1, len(lo))
    dim, r2 = len(lo), r * r
    rng = np.random.Generator(np.random.PCG64(seed))
    size = cell_size(r, dim)
    shape = grid_shape(hi - lo, r)
    occupied = np.zeros(shape, bool)
    occupied[tuple(np.floor((points - lo) / size).astype(np.int64).T)] = True
    corners = lo + np.argwhere(~occupied) * size
    cells = corners[(corners < hi).all(axis=1)]
    children = window_offsets(dim, 1)[(window_offsets(dim, 1) >= 0).all(axis=1)]  # {0, 1}^n
    found: list[np.ndarray] = []
    tree = cKDTree(points) if len(points) else None
    nearest = min(8, max(len(points), 1))
    for _ in range(max_depth + 1):
        if not len(cells):
            break
        box_lo, box_hi = cells, np.minimum(cells + size, hi)
        if tree is not None:  # a cell inside one disc holds no gap: test its few nearest samples
            _, ids = tree.query((box_lo + box_hi) / 2, k=nearest)
            ids = ids.reshape(len(cells), -1)
            covered = (_farthest_corner2(tree.data[ids], box_lo[:, None], box_hi[:, None]) <= r2).any(axis=1)
            cells, box_lo, box_hi = cells[~covered], box_lo[~covered], box_hi[~covered]
        darts = box_lo + rng.random(box_lo.shape) * (box_hi - box_lo)
        darts = darts[inside(darts, lo, hi)]
        if tree is not None and len(darts):
            distance, _ = tree.query(darts)
            darts = darts[distance > r]
        kept = darts[_first_come(darts, r)] if len(darts) else darts
        if len(kept):
            found.append(kept)
            points = np.concatenate([points, found[-1]])
            tree = cKDTree(points)
            nearest = min(8, len(points))
        size /= 2.0
        cells = (cells[:, None, :] + children * size).reshape(-1, dim)
        cells = cells[(cells < hi).all(axis=1)]
    return np.concatenate(found) if found else np.zeros((0, dim))


# }}}

# {{{ measures


def uncovered_fraction(points, lo, hi, r: float, probes: int = 200_000, seed: int = 1) -> float:
    """Share of uniform probe points farther than r from every sample: the area a further sample would fit in (0
    for a maximal sampling)."""
    from scipy.spatial import cKDTree

    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    probe = np.random.Generator(np.random.PCG64(seed)).uniform(lo, hi, (probes, len(lo)))
    distance, _ = cKDTree(np.asarray(points, np.float64)).query(probe)
    return float((distance > r).mean())


def packing_density(points, lo, hi, r: float) -> float:
    """N times the volume of an n-ball of radius r/2, over the domain's volume: the share the non-overlapping
    spheres of diameter r fill (2-D random sequential adsorption saturates at 0.547)."""
    dim = np.asarray(lo).size
    ball = math.pi ** (dim / 2) / math.gamma(dim / 2 + 1) * (r / 2) ** dim
    return len(points) * ball / float(np.prod(np.asarray(hi, np.float64) - np.asarray(lo, np.float64)))


def min_distance(points) -> float:
    """Smallest distance between two samples (inf for fewer than two)."""
    from scipy.spatial import cKDTree

    points = np.asarray(points, np.float64)
    if len(points) < 2:
        return math.inf
    distance, _ = cKDTree(points).query(points, k=2)
    return float(distance[:, 1].min())


def nearest_distances(points) -> np.ndarray:
    """Each sample's distance to its nearest other sample (the .npz's nn_dist; inf for a lone sample)."""
    from scipy.spatial import cKDTree

    points = np.asarray(points, np.float64)
    if len(points) < 2:
        return np.full(len(points), np.inf)
    distance, _ = cKDTree(points).query(points, k=2)
    return distance[:, 1]


# }}}
