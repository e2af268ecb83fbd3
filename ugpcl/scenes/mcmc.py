"""3D spatial sampling with MCMC: Metropolis chains on a simplex-noise density, the rejection sampler and the Monte
Carlo pi estimate (vol.1 ch.8; docs/chapters/08-mcmc.md).

``mode=metropolis``: ``Prepare`` fills the L^3 lattice with Perlin's simplex noise W; ``Sequence`` runs one chain per
work-item: Reset (uniform start points until D > 0), ``burn_in`` Next steps, then ``samples`` times (emit, Next),
where Next proposes x + N(0, sigma^2 C) and keeps it iff ``D(x) <= 0 or min(1, D(x')/D(x)) >= U`` and
``D(x') > threshold`` (the book's code: ``>=``, not the text's ``>``). D is the code's unnormalised sum
``sum_i exp(-|x - p_i|^2) W_i`` (the text calls it an inverse-distance weighted average): ``density=exact`` truncates
it at |x - p_i|^2 <= 25, ``legacy`` is the book's estimate from 500 random lattice picks, ``grid`` looks it up
trilinearly in a precomputed ``DensityGrid``, ``gaussian`` is an analytic test target. ``mode=rejection``:
``RejectionSequence`` keeps uniform points whose clamped noise exceeds a threshold. ``mode=pi``: ``MonteCarloPi``.

Every random number comes from Philox (clkernels/include/random.h) by what it is for, so the tests' numpy twin
(tests/reference/mcmc.py) redraws any chain. The simulation samples everything at
reset; ``step`` only advances the clock that reveals chains and rejection batches (the sample's demo: one chain
per 0.1 s; here 600 within 0.1 s by default, ``chains_per_second``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..random import key_of_seed, philox4x32, uniform01
from ..resources import Allocation
from ..scene import Animation, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

PERLIN_T = (0x15, 0x38, 0x32, 0x2C, 0x0D, 0x13, 0x07, 0x2A)
"""Perlin's published table of the reference simplex noise (the book's generator fills T with unseeded randoms)."""
DENSITY_MODES = ("exact", "legacy", "grid", "gaussian")
"""Index = the kernel's DENSITY_* constant."""
PURPOSE_STEP_XY, PURPOSE_STEP_Z, PURPOSE_RESET, PURPOSE_PALETTE = 0, 1, 2, 3
"""Fourth Philox counter word: what a draw is for (mcmc.cl PURPOSE_*)."""
PURPOSE_REJECTION, PURPOSE_PI, PURPOSE_LEGACY = 4, 5, 6
LEGACY_RESET_INDEX = 0x80000000
"""Counter index of the legacy picks of reset try t: LEGACY_RESET_INDEX + t (steps use 0, 1, ...)."""
TRUNCATION_RADIUS = 5.0
"""density=exact leaves out lattice points with |x - p|^2 > 25: each weighs exp(-25) = 1.4e-11."""
GRID_MARGIN = 3
"""Dgrid reaches this many lattice units beyond [0, L-1] on each side (exp(-9) = 1.2e-4 at its edge; 0 outside)."""
PI_POINTS_PER_ITEM = 64
"""Points each MonteCarloPi work-item tests (two per Philox draw)."""
PI_GROUP_SIZE = 256
"""MonteCarloPi's work-group (tree reduction); halved where the device cannot run it."""
GROUP_SIZE = 64
MAX_STATES = 33554432
"""Most chain states one run keeps (chains x samples, 12 bytes each: 400 MB)."""
PALETTE = (
    (1.0, 1.0, 1.0),
    (1.0, 0.0, 0.0),
    (0.0, 1.0, 1.0),
    (0.0, 1.0, 0.0),
    (1.0, 0.848, 0.0),
    (1.0, 0.0, 0.0),
    (0.117, 0.0, 1.0),
    (1.0, 0.609, 1.0),
    (0.0, 0.303, 0.0),
)
"""The sample's cube materials mat1..mat9 (mat2 and mat6 are both red); rejection points use mat1."""


