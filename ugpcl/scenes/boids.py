"""Boids on the GPU: Reynolds flocking of N boids in a box (vol.1 ch.3; docs/chapters/03-boids.md).

Kernel order per step: ``ForceCS`` (steering forces against all N boids through ``__local`` tiles) then
``IntegrateCS`` (wall avoidance, speed limit, explicit Euler). The variant picks the ForceCS kernel, the same on
every device: ``tiled`` is the book's ``ForceCS``; ``lanes`` is ``ForceCS_cpu``, 16 boids per work-item in vector
lanes, no local memory, no barriers; ``naive`` is ``ForceCS_naive``, the same sums without local memory; ``grid`` is
``ForceCS_grid``, which visits only the boids in the 27 uniform-grid cells around each boid (the chapter's summary,
vol.1 ch.3 section 3.5, suggests it). ``auto`` (default) runs ``tiled`` on GPUs and Oclgrind and ``lanes`` on CPU
devices (PoCL), where barriers cost a work-group loop per tile; ``stats()["ForceCS kernel"]`` names the kernel that
ran.

Differences from the book: N need not be a multiple of the block size (the book dispatches floor(N/256) groups
and reads past the buffer otherwise); a rule whose mean direction is the zero vector steers by 0 instead of
``normalize(0)`` = NaN; the block size drops to the device's limit (halving) when 256 does not fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import ordered_floats
from ..grid import UniformGrid
from ..scene import Animation, AtScale, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

BOID_DTYPE = np.dtype([("velocity", "<f4", 4), ("position", "<f4", 4)])
"""Mirror of ``Boid`` in clkernels/include/boid.h (32 bytes)."""
MAX_GRID_CELLS = 1 << 21
"""Cap on the cells of variant=grid (the book's box with radius 2 needs 16^3 = 4096)."""
CPU_LANES = 16
"""Boids per work-item of ForceCS_cpu (CPU_LANES in clkernels/boids.cl)."""
FORCE_KERNELS = {"tiled": "ForceCS", "lanes": "ForceCS_cpu", "naive": "ForceCS_naive", "grid": "ForceCS_grid"}
"""The ForceCS kernel of each variant; ``auto`` takes the device's (``Simulation.auto_kernel``)."""

INIT_POSITION_RADIUS = 1.0
"""Boids start uniformly inside a ball of this radius (book: Random.insideUnitSphere * 1.0)."""
INIT_SPEED = 0.1
"""Initial velocities are uniform inside a ball of this radius (book: Random.insideUnitSphere * 0.1)."""


@dataclass(frozen=True)
class Params(BaseParams):
    max_object_num: int = param(16384, 1, 1 << 22)
    """Number of boids N (book: MaxObjectNum, inspector range 256-32768)."""
    cohesion_neighborhood_radius: float = param(2.0, 0.0, 1e4, lo_open=True, live=True)
    """Neighbours closer than this pull towards their centroid, world units (book: _CohesionNeighborhoodRadius).
    Up to 1e4: squared in float32."""
    alignment_neighborhood_radius: float = param(2.0, 0.0, 1e4, lo_open=True, live=True)
    """Neighbours closer than this share their mean velocity, world units (book: _AlignmentNeighborhoodRadius).
    Up to 1e4: squared in float32."""
    separate_neighborhood_radius: float = param(1.0, 0.0, 1e4, lo_open=True, live=True)
    """Neighbours closer than this push apart, world units (book: _SeparateNeighborhoodRadius).
    Up to 1e4: squared in float32."""
    max_speed: float = param(5.0, 0.0, 1e4, lo_open=True, live=True)
    """Speed limit and target speed of every steering rule, units/s (book: _MaxSpeed).
    Up to 1e4: |v|^2 stays finite in float32."""
    max_steer_force: float = param(0.5, 0.0, 1e4, live=True)
    """Length limit of each rule's steering force (book: _MaxSteerForce).
    Up to 1e4: weighted sums of forces stay finite in float32."""
    cohesion_weight: float = param(1.0, 0.0, 1e4, live=True)
    """Weight of the cohesion force (book: _CohesionWeight).
    Up to 1e4: weight x max_steer_force stays finite in float32."""
    alignment_weight: float = param(1.0, 0.0, 1e4, live=True)
    """Weight of the alignment force (book: _AlignmentWeight). Up to 1e4, as cohesion_weight."""
    separate_weight: float = param(3.0, 0.0, 1e4, live=True)
    """Weight of the separation force (book: _SeparateWeight). Up to 1e4, as cohesion_weight."""
    avoid_wall_weight: float = param(10.0, 0.0, 1e4, live=True)
    """Push back per axis while a boid is outside the box (book: _AvoidWallWeight). Up to 1e4, as cohesion_weight."""
    wall_center: tuple[float, float, float] = param((0.0, 0.0, 0.0), -1e4, 1e4, live=True)
    """Centre of the box, world units (book: _WallCenter). Within 1e4: float32 positions keep 1e-3."""
    wall_size: tuple[float, float, float] = param((32.0, 32.0, 32.0), 0.0, 1e4, lo_open=True, live=True)
    """Edge lengths of the box, world units (book: _WallSize). Up to 1e4: float32 positions keep 1e-3."""
    simulation_block_size: int = param(256, choices=(1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024))
    """Work-group size = tile length of ForceCS (book: SIMULATION_BLOCK_SIZE); halved if the device cannot run it."""
    object_scale: tuple[float, float, float] = param((0.1, 0.2, 0.5), 0.0, 1e4, lo_open=True, live=True)
    """Scale of the instanced cube drawn per boid, render only (book: ObjectScale). Up to 1e4, as wall_size."""
    variant: str = param("auto", choices=("auto", "tiled", "lanes", "naive", "grid"), live=True)
    """ForceCS kernel: tiled = the book's local-memory tiles with barriers (ForceCS), lanes = 16 boids per work-item
    in vector lanes (ForceCS_cpu), naive = the plain global-memory loop, grid = the uniform grid; auto = tiled on a
    GPU, lanes on a CPU device. The same forces up to float rounding."""
    start: str = param("book", choices=("book", "spread"))
    """Where the boids start: book = uniform in a ball of radius 1 (Random.insideUnitSphere); spread = uniform in the
    wall box, as a flock that has spread out (at a million boids the book's ball puts every boid in every other's
    radius, so the large sizes of the grid start spread)."""


class Simulation(BaseSimulation):
    """N boids: ForceCS then IntegrateCS each step."""

    Params = Params
    history = ("position", "velocity")

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.n = p.max_object_num
        # largest power of two <= simulation_block_size that the device runs ForceCS with
        # (docs/chapters/03-boids.md, "What differs from the book")
        self.block_size, self.program = rt.fitted_program(
            "boids", ("ForceCS",), p.simulation_block_size, define="SIMULATION_BLOCK_SIZE"
        )
        # what variant=auto runs: the book's barrier-synchronised tiles cost PoCL a work-group loop per tile, so CPU
        # devices get the vector-lane kernel (variant=lanes); GPUs and Oclgrind (which checks them) the tiles
        cpu = bool(rt.device.type & cl.device_type.CPU) and not rt.is_oclgrind
        self.auto_kernel = FORCE_KERNELS["lanes" if cpu else "tiled"]
        boids = initial_boids(self.n, self.seed)
        if p.start == "spread":
            boids["position"][:, :3] = spread_positions(self.n, self.seed, p.wall_center, p.wall_size)
        self.boid_data = rt.to_device(boids)
        self.boid_force = rt.zeros(self.n, cltypes.float4)
        self.grid = None  # built on first use by variant=grid
        self.packed = None  # PackBoidsHalf's output, made on first use (a view's)

    # {{{ kernels, in the book's order

    def _rules(self) -> tuple:
        p = self.params
        return tuple(
            np.float32(v)
            for v in (
                p.separate_neighborhood_radius,
                p.alignment_neighborhood_radius,
                p.cohesion_neighborhood_radius,
                p.max_speed,
                p.max_steer_force,
                p.separate_weight,
                p.alignment_weight,
                p.cohesion_weight,
            )
        )

    def force_cs(self) -> None:
        """ForceCS (ForceCS_naive, ForceCS_grid): steering force of every boid against its neighbours."""
        variant = self.params.variant
        name = self.force_kernel()
        boids, grid_args = self.boid_data, ()
        if variant == "grid":
            grid = self._neighbour_grid()
            grid.build(self.boid_data, self.n, stride=BOID_DTYPE.itemsize // 4, offset=4)  # floats 4..6: position
            grid.copy_in_cell_order(self.boid_data, self.sorted_boids, BOID_DTYPE.itemsize)
            boids, grid_args = self.sorted_boids, (*grid.geometry_args(), *grid.search_args())
        args = (boids.data, self.boid_force.data, np.int32(self.n), *self._rules(), *grid_args)
        kernel = self.program.kernel(name)
        if name == "ForceCS_cpu":
            kernel((-(-self.n // CPU_LANES),), None, *args)  # one work-item per CPU_LANES boids, any work-group
        else:
            kernel.over(self.n, self.block_size, *args)

    def force_kernel(self) -> str:
        """The ForceCS kernel that the current variant runs on this device."""
        variant = self.params.variant
        return self.auto_kernel if variant == "auto" else FORCE_KERNELS[variant]

    def _neighbour_grid(self) -> UniformGrid:
        """A grid over the wall box with cells as large as the largest radius (coarser if that would need more
        than MAX_GRID_CELLS cells); boids outside the box fall in its border cells, which keeps the search exact.
        Made with it: ``sorted_boids``, the boids in the grid's cell order, which ForceCS_grid reads."""
        p = self.params
        radius = max(p.separate_neighborhood_radius, p.alignment_neighborhood_radius, p.cohesion_neighborhood_radius)
        size = np.asarray(p.wall_size, float)
        cell = max(radius, float(np.cbrt(np.prod(size) / MAX_GRID_CELLS)))
        key = (tuple(p.wall_center), tuple(size), cell)
        if self.grid is None or self.grid_key != key:
            lower = np.asarray(p.wall_center) - size / 2
            self.grid = UniformGrid.covering(self.runtime, self.n, lower, lower + size, cell)
            self.sorted_boids = self.runtime.empty(self.n, BOID_DTYPE)
            self.grid_key = key
        return self.grid

    def integrate_cs(self, dt: float) -> None:
        """IntegrateCS: wall force, velocity += force*dt (limited to max_speed), position += velocity*dt."""
        p = self.params
        self.program.kernel("IntegrateCS").over(
            self.n,
            self.block_size,
            self.boid_data.data,
            self.boid_force.data,
            np.int32(self.n),
            np.float32(dt),
            np.float32(p.max_speed),
            cltypes.make_float4(*p.wall_center, 0.0),
            cltypes.make_float4(*p.wall_size, 0.0),
            np.float32(p.avoid_wall_weight),
        )

    # }}}

    def _step(self, dt: float) -> None:
        self.force_cs()  # book order: ForceCS, then IntegrateCS
        self.integrate_cs(dt)

    def packed_boids(self):
        """PackBoidsHalf: the boids' positions and velocities as half4 pairs, (N, 8) float16 on the device (the
        view's copy of a large flock), and their bounding box as (2, 3) float32 (min, max) on the host."""
        rt = self.runtime
        if self.packed is None:
            self.packed, self.bounds = rt.empty((self.n, 8), np.float16), rt.empty(6, np.int32)
        self.bounds.set(np.array([2**31 - 1] * 3 + [-(2**31)] * 3, np.int32))
        self.program.kernel("PackBoidsHalf").over(
            self.n, 256, self.boid_data, np.int32(self.n), self.packed, self.bounds
        )
        return self.packed, ordered_floats(rt.read_back(self.bounds)).reshape(2, 3)

    def boids(self) -> np.ndarray:
        """The raw Boid records (N,) of BOID_DTYPE, as the view uploads them."""
        return self.boid_data.get()

    def set_boids(self, position, velocity) -> None:
        """Place boids by hand (tests, experiments); N stays the same."""
        data = np.zeros(self.n, BOID_DTYPE)
        data["position"][:, :3] = position
        data["velocity"][:, :3] = velocity
        self.boid_data.set(data)

    def state(self) -> dict[str, np.ndarray]:
        data = self.boids()
        return {
            "position": np.ascontiguousarray(data["position"][:, :3]),
            "velocity": np.ascontiguousarray(data["velocity"][:, :3]),
            "force": np.ascontiguousarray(self.boid_force.get().view(np.float32).reshape(-1, 4)[:, :3]),
        }

    def restore(self, state: dict[str, np.ndarray]) -> None:
        shape = np.shape(state["position"])
        if shape != (self.n, 3):
            raise ValueError(f"saved position has shape {shape}; max_object_num={self.n} makes {(self.n, 3)}")
        self.set_boids(state["position"], state["velocity"])  # the force is recomputed by the next ForceCS

    def stats(self) -> dict:
        speed = np.linalg.norm(self.boids()["velocity"][:, :3], axis=1)
        return {
            **super().stats(),
            "boids": self.n,
            "variant": self.params.variant,
            "ForceCS kernel": self.force_kernel(),
            "block size": self.block_size,
            "mean speed": float(speed.mean()),
        }


def initial_boids(n: int, seed: int) -> np.ndarray:
    """Positions uniform in a ball of INIT_POSITION_RADIUS, velocities uniform in a ball of INIT_SPEED (seeded)."""
    rng = np.random.default_rng(seed)
    data = np.zeros(n, BOID_DTYPE)
    data["position"][:, :3] = inside_unit_sphere(rng, n) * INIT_POSITION_RADIUS
    data["velocity"][:, :3] = inside_unit_sphere(rng, n) * INIT_SPEED
    return data


def spread_positions(n: int, seed: int, center, size) -> np.ndarray:
    """(n, 3) positions uniform in the box of ``center`` and ``size`` (start=spread), seeded apart from the ball's."""
    rng = np.random.default_rng([seed, 1])
    return (np.asarray(center) + (rng.random((n, 3)) - 0.5) * np.asarray(size)).astype(np.float32)


def inside_unit_sphere(rng: np.random.Generator, n: int) -> np.ndarray:
    """Unity's Random.insideUnitSphere: n points uniform in the unit ball."""
    direction = rng.normal(size=(n, 3))
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-12)
    return direction * rng.random((n, 1)) ** (1.0 / 3.0)


SCENES = [
    Scene(
        "boids",
        Simulation,
        "GPU boids: flocking with local-memory tiles (vol.1 ch.3)",
        # wider cohesion and alignment than the book's 2: after 15 s the boids stream in one dense flock that shows at
        # picture size (with the defaults 4096 boids fill the box evenly)
        preview={
            "steps": 900,
            "max_object_num": 4096,
            "cohesion_neighborhood_radius": 4.0,
            "alignment_neighborhood_radius": 4.0,
        },
        interactive={"max_object_num": 2048},
        # about 30 neighbours within radius 2 (0.9 boids per unit^3), spread through the box from the start
        at_scale=AtScale(
            gpu={"max_object_num": 1 << 20, "variant": "grid", "start": "spread", "wall_size": (105.0, 105.0, 105.0)},
            cpu={"max_object_num": 1 << 14, "variant": "grid", "start": "spread", "wall_size": (26.0, 26.0, 26.0)},
            loop=Animation(
                "a million boids spread through the box: local flocks form and turn, shaded by their headings",
                every=6,
                start=300,
                quality=50,
            ),
        ),
        animation=Animation("the flock turning in its box", every=3),
        preview_check=PreviewCheck(min_subject=0.02, sparse="small boids spread through their cage"),
    )
]
