"""SPH fluid 2D: weakly compressible SPH in a 16 x 9 box (vol.1 ch.5, "Fluid simulation by the SPH method";
docs/chapters/05-sph-2d.md).

One step = one frame = ``iterations`` sub-steps of dt = min(max_allowable_timestep, frame dt) (book: Update), each
running the book's RunFluidSolver: ``DensityCS`` (Poly6, self excluded) -> ``PressureCS`` (Tait, gamma 7) ->
``ForceCS`` (Spiky pressure gradient with the mean pressure, viscosity Laplacian, divided by the own density) ->
``IntegrateCS`` (mouse push, penalty walls, gravity, symplectic Euler) -> swap of the particle ping-pong pair.

``search=grid`` (the neighbour search the book leaves out for simplicity: vol.1 ch.5 section 5.4.3, after listing
5.5) sorts the particles by cell with the shared ``ugpcl.grid.UniformGrid`` before each sub-step, copies them in
that order (``GridCopyItemsInCellOrder``) and runs ``DensityCS_grid`` / ``ForceCS_grid`` over the sorted copy: the
same per-pair maths over the 3x3 cells around each particle, equal to the book's all-pairs loops up to summation
order; density, pressure and force stay in particle order.

Differences from the book: N need not be a multiple of 1024 (the global size is padded, kernels guard i < N); the
three divisions by zero that give NaN in the original are guarded (coincident pair, isolated particle of density 0,
mouse exactly on a particle); ``variant=fixed`` (default) divides ForceCS by at least the self density the book's
density leaves out, which stops spray particles of density ~0 from blowing up (``variant=book`` keeps the book's
divisions); the defaults are the scene's inspector values, not the code's (``sph_2d_code_defaults`` has those);
``start=dam_break`` and the scripted ``mouse`` are additions for headless runs; the book's ``simulate`` flag is the
viewer's shared pause key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..buffers import PingPong
from ..grid import UniformGrid
from ..scene import Animation, AtScale, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

PARTICLE_DTYPE = np.dtype([("position", "<f4", 2), ("velocity", "<f4", 2)])
"""Mirror of ``FluidParticle`` in clkernels/include/sph_2d.h (16 bytes)."""

MAX_GRID_CELLS = 1 << 22
"""The grid's cells grow past h when a tiny h in a large box would need more cells than this (still exact)."""

LOCAL_SIZES = (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024)