@dataclass(frozen=True)
class Params(BaseParams):
    limits = (
        f"chains*samples <= {MAX_STATES}",
        "(L+5)*oversample <= 400 with density=grid",
        "batches*limit <= 16777216",
    )

    mode: str = param("metropolis", choices=("metropolis", "rejection", "pi"))
    """Which of the chapter's samplers runs: Metropolis chains, the rejection sampler, or the pi estimate."""
    L: int = param(30, 2, 128)
    """Lattice edge: L^3 noise weights at integer points, chains start in [0, L)^3 (book: lEdge, scene 30); also the
    rejection output scale (Rejection3d lEdge, 20)."""
    chains: int = param(600, 1, 1 << 22, used_only_when={"mode": "metropolis"})
    """Number of independent chains C, one work-item each (book: loop, scene 600)."""
    burn_in: int = param(100, 0, 100000, used_only_when={"mode": "metropolis"})
    """Next steps before a chain emits (book: nInitialize)."""
    samples: int = param(20, 1, 10000, used_only_when={"mode": "metropolis"})
    """States each chain emits, rejected steps repeating the state (book: nlimit, scene 20)."""
    sigma: float = param(1.0, 0.01, 100.0, used_only_when={"mode": "metropolis"})
    """Proposal standard deviation in lattice units (book: standard normal, 1). Small values give the tight
    "plants and flowers" clusters of section 8.6."""
    correlation: tuple[float, float, float] = param((0.0, 0.0, 0.0), -0.99, 0.99, used_only_when={"mode": "metropolis"})
    """Proposal correlations (xy, xz, yz): covariance sigma^2 R, factored by Cholesky (book: GenerateRandomPoint,
    without its m21-for-m20 bug). R must be positive definite."""
    threshold: float = param(-100.0, -1e6, 1e6, used_only_when={"mode": "metropolis"})
    """Hard floor: a proposal is kept only if D(x') > threshold (book: threshold, -100 = off). Above 0 the target
    region can fall apart into pieces no chain crosses (section 8.4.3, irreducibility)."""
    density: str = param("exact", choices=DENSITY_MODES)
    """Target density: exact (truncated lattice sum), legacy (the book's 500 random picks), grid (trilinear lookup
    in a precomputed grid), gaussian (analytic test target)."""
    legacy_picks: int = param(500, 1, 100000, used_only_when={"density": "legacy"})
    """Lattice points per legacy density estimate (book: weightReferenceloopCount)."""
    oversample: int = param(4, 1, 16, used_only_when={"density": "grid"})
    """Grid points per lattice unit of density=grid (whose grid has ((L + 5) oversample + 1)^3 points)."""
    target_mean: tuple[float, float, float] = param(
        (10.0, 10.0, 10.0), -1e4, 1e4, used_only_when={"density": "gaussian"}
    )
    """Mean of the gaussian target."""
    target_sigma: float = param(2.0, 0.01, 1e4, used_only_when={"density": "gaussian"})
    """Standard deviation of the gaussian target (per axis)."""
    reset_limit: int = param(100, 1, 100000, used_only_when={"mode": "metropolis"})
    """Most start points a chain draws looking for D > 0 (book: limitResetLoopCount)."""
    noise_T: str = param("perlin", choices=("perlin", "random"))
    """Noise table: Perlin's published one, or 8 values drawn from the seed (the book: unseeded randoms)."""
    batches: int = param(600, 1, 100000, used_only_when={"mode": "rejection"})
    """Rejection batches (book: loop, scene 600)."""
    limit: int = param(1000, 1, 1000000, used_only_when={"mode": "rejection"})
    """Candidates per rejection batch (book: limit)."""
    noise_scale: float = param(10.0, 1e-3, 1e4, used_only_when={"mode": "rejection"})
    """Rejection candidates u in [0, 1)^3 are tested at noise(u * noise_scale) (book: pnoiseScale)."""
    rejection_threshold: float = param(0.15, -1.0, 1.0, used_only_when={"mode": "rejection"})
    """Keep a candidate if clamp(noise, 0, 1) > this (book: 0.75 class, 0.25 scene: the noise never reaches 0.34,
    so both keep almost nothing; 0.15 keeps about 10%)."""
    n: int = param(16777216, 1, (1 << 31) - 1, used_only_when={"mode": "pi"})
    """Points of the pi estimate (mode=pi)."""
    chains_per_second: float = param(6000.0, 0.1, 1e6, live=True, used_only_when={"mode": "metropolis"})
    """How fast the view reveals the chains, per second of the run's clock (every chain is sampled at reset). The
    sample's demo waits 0.1 s per chain (10: a minute for its 600, two chains after a 10-step run); the default
    shows 600 chains within 0.1 s (6 frames), so that a short run and its picture show the whole sample."""
    batches_per_second: float = param(6000.0, 0.1, 1e6, live=True, used_only_when={"mode": "rejection"})
    """How fast the view reveals the rejection batches, per second of the run's clock (all are drawn at reset). The
    sample waits 0.001 s per batch, i.e. one a frame (60: 10 s for its 600); the default shows 600 within 0.1 s."""

    def check(self) -> None:
        if self.chains * self.samples > MAX_STATES:
            raise self.broken(f"chains*samples <= {MAX_STATES}", f"{self.chains * self.samples} states")
        if self.density == "grid" and (self.L + 5) * self.oversample > 400:
            raise self.broken("(L+5)*oversample <= 400 with density=grid")
        if self.batches * self.limit > 16777216:
            raise self.broken("batches*limit <= 16777216", f"{self.batches * self.limit} candidates")
        try:
            self.cholesky()
        except np.linalg.LinAlgError:
            raise ValueError(f"correlation must make a positive definite matrix, got {self.correlation}") from None

    def cholesky(self) -> np.ndarray:
        """Lower-triangular Lc with Lc Lc^T = sigma^2 R: the proposal is x + Lc z, z standard normal."""
        xy, xz, yz = self.correlation
        r = np.array([[1.0, xy, xz], [xy, 1.0, yz], [xz, yz, 1.0]])
        return np.linalg.cholesky(r) * self.sigma