@dataclass(frozen=True)
class Params(BaseParams):
    particle_num: int = param(8192, 2, 1 << 20)
    """Number of particles N (book: particleNum, NUM_1K..NUM_8K; any N >= 2 here)."""
    smoothlen: float = param(0.5, 1e-4, 1e4, live=True)
    """Kernel radius h, world units: particles closer than h interact (book: smoothlen, "particle radius").
    1e-4 to 1e4: the kernel coefficients hold smoothlen^8 and 1/smoothlen^8 in float32."""
    pressure_stiffness: float = param(0.57, 0.0, 1e6, live=True)
    """Tait coefficient B of p = B max((rho/rho0)^7 - 1, 0) (book: pressureStiffness, "Becker's coefficient").
    Up to 1e6: B times the Tait term stays finite."""
    rest_density: float = param(4.0, 1e-3, 1e6, live=True)
    """Rest density rho0, mass per area (book: restDensity). 1e-3 to 1e6: the Tait term takes (rho/rho0)^7."""
    particle_mass: float = param(0.08, 0.0, 1e4, lo_open=True, live=True)
    """Mass of every particle (book: particleMass), folded into the kernel coefficients.
    Up to 1e4: m 4 / (pi h^8) stays finite at the smallest smoothlen."""
    viscosity: float = param(3.0, 0.0, 1e4, live=True)
    """Viscosity coefficient mu (book: viscosity). Up to 1e4: the viscosity term stays finite in float32."""
    max_allowable_timestep: float = param(1.0 / 240.0, 0.0, 1.0 / 120.0, lo_open=True, live=True)
    """Largest sub-step dt, s; the sub-step is min(this, frame time) (book: maxAllowableTimestep; 1/60 explodes)."""
    wall_stiffness: float = param(3000.0, 0.0, 5e4, live=True)
    """Penalty wall strength: acceleration per unit of distance outside the box, 1/s^2 (book: wallStiffness).
    Up to 5e4: explicit Euler stays stable while max_allowable_timestep * sqrt(this) < 2 (1/120 s: 1.9)."""
    iterations: int = param(4, 1, 64, live=True)
    """Sub-steps per frame (book: iterations)."""
    gravity: tuple[float, float] = param((0.0, -10.0), -1e4, 1e4, live=True)
    """External acceleration, world units/s^2 (book: gravity; the G key toggles it off for weightless fluid).
    Within 1e4: dt * gravity stays finite and resolvable."""
    range: tuple[float, float] = param((16.0, 9.0), 0.0, 1e4, lo_open=True)
    """Box [0, range.x] x [0, range.y], world units (book: range). Up to 1e4: float32 positions keep 1e-3."""
    ball_radius: float = param(5.0, 0.0, 1e4, lo_open=True)
    """Radius of the disc the particles start in, centred in the box (book: Fluid2D.ballRadius); dam_break keeps its
    area. Up to 1e4: float32 positions keep 1e-3."""
    mouse_interaction_radius: float = param(1.5, 0.0, 1e4, lo_open=True, live=True)
    """Particles closer than this to the held mouse are pushed away, world units (book: MouseInteractionRadius).
    Up to 1e4: float32 positions keep 1e-3."""
    mouse_gain: float = param(100.0, 0.0, 5e4, live=True)
    """Push per unit of depth inside the mouse radius, 1/s^2 (book: the literal 100 in IntegrateCS).
    Up to 5e4: explicit Euler stays stable while max_allowable_timestep * sqrt(this) < 2 (1/120 s: 1.9)."""
    mouse: tuple[float, float, int] = param((8.0, 4.5, 0), -1e6, 1e6, live=True)
    """Scripted mouse for headless runs: hold the button at (x, y) for the first N frames after reset (0: never;
    --set mouse=x,y,frames). Within 1e6: far outside any box, still finite in float32."""
    start: str = param("ball", choices=("ball", "dam_break"))
    """Initial particles: uniform in the centred disc (book), or the same area as a column against the left wall."""
    variant: str = param("fixed", choices=("fixed", "book"), live=True)
    """book: ForceCS divides by the densities as they are; fixed: by at least the self term the density leaves out,
    which keeps spray particles (density near 0) from a viscous blow-up."""
    search: str = param("all_pairs", choices=("all_pairs", "grid"), live=True)
    """Neighbour search: the book's loops over all N, or the uniform grid (DensityCS_grid/ForceCS_grid)."""
    local_size: int = param(256, choices=LOCAL_SIZES)
    """Work-group size (book: THREAD_SIZE_X = 1024); lowered to what the device allows."""
    particle_radius: float = param(0.05, 0.0, 1e4, lo_open=True, live=True)
    """Half-size of each particle's billboard, world units, render only (book: FluidRenderer particleRadius).
    Up to 1e4: float32 positions keep 1e-3."""
    water_color: tuple[float, float, float, float] = param((0.0, 0.462, 1.0, 1.0), 0.0, 1.0, live=True)
    """Particle tint RGBA, render only (book: FluidRenderer WaterColor)."""

    limits = ("mouse frames (third number) >= 0",)

    def check(self) -> None:
        if self.mouse[2] < 0:
            raise self.broken(self.limits[0])

    # {{{ derived values (book: FluidBase.Update, the "2D kernel coefficients")

    @property
    def density_coef(self) -> float:
        """m 4 / (pi h^8): Poly6 in 2D with the mass folded in."""
        return self.particle_mass * 4.0 / (math.pi * self.smoothlen**8)

    @property
    def grad_pressure_coef(self) -> float:
        """m (-30) / (pi h^5): Spiky gradient in 2D with the mass folded in."""
        return self.particle_mass * -30.0 / (math.pi * self.smoothlen**5)

    @property
    def lap_viscosity_coef(self) -> float:
        """m 20 / (3 pi h^5): viscosity-kernel Laplacian in 2D with the mass folded in."""
        return self.particle_mass * 20.0 / (3.0 * math.pi * self.smoothlen**5)

    @property
    def self_density(self) -> float:
        """density_coef h^6 = m 4 / (pi h^2): the particle's own Poly6 term, which the book's density excludes."""
        return self.density_coef * self.smoothlen**6

    @property
    def min_density(self) -> float:
        """Smallest density ForceCS divides by: 0 in the book, the self term in the fixed variant."""
        return self.self_density if self.variant == "fixed" else 0.0

    # }}}


CODE_DEFAULTS = {
    "smoothlen": 0.012,
    "pressure_stiffness": 200.0,
    "rest_density": 1000.0,
    "particle_mass": 0.0002,
    "viscosity": 0.1,
    "max_allowable_timestep": 0.005,
    "gravity": (0.0, -0.5),
    "range": (1.0, 1.0),
    "ball_radius": 0.1,
    "mouse_interaction_radius": 1.0,
    "mouse": (0.5, 0.5, 0),
    "particle_radius": 0.004,
}
"""The code defaults of listing 5.1 (FluidBase.cs, Fluid2D.cs) where they differ from the scene's inspector values."""


class Simulation(BaseSimulation):
    """N fluid particles; each step runs ``iterations`` sub-steps of DensityCS, PressureCS, ForceCS, IntegrateCS."""

    Params = Params
    default_dt = 1.0 / 60.0
    """Frame time of headless runs; each of the ``iterations`` sub-steps is min(max_allowable_timestep, this)."""
    history = ("position", "mean_density", "kinetic_energy")

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.n = p.particle_num
        self.program = rt.program("sph_2d")
        start = initial_particles(self.n, p, self.seed)
        self.particles = PingPong(rt.to_device(start), rt.to_device(start))  # book: particlesBufferRead/Write
        self.density = rt.zeros(self.n, np.float32)
        self.pressure = rt.zeros(self.n, np.float32)
        self.force = rt.zeros(self.n, cltypes.float2)
        self._grid: UniformGrid | None = None
        self._grid_is_current = False
        self.sorted_particles = None  # particles_in in the grid's cell order (search=grid), made with the grid
        self.positions = None  # PackPositions' output, made on first use (a view's)
        self.mouse_pos, self.mouse_down = (0.0, 0.0), False  # book: screenToWorldPointPos starts at the origin

    # {{{ neighbour grid (search=grid)

    def grid(self) -> UniformGrid:
        """The uniform grid over the box (cells >= h), sorted for the current particles_in, which
        ``sorted_particles`` holds in the grid's cell order (what DensityCS_grid and ForceCS_grid read)."""
        p = self.params
        cell = max(p.smoothlen, math.sqrt(p.range[0] * p.range[1] / MAX_GRID_CELLS))
        if self._grid is None or self._grid.cell_size != cell:  # smoothlen is live: a new h needs new cells
            self._grid = UniformGrid.covering(self.runtime, self.n, (0.0, 0.0), p.range, cell)
            self.sorted_particles = self.runtime.empty(self.n, PARTICLE_DTYPE)
            self._grid_is_current = False
        if not self._grid_is_current:
            self._grid.build(self.particles.read, self.n, stride=4, offset=0)  # position = floats 0, 1 of 4
            self._grid.copy_in_cell_order(self.particles.read, self.sorted_particles, PARTICLE_DTYPE.itemsize)
            self._grid_is_current = True
        return self._grid

    # }}}

    # {{{ kernels, in the book's order

    def density_cs(self) -> None:
        """DensityCS (or DensityCS_grid): density of every particle from particles_in."""
        p = self.params
        args = (
            self.particles.read.data,
            self.density.data,
            np.int32(self.n),
            np.float32(p.smoothlen),
            np.float32(p.density_coef),
        )
        if p.search == "grid":
            grid = self.grid()
            self.program.kernel("DensityCS_grid").over(
                self.n,
                p.local_size,
                self.sorted_particles,  # particles_in in cell order
                *args[1:],
                *grid.geometry_args(),
                *grid.search_args(),
            )
        else:
            self.program.kernel("DensityCS").over(self.n, p.local_size, *args)

    def pressure_cs(self) -> None:
        """PressureCS: Tait pressure of every particle from its density."""
        p = self.params
        self.program.kernel("PressureCS").over(
            self.n,
            p.local_size,
            self.density.data,
            self.pressure.data,
            np.int32(self.n),
            np.float32(p.pressure_stiffness),
            np.float32(p.rest_density),
        )

    def force_cs(self) -> None:
        """ForceCS (or ForceCS_grid): acceleration of every particle from pressure and viscosity."""
        p = self.params
        args = (
            self.particles.read.data,
            self.density.data,
            self.pressure.data,
            self.force.data,
            np.int32(self.n),
            np.float32(p.smoothlen),
            np.float32(p.grad_pressure_coef),
            np.float32(p.lap_viscosity_coef),
            np.float32(p.viscosity),
            np.float32(p.min_density),
        )
        if p.search == "grid":
            grid = self.grid()
            self.program.kernel("ForceCS_grid").over(
                self.n,
                p.local_size,
                self.sorted_particles,  # particles_in in cell order
                *args[1:],
                *grid.geometry_args(),
                *grid.search_args(),
            )
        else:
            self.program.kernel("ForceCS").over(self.n, p.local_size, *args)

    def integrate_cs(self, dt: float) -> None:
        """IntegrateCS: mouse, walls, gravity and the Euler update from particles_in into particles_out."""
        p = self.params
        self.program.kernel("IntegrateCS").over(
            self.n,
            p.local_size,
            self.particles.read.data,
            self.force.data,
            self.particles.write.data,
            np.int32(self.n),
            np.float32(dt),
            np.float32(p.wall_stiffness),
            cltypes.make_float2(*p.gravity),
            cltypes.make_float2(*p.range),
            cltypes.make_float2(*self.mouse_pos),
            np.float32(p.mouse_interaction_radius),
            np.float32(p.mouse_gain),
            np.int32(self.mouse_down),
        )

    def run_fluid_solver(self, dt: float) -> None:
        """One sub-step (book: RunFluidSolver): the four kernels, then swap the particle buffers."""
        self.density_cs()
        self.pressure_cs()
        self.force_cs()
        self.integrate_cs(dt)
        self.particles.swap()  # book: SwapComputeBuffer(ref particlesBufferRead, ref particlesBufferWrite)
        self._grid_is_current = False

    # }}}

    def _step(self, dt: float) -> float:
        """One frame: ``iterations`` sub-steps of min(max_allowable_timestep, dt) (book: Update); returns the time
        they simulated, which the clock advances by."""
        p = self.params
        x, y, frames = p.mouse
        if frames and self.steps < frames:  # scripted mouse: held for the first `frames` frames ...
            self.push(x, y)
        elif frames and self.steps == frames:  # ... then released where it was
            self.release()
        time_step = min(p.max_allowable_timestep, dt)
        for _ in range(p.iterations):
            self.run_fluid_solver(time_step)
        return time_step * p.iterations

    # {{{ interaction

    def push(self, x: float, y: float) -> None:
        """Hold the mouse button at world (x, y): particles within mouse_interaction_radius are pushed away."""
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"mouse position must be finite, got ({x}, {y})")
        self.mouse_pos, self.mouse_down = (float(x), float(y)), True

    def release(self) -> None:
        """Release the button; the last position is kept, as the book's Fluid2D does."""
        self.mouse_down = False

    # }}}

    # {{{ state

    def packed_positions(self):
        """PackPositions: the particles' positions alone, (N, 2) float32 on the device (the view's water colour)."""
        if self.positions is None:
            self.positions = self.runtime.empty((self.n, 2), np.float32)
        self.program.kernel("PackPositions").over(self.n, 256, self.particles.read, self.positions, np.int32(self.n))
        return self.positions

    def particles_array(self) -> np.ndarray:
        """The current particles (N,) of PARTICLE_DTYPE (particles_in: the buffer written last), as the view draws."""
        return self.particles.read.get()

    def set_particles(self, position, velocity=None) -> None:
        """Place particles by hand (tests, experiments); N stays the same."""
        data = np.zeros(self.n, PARTICLE_DTYPE)
        data["position"] = position
        data["velocity"] = 0.0 if velocity is None else velocity
        self.particles.read.set(data)
        self._grid_is_current = False

    def state(self) -> dict[str, np.ndarray]:
        data = self.particles_array()
        density = self.density.get()
        speed_sq = (data["velocity"].astype(np.float64) ** 2).sum(axis=1)
        with np.errstate(over="ignore"):  # a diverged run's energy is inf in float32: the divergence check says so
            energy = np.float32(0.5 * self.params.particle_mass * speed_sq.sum())
        return {
            "position": np.ascontiguousarray(data["position"]),
            "velocity": np.ascontiguousarray(data["velocity"]),
            "density": density,
            "pressure": self.pressure.get(),
            "acceleration": self.force.get().view(np.float32).reshape(-1, 2),
            "mean_density": np.float32(density.mean()),
            "kinetic_energy": energy,
        }

    def restore(self, state: dict[str, np.ndarray]) -> None:
        shape = np.shape(state["position"])
        if shape != (self.n, 2):
            raise ValueError(f"saved position has shape {shape}; particle_num={self.n} makes {(self.n, 2)}")
        self.set_particles(state["position"], state["velocity"])  # density, pressure, force: recomputed each step

    def stats(self) -> dict:
        state = self.state()
        position, p = state["position"], self.params
        overshoot = max(0.0, float(-position.min()), float((position - np.asarray(p.range)).max()))
        out = {
            **super().stats(),
            "particles": self.n,
            "search": p.search,
            "mean density": float(state["mean_density"]),
            "max density": float(state["density"].max()),
            "isolated particles (density 0)": int((state["density"] == 0).sum()),
            "kinetic energy": float(state["kinetic_energy"]),
            "max distance outside the box": overshoot,
            "finite": bool(np.isfinite(position).all() and np.isfinite(state["velocity"]).all()),
        }
        if p.search == "grid" and self._grid is not None:
            out.update({f"grid {k}": v for k, v in self.grid().occupancy().items()})
        return out

    # }}}