def noise_table(name: str, seed: int) -> np.ndarray:
    """The 8-entry table T: Perlin's, or 8 values in [0, 64) drawn from the seed (only bits 0..5 of the sum matter)."""
    if name == "perlin":
        return np.array(PERLIN_T, np.int32)
    return np.random.default_rng(seed).integers(0, 64, 8).astype(np.int32)


class Simulation(BaseSimulation):
    """The mode's sampler, run at reset; ``step`` reveals its output over time."""

    Params = Params

    @classmethod
    def allocations(cls, params: Params) -> list[Allocation]:
        """The lattice, the density grid (density=grid) and the mode's output: the chains' samples or the
        rejection's candidates (a point and an id each)."""
        p, m = params, (params.L - 1 + 2 * GRID_MARGIN) * params.oversample + 1
        out = [Allocation("noise lattice", p.L**3 * 4, "L")]
        if p.density == "grid":
            out.append(Allocation("density grid", m**3 * 4, "oversample"))
        if p.mode == "metropolis":
            out.append(Allocation("chain samples", p.chains * (p.samples * 12 + 13), "chains"))
        elif p.mode == "rejection":
            out.append(Allocation("rejection candidates", p.batches * p.limit * 16, "batches"))
        return out

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.pi_group, self.program = rt.fitted_program(
            "mcmc", ("MonteCarloPi",), PI_GROUP_SIZE, define="PI_GROUP_SIZE"
        )
        self.key = key_of_seed(self.seed)
        self.key_arg = cltypes.make_uint2(*(int(k) for k in self.key))
        self.T = noise_table(p.noise_T, self.seed)
        self.T_buffer = rt.to_device(self.T)
        self.prepare()
        self.grid = None
        if p.density == "grid":  # Sequence and DensityAt (the view's slice, in every mode) read it
            self.density_grid()
        if p.mode == "metropolis":
            self.chain_buffers()
            self.sequence()
        elif p.mode == "rejection":
            self.rejection_sequence()
        else:
            self.monte_carlo_pi()

    def chain_buffers(self) -> None:
        """What Sequence writes per chain: the emitted states (C, S, 3), accepted steps, reset tries, the start's
        density and the palette entry."""
        p, rt = self.params, self.runtime
        C, S = p.chains, p.samples
        self.samples_buffer = rt.empty((C, S, 3), np.float32)
        self.accepted = rt.empty(C, np.uint32)
        self.reset_tries = rt.empty(C, np.uint32)
        self.init_density = rt.empty(C, np.float32)
        self.palette = rt.empty(C, np.uint8)

    # {{{ kernels, in the host's order

    def prepare(self) -> None:
        """Prepare: W[z, y, x] = noise(x, y, z) on the L^3 lattice."""
        L = self.params.L
        self.W = self.runtime.empty((L, L, L), np.float32)
        self.program.kernel("Prepare").over((L, L, L), (4, 4, 4), self.W, np.int32(L), self.T_buffer)

    def grid_geometry(self) -> tuple[int, float, float]:
        """(M, origin, oversample) of Dgrid: M^3 points from origin with spacing 1 / oversample."""
        p = self.params
        return (p.L - 1 + 2 * GRID_MARGIN) * p.oversample + 1, -float(GRID_MARGIN), float(p.oversample)

    def density_grid(self) -> None:
        """DensityGrid: the exact density on the grid density=grid reads."""
        M, origin, oversample = self.grid_geometry()
        self.grid = self.runtime.empty((M, M, M), np.float32)
        self.program.kernel("DensityGrid").over(
            (M, M, M),
            (4, 4, 4),
            self.W,
            np.int32(self.params.L),
            self.grid,
            np.int32(M),
            np.float32(origin),
            np.float32(1.0 / oversample),
        )

    def _density_args(self) -> tuple:
        p = self.params
        M, origin, oversample = self.grid_geometry()
        return (
            np.int32(DENSITY_MODES.index(p.density)),
            self.grid if p.density == "grid" else self.W,
            np.int32(p.L),
            np.int32(M),
            np.float32(origin),
            np.float32(oversample),
            np.int32(p.legacy_picks),
            cltypes.make_float4(*p.target_mean, p.target_sigma),
        )

    def sequence(self, batch: int = 0) -> None:
        """Sequence: every chain's Reset, burn-in and emitted states (batch: another set of random numbers)."""
        p = self.params
        C, S = p.chains, p.samples
        lc = p.cholesky()
        cholesky = cltypes.make_float8(lc[0, 0], lc[1, 0], lc[1, 1], lc[2, 0], lc[2, 1], lc[2, 2], 0.0, 0.0)
        self.program.kernel("Sequence").over(
            C,
            GROUP_SIZE,
            *self._density_args(),
            self.key_arg,
            np.uint32(batch),
            np.int32(C),
            np.int32(p.burn_in),
            np.int32(S),
            np.float32(p.threshold),
            np.int32(p.reset_limit),
            np.float32(p.L),
            cholesky,
            self.samples_buffer,
            self.accepted,
            self.reset_tries,
            self.init_density,
            self.palette,
        )

    def rejection_sequence(self, cap: int | None = None) -> None:
        """RejectionSequence over the batches * limit candidates (ids 0, 1, ...), appending at most ``cap`` points
        (default: all of them); the counter still counts every acceptance."""
        p, rt = self.params, self.runtime
        self.n_candidates = p.batches * p.limit
        self.cap = self.n_candidates if cap is None else cap
        self.points_buffer = rt.empty((max(self.cap, 1), 3), np.float32)
        self.cand_buffer = rt.empty(max(self.cap, 1), np.uint32)
        self.counter = rt.zeros(1, np.uint32)
        self.program.kernel("RejectionSequence").over(
            self.n_candidates,
            GROUP_SIZE,
            self.key_arg,
            np.uint32(0),
            np.int32(self.n_candidates),
            np.float32(p.noise_scale),
            np.float32(p.rejection_threshold),
            np.float32(p.L),
            self.T_buffer,
            self.points_buffer,
            self.cand_buffer,
            self.counter,
            np.uint32(self.cap),
        )

    def monte_carlo_pi(self, batch: int = 0) -> None:
        """MonteCarloPi: hits among n points of the unit square, summed per work-group then atomically."""
        n = self.params.n
        items = -(-n // PI_POINTS_PER_ITEM)
        self.hits = self.runtime.zeros(1, np.uint32)
        self.program.kernel("MonteCarloPi").over(
            items,
            self.pi_group,
            self.key_arg,
            np.uint32(batch),
            np.int32(PI_POINTS_PER_ITEM),
            np.uint64(n),
            self.hits,
        )

    def noise_at(self, points) -> np.ndarray:
        """NoiseAt: the simplex noise at each point (n, 3)."""
        pts = np.ascontiguousarray(points, np.float32).reshape(-1, 3)
        out = self.runtime.empty(len(pts), np.float32)
        if len(pts):
            self.program.kernel("NoiseAt").over(
                len(pts), GROUP_SIZE, self.runtime.to_device(pts), np.int32(len(pts)), self.T_buffer, out
            )
        return out.get()

    def density_at(self, points, batch: int = 0) -> np.ndarray:
        """DensityAt: the current density mode at each point (n, 3) (legacy: point i draws chain i's picks)."""
        pts = np.ascontiguousarray(points, np.float32).reshape(-1, 3)
        out = self.runtime.empty(len(pts), np.float32)
        if len(pts):
            self.program.kernel("DensityAt").over(
                len(pts),
                GROUP_SIZE,
                *self._density_args(),
                self.key_arg,
                np.uint32(batch),
                self.runtime.to_device(pts),
                np.int32(len(pts)),
                out,
            )
        return out.get()

    # }}}

    def _step(self, dt: float) -> None:
        """Nothing to run: the samplers ran at reset, and the reveal clock is the step's time."""

    def revealed(self) -> int:
        """Chains (metropolis) or batches (rejection) the view shows at the current time."""
        p = self.params
        if p.mode == "metropolis":
            return min(p.chains, int(self.time * p.chains_per_second) + 1)
        return min(p.batches, int(self.time * p.batches_per_second) + 1)

    def lattice(self) -> np.ndarray:
        return self.W.get()

    def rejection_points(self) -> tuple[np.ndarray, np.ndarray]:
        """(points (K, 3), cand_id (K,)) sorted by candidate id; K = min(accepted, cap)."""
        k = min(int(self.counter.get()[0]), self.cap)
        ids = self.cand_buffer.get()[:k]
        order = np.argsort(ids, kind="stable")
        return self.points_buffer.get()[:k][order], ids[order]

    def pi_estimate(self) -> tuple[float, int]:
        hits = int(self.hits.get()[0])
        return 4.0 * hits / self.params.n, hits

    def state(self) -> dict[str, np.ndarray]:
        p = self.params
        out = {"lattice_w": self.lattice(), "noise_T": self.T.copy()}
        if p.mode == "metropolis":
            accepted = self.accepted.get()
            out |= {
                "samples": self.samples_buffer.get(),
                "accepted": accepted,
                "reset_tries": self.reset_tries.get(),
                "init_density": self.init_density.get(),
                "palette": self.palette.get(),
                "acceptance_rate": np.float64(accepted.sum(dtype=np.int64) / (p.chains * (p.burn_in + p.samples))),
            }
        elif p.mode == "rejection":
            points, ids = self.rejection_points()
            out |= {
                "points": points,
                "cand_id": ids,
                "n_candidates": np.int64(self.n_candidates),
                "n_accepted": np.int64(self.counter.get()[0]),
            }
        else:
            estimate, hits = self.pi_estimate()
            out |= {"pi_estimate": np.float64(estimate), "hits": np.int64(hits), "n": np.int64(p.n)}
        return out

    def stats(self) -> dict:
        p = self.params
        s = {**super().stats(), "mode": p.mode}
        if p.mode == "metropolis":
            accepted = self.accepted.get()
            s |= {
                "density": p.density,
                "chains shown": self.revealed(),
                "chains": p.chains,
                "acceptance rate": float(accepted.sum(dtype=np.int64) / (p.chains * (p.burn_in + p.samples))),
                "failed resets": int((self.init_density.get() <= 0).sum()),
            }
        elif p.mode == "rejection":
            accepted = int(self.counter.get()[0])
            s |= {
                "batches shown": self.revealed(),
                "accepted": accepted,
                "candidates": self.n_candidates,
                "acceptance rate": accepted / self.n_candidates,
            }
        else:
            estimate, hits = self.pi_estimate()
            s |= {"pi estimate": estimate, "hits": hits, "n": p.n}
        return s

    def pi_points(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """The first ``count`` points of the pi estimate (numpy twin of MonteCarloPi's draws) and whether each hit."""
        g = np.arange(count // 2 + 1) // (PI_POINTS_PER_ITEM // 2)
        d = np.arange(count // 2 + 1) % (PI_POINTS_PER_ITEM // 2)
        counters = np.column_stack([g, d, np.zeros_like(g), np.full_like(g, PURPOSE_PI)]).astype(np.uint32)
        u = uniform01(philox4x32(counters, self.key)).reshape(-1, 2)[:count]
        return u, (u * u).sum(axis=1, dtype=np.float32) <= np.float32(1.0)


SCENES = [
    Scene(
        "mcmc",
        Simulation,
        "Metropolis chains sampling a simplex-noise density, one colour per chain (vol.1 ch.8)",
        preview={"steps": 60},
        animation=Animation(
            "the Metropolis chains appear (800 a second instead of the book's 10) while the camera swings",
            start=0,
            swing=30.0,
            quality=60,  # 12,000 small cubes: at 70 the loop is 410 KB
            overrides={"chains_per_second": 800.0},
        ),
    ),
    Scene(
        "mcmc_rejection",
        Simulation,
        "Rejection sampling of the noise superlevel set {noise > 0.15}, for comparison (vol.1 ch.8)",
        defaults={"mode": "rejection", "L": 20},
        preview={"steps": 60},
    ),
]