def initial_particles(n: int, p: Params, seed: int) -> np.ndarray:
    """Book (Fluid2D.InitParticleData): at rest, uniform in a disc of ball_radius at the box centre; ``dam_break``:
    the same area as a jittered lattice column standing on the floor against the left wall."""
    rng = np.random.default_rng(seed)
    data = np.zeros(n, PARTICLE_DTYPE)
    centre = np.asarray(p.range) / 2
    if p.start == "ball":  # Unity's Random.insideUnitCircle * ballRadius
        angle = rng.uniform(0.0, 2.0 * np.pi, n)
        radius = p.ball_radius * np.sqrt(rng.random(n))
        data["position"] = centre + radius[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
        return data
    area = math.pi * p.ball_radius**2  # same number density as the ball
    height = min(0.9 * p.range[1], math.sqrt(2.0 * area))
    width = area / height
    columns = max(1, round(math.sqrt(n * width / height)))
    rows = math.ceil(n / columns)
    spacing = np.array([width / columns, height / rows])
    cell = np.column_stack([np.arange(n) % columns, np.arange(n) // columns]) + 0.5
    jitter = rng.uniform(-0.1, 0.1, (n, 2))  # breaks the lattice's symmetry
    data["position"] = (cell + jitter) * spacing
    return data


SCENES = [
    Scene(
        "sph_2d",
        Simulation,
        "SPH fluid 2D: a disc of water falls and splashes in a box (vol.1 ch.5)",
        # a dam break 15 s later: the water has settled on the floor (the disc of the book's start needs 8192
        # particles to fill the floor and keeps sloshing longer)
        preview={"steps": 900, "particle_num": 4096, "ball_radius": 3.5, "start": "dam_break", "search": "grid"},
        # a smaller disc at the spacing of the book's 8192 particles in radius 5
        interactive={"particle_num": 4096, "ball_radius": 3.5, "search": "grid"},
        # the disc and box scaled by sqrt(N / 8192): the number density of the book's 8192 (ugpcl.bench.sph_2d); the
        # drawn radius too on the CPU, and 0.2 on the GPU (at the book's 0.05 a particle of the 181-unit box is a third
        # of a pixel at 1280x720 and nothing is drawn; 0.3 cost the H200's graphics units 7 ms a frame)
        at_scale=AtScale(
            gpu={
                "particle_num": 1 << 20,
                "search": "grid",
                "range": (181.02, 101.82),
                "ball_radius": 56.57,
                "particle_radius": 0.2,
            },
            cpu={
                "particle_num": 1 << 14,
                "search": "grid",
                "range": (22.63, 12.73),
                "ball_radius": 7.07,
                "particle_radius": 0.0707,
            },
            loop=Animation(
                "a million particles at the book's density: the disc falls 11 times as far as the book's and "
                "splashes so hard that spray passes the penalty walls",
                every=6,
                quality=50,
            ),
        ),
        animation=Animation(
            "the dam break: the column falls, splashes against the far wall and settles",
            every=25,
            start=0,
            frames=36,
            quality=50,  # 4096 dots: at 70 the loop is 430 KB
        ),
    ),
    Scene(
        "sph_2d_code_defaults",
        Simulation,
        "SPH fluid 2D with the code defaults of listing 5.1 (1 x 1 box, h = 0.012) (vol.1 ch.5)",
        defaults=CODE_DEFAULTS,
        preview={"steps": 120, "search": "grid"},
        # radius 0.1 * sqrt(2048 / 8192): the spacing of the code's 8192
        interactive={"particle_num": 2048, "ball_radius": 0.05, "search": "grid"},
        preview_check=PreviewCheck(
            min_subject=0.04,
            sparse="before it lands (step 75) the disc hangs at the box's middle: framed with the floor under it, "
            "it covers 4.6 % of a 1280x720 frame",
            fills_frame="the picture zooms onto the fluid and the floor under it: the floor line crosses the frame",
        ),
    ),
]
