"""Stable fluids in 3D: Stam's solver on a w x h x d grid with a smoke emitter (vol.1 ch.4; spec 04, 3D parts).

The original ships ``Solver3D.compute`` and ``Solver3D.cs`` but no scene that runs them (and they cannot run as
written: spec 04 section 10). This is that solver, with the same kernels and order as the 2D one:

    AddSourceBrush3D                                   (emitter on)
    velocity step (unless density_only):
      AddSourceVelocity -> gs x (DiffuseVelocity, B) -> Project -> SwapVelocity -> AdvectVelocity, B -> Project
    density step:
      AddSourceDensity -> gs x (DiffuseDensity, B) -> SwapDensity -> AdvectDensity (AdvectDensityFromExt), B
    Draw
    Project = ProjectStep1, SetBoundaryDiv, SetBoundaryP -> gs x (ProjectStep2, SetBoundaryP) -> ProjectStep3, B

B = the field's SetBoundary* kernel launched for faces, edges, corners. The AddSource kernels run only while the
source is on (the original passes no source texture otherwise), so ``prev`` keeps its leftovers as the book's does.

Differences from the book: Jacobi sweeps between ping-pong buffers (the original's in-place Gauss-Seidel races);
boundaries as separate launches; a scripted emitter (``emitter``, ``emitter_frames``) replaces the missing source
provider; ``variant=fixed`` (default) uses Stam's divergence and clamps the back-trace, ``variant=book`` keeps the
original's divergence precedence bug and unclamped back-trace. Bugs that would stop Solver3D from running at all
are fixed in both variants (guards on id.x < d, AdvectDensity sampling prev.z, a 2-channel velocity volume,
integer uvw, the last corner rule, diffusion coefficient without d): the 3D solver follows the 2D one's intent.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl.array as cla
import pyopencl.cltypes as cltypes

from ..benchmark import seconds_per_call, seconds_per_step
from ..buffers import PingPong
from ..runtime import round_up
from ..scene import Params as BaseParams
from ..scene import Scene, check_dt, param
from ..scene import Simulation as BaseSimulation

STEM = "stable_fluids_3d"
MAX_CELLS = 1 << 25
"""Largest grid accepted (w*h*d): 320^3-ish, 3.5 GB of fields. The GPU bench goes to 256^3 = 16.8M cells."""
BOUNDARY_PARTS = (0, 1, 2)
"""SetBoundary* launch parts in order: faces, edges, corners (BOUNDARY_FACES.. in stable_fluids_3d.cl)."""


@dataclass(frozen=True)
class Params(BaseParams):
    width: int = param(64, 3, 2048)
    """Grid cells along x (spec 04 proposal; the original takes Screen.width)."""
    height: int = param(64, 3, 2048)
    """Grid cells along y, y = 0 at the bottom (the original takes Screen.height)."""
    depth: int = param(64, 3, 2048)
    """Grid cells along z (book: depth, a serialized field never set in any scene)."""
    diff: float = param(10.0, 0.0)
    """Density diffusion coefficient kappa; a_d = dt*diff*w*h*d (book: diff; scene 10, code default 0)."""
    visc: float = param(20.0, 0.0)
    """Kinematic viscosity nu; a_v = dt*visc*w*h*d (book: visc; scene 20, code default 0)."""
    velocity_coef: float = param(2.0, 0.0)
    """Gain of the source's velocity, per second (book: velocityCoef; 2D sample scene 2; see SCENE_DEFAULTS)."""
    density_coef: float = param(2.0, 0.0)
    """Gain of the source's density, per second (book: densityCoef; scene 2)."""
    density_only: bool = False
    """Skip the velocity step and advect the density by the source's velocity (book: isDensityOnly)."""
    gs_iterations: int = param(2, 1, 4096)
    """Jacobi sweeps per diffusion and per pressure solve (book: GS_ITERATE = 2 in Solver3D.compute)."""
    emitter: bool = True
    """Scripted source on: a continuous spherical emitter, headless runs' stand-in for a source (spec 04 proposal)."""
    emitter_frames: int = param(0, 0)
    """Frames the emitter blows from the start; 0 = the whole run (120: a puff, then the smoke drifts)."""
    emitter_center: tuple[float, float, float] = param((0.5, 0.15, 0.5), 0.0, 1.0)
    """Centre c of the spherical emitter in uvw units, (0, 0, 0) = the grid's bottom-left-front corner."""
    emitter_direction: tuple[float, float, float] = param((0.0, 1.0, 0.0), -1.0, 1.0)
    """Velocity the emitter blows (its dir; the 2D brush's clamped mouse delta), before velocity_coef."""
    source_radius: float = param(0.08, 0.0, 1.0, lo_open=True)
    """Emitter radius r in uvw units: f = clamp(1 - |(uvw - c)/r|^2, 0, 1) (book 2D: sourceRadius)."""
    variant: str = param("fixed", choices=("book", "fixed"))
    """fixed: Stam's divergence, back-trace clamped to the grid; book: the original's divergence and no clamp."""
    local_size: tuple[int, int, int] = param((8, 8, 4), 1, 1024)
    """Work-group shape of the grid kernels (book: numthreads(8, 8, 4)); halved where the device cannot run it."""
    absorption: float = param(80.0, 0.0, lo_open=True)
    """Render only: extinction of the ray-marched smoke per unit density per box length."""

    def check(self) -> None:
        cells = self.width * self.height * self.depth
        if cells > MAX_CELLS:
            raise ValueError(f"width*height*depth must be <= {MAX_CELLS}, got {cells}")


class Simulation(BaseSimulation):
    """Velocity, density and the multiplexed prev field on a w x h x d grid; one step = the original's Update()."""

    Params = Params
    history = ("density", "kinetic_energy")
    live_params = frozenset(Params.names()) - {"width", "height", "depth", "local_size"}

    def reset(self) -> None:
        p, rt = self.params, self.runtime
        self.shape = (p.depth, p.height, p.width)  # numpy (D, H, W): row z*h + y, column x
        self.dims = (np.int32(p.width), np.int32(p.height), np.int32(p.depth))
        self.local_size = self._fit_local_size(p.local_size)
        self.global_size = tuple(
            round_up(n, t) for n, t in zip((p.width, p.height, p.depth), self.local_size, strict=True)
        )
        self.velocity = PingPong.zeros(rt, (*self.shape, 4), np.float32)  # (u, v, w, 0)
        self.density = PingPong.zeros(rt, self.shape, np.float32)
        self.prev = PingPong.zeros(rt, (*self.shape, 4), np.float32)
        self.source = rt.zeros((*self.shape, 4), np.float32)
        self.no_source = rt.zeros((*self.shape, 4), np.float32)  # what AdvectDensityFromExt reads with no source
        self.solver = rt.zeros((*self.shape, 4), np.float32)
        self.external_source = False
        self.time, self.steps = 0.0, 0

    def _fit_local_size(self, wanted: tuple[int, int, int]) -> tuple[int, int, int]:
        """Halve an axis over the device's per-axis limit, else the largest axis, until the device accepts the shape
        (spec 04 section 5)."""
        device = self.runtime.device
        limits = device.max_work_item_sizes[:3]
        size = list(wanted)
        while size[0] * size[1] * size[2] > device.max_work_group_size or any(
            s > m for s, m in zip(size, limits, strict=True)
        ):
            over = [a for a in range(3) if size[a] > limits[a]]
            axis = over[0] if over else size.index(max(size))
            size[axis] = max(1, size[axis] // 2)
        return tuple(size)

    @property
    def program(self):
        tx, ty, tz = self.local_size
        return self.runtime.program(
            STEM, THREAD_X=tx, THREAD_Y=ty, THREAD_Z=tz, BOOK_VARIANT=self.params.variant == "book"
        )

    def _grid(self, name: str, *args) -> None:
        """Launch a grid kernel over every cell: buffers first, then w, h, d, then the scalars."""
        buffers = [a.data for a in args if isinstance(a, cla.Array)]
        scalars = [a for a in args if not isinstance(a, cla.Array)]
        self.program.kernel(name)(self.runtime.queue, self.global_size, self.local_size, *buffers, *self.dims, *scalars)

    def _boundary(self, name: str, field) -> None:
        """SetBoundary<name> on ``field``: faces, then edges, then corners (each reads what the one before wrote)."""
        w, h, d = (int(n) for n in self.dims)
        sizes = ((max(w, h), max(h, d), 6), (max(w, h, d), 12), (8,))
        kernel = self.program.kernel(f"SetBoundary{name}")
        for part, size in zip(BOUNDARY_PARTS, sizes, strict=True):
            kernel(self.runtime.queue, size, None, field.data, *self.dims, np.int32(part))

    # {{{ boundaries (the book's in-kernel SetBoundary* helpers)

    def set_boundary_density(self) -> None:
        self._boundary("Density", self.density.read)

    def set_boundary_velocity(self) -> None:
        self._boundary("Velocity", self.velocity.read)

    def set_boundary_div(self) -> None:
        self._boundary("Div", self.prev.read)

    def set_boundary_p(self) -> None:
        self._boundary("P", self.prev.read)

    # }}}

    # {{{ kernels, in the book's order

    def add_source_brush3d(self) -> None:
        """AddSourceBrush3D: the spherical emitter into ``source``."""
        p = self.params
        self._grid(
            "AddSourceBrush3D",
            self.source,
            cltypes.make_float4(*p.emitter_center, 0.0),
            cltypes.make_float4(*p.emitter_direction, 0.0),
            np.float32(p.source_radius),
        )

    def add_source_velocity(self, dt: float) -> None:
        """AddSourceVelocity: velocity += source.xyz*velocity_coef*dt; prev.xyz = the same."""
        self._grid(
            "AddSourceVelocity",
            self.velocity.read,
            self.prev.read,
            self.source,
            np.float32(self.params.velocity_coef),
            np.float32(dt),
        )

    def diffuse_velocity(self, dt: float, sweeps: int | None = None) -> None:
        """DiffuseVelocity: ``sweeps`` (default gs_iterations) Jacobi sweeps, each followed by SetBoundaryVelocity."""
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid(
                "DiffuseVelocity",
                self.velocity.read,
                self.prev.read,
                self.velocity.write,
                np.float32(dt),
                np.float32(self.params.visc),
            )
            self.velocity.swap()
            self.set_boundary_velocity()

    def project_step1(self) -> None:
        """ProjectStep1: prev = (0, div, prev.z, prev.w); SetBoundaryDiv, SetBoundaryP."""
        self._grid("ProjectStep1", self.velocity.read, self.prev.read)
        self.set_boundary_div()
        self.set_boundary_p()

    def project_step2(self, sweeps: int | None = None) -> None:
        """ProjectStep2: ``sweeps`` (default gs_iterations) Jacobi sweeps for p, each followed by SetBoundaryP."""
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid("ProjectStep2", self.prev.read, self.prev.write)
            self.prev.swap()
            self.set_boundary_p()

    def project_step3(self) -> None:
        """ProjectStep3: velocity -= grad p; SetBoundaryVelocity."""
        self._grid("ProjectStep3", self.velocity.read, self.prev.read)
        self.set_boundary_velocity()

    def project(self, sweeps: int | None = None) -> None:
        """The book's mass conservation: ProjectStep1, ProjectStep2 (x sweeps), ProjectStep3."""
        self.project_step1()
        self.project_step2(sweeps)
        self.project_step3()

    def swap_velocity(self) -> None:
        """SwapVelocity: prev.xyz = velocity."""
        self._grid("SwapVelocity", self.velocity.read, self.prev.read)

    def advect_velocity(self, dt: float) -> None:
        """AdvectVelocity: velocity = prev.xyz at the back-traced point; SetBoundaryVelocity."""
        self._grid("AdvectVelocity", self.prev.read, self.velocity.read, np.float32(dt))
        self.set_boundary_velocity()

    def add_source_density(self, dt: float) -> None:
        """AddSourceDensity: density += source.w*density_coef*dt; prev.w = the same."""
        self._grid(
            "AddSourceDensity",
            self.density.read,
            self.prev.read,
            self.source,
            np.float32(self.params.density_coef),
            np.float32(dt),
        )

    def diffuse_density(self, dt: float, sweeps: int | None = None) -> None:
        """DiffuseDensity: ``sweeps`` (default gs_iterations) Jacobi sweeps, each followed by SetBoundaryDensity."""
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid(
                "DiffuseDensity",
                self.density.read,
                self.prev.read,
                self.density.write,
                np.float32(dt),
                np.float32(self.params.diff),
            )
            self.density.swap()
            self.set_boundary_density()

    def swap_density(self) -> None:
        """SwapDensity: prev.w = density."""
        self._grid("SwapDensity", self.density.read, self.prev.read)

    def advect_density(self, dt: float) -> None:
        """AdvectDensity: density = prev.w at the point back-traced by the velocity; SetBoundaryDensity."""
        self._grid("AdvectDensity", self.velocity.read, self.prev.read, self.density.read, np.float32(dt))
        self.set_boundary_density()

    def advect_density_from_ext(self, dt: float, source: bool = True) -> None:
        """AdvectDensityFromExt: as AdvectDensity, back-traced by source.xyz; SetBoundaryDensity. With the source off
        the original binds no source texture, whose reads are 0: the density stays put (as the 2D scene)."""
        field = self.source if source else self.no_source
        self._grid("AdvectDensityFromExt", field, self.prev.read, self.density.read, np.float32(dt))
        self.set_boundary_density()

    def draw(self) -> None:
        """Draw: solver = (u, v, w, density)."""
        self._grid("Draw", self.velocity.read, self.density.read, self.solver)

    # }}}

    def source_active(self) -> bool:
        """Whether this step adds a source (the original: a source texture is bound)."""
        if self.external_source:
            return True
        p = self.params
        return p.emitter and (p.emitter_frames == 0 or self.steps < p.emitter_frames)

    def velocity_step(self, dt: float, source: bool) -> None:
        if source:
            self.add_source_velocity(dt)
        self.diffuse_velocity(dt)
        self.project()
        self.swap_velocity()
        self.advect_velocity(dt)
        self.project()

    def density_step(self, dt: float, source: bool) -> None:
        if source:
            self.add_source_density(dt)
        self.diffuse_density(dt)
        self.swap_density()
        if self.params.density_only:
            self.advect_density_from_ext(dt, source)  # the original sets this kernel up but dispatches AdvectDensity
        else:
            self.advect_density(dt)

    def step(self, dt: float | None = None) -> None:
        dt = check_dt(dt, self.default_dt)
        source = self.source_active()
        if source and not self.external_source:
            self.add_source_brush3d()
        if not self.params.density_only:
            self.velocity_step(dt, source)
        self.density_step(dt, source)
        self.draw()
        self._advance(dt)

    # {{{ state

    def set_source(self, source: np.ndarray | None) -> None:
        """Use ``source`` (D, H, W, 4: velocity xyz, density w) on every step instead of the emitter, as the book's
        SorceTex set by another component; None goes back to the emitter."""
        if source is None:
            self.external_source = False
            return
        source = np.asarray(source, np.float32)
        if source.shape != (*self.shape, 4):
            raise ValueError(f"source must have shape {(*self.shape, 4)}, got {source.shape}")
        self.source.set(np.ascontiguousarray(source))
        self.external_source = True

    def set_fields(self, velocity=None, density=None, prev=None) -> None:
        """Overwrite fields (tests, experiments): velocity (D, H, W, 3), density (D, H, W), prev (D, H, W, 4)."""
        if velocity is not None:
            full = np.zeros((*self.shape, 4), np.float32)
            full[..., :3] = velocity
            self.velocity.read.set(full)
        if density is not None:
            self.density.read.set(np.ascontiguousarray(density, np.float32))
        if prev is not None:
            self.prev.read.set(np.ascontiguousarray(prev, np.float32))

    def solver_field(self) -> np.ndarray:
        """The Draw output (D, H, W, 4) = (u, v, w, density): what the view renders."""
        return self.solver.get()

    def state(self) -> dict[str, np.ndarray]:
        velocity = self.velocity.read.get()[..., :3]
        return {
            "velocity": np.ascontiguousarray(velocity),
            "density": self.density.read.get(),
            "solver": self.solver.get(),
            "prev": self.prev.read.get(),
            "source": self.source.get(),
            "divergence": central_divergence(velocity),
            "kinetic_energy": np.float32(0.5 * np.mean(np.sum(velocity.astype(np.float64) ** 2, axis=-1))),
        }

    def stats(self) -> dict:
        state = self.state()
        speed = np.linalg.norm(state["velocity"], axis=-1)
        return {
            **super().stats(),
            "grid": "x".join(str(n) for n in (self.params.width, self.params.height, self.params.depth)),
            "variant": self.params.variant,
            "local size": self.local_size,
            "max density": float(state["density"].max()),
            "total density": float(state["density"].sum(dtype=np.float64)),
            "max speed": float(speed.max()),
            "mean |divergence|": float(np.abs(state["divergence"][1:-1, 1:-1, 1:-1]).mean()),
        }

    # }}}


def central_divergence(velocity: np.ndarray) -> np.ndarray:
    """du/dx + dv/dy + dw/dz by central differences in cells (0.5*(u(x+1) - u(x-1)) + ...), 0 on boundary cells.
    The fixed projection drives -0.5*(du/w + dv/h + dw/d) to 0, proportional to this on cubic grids."""
    v = velocity.astype(np.float32)
    out = np.zeros(v.shape[:3], np.float32)
    inner = (slice(1, -1),) * 3
    out[inner] = 0.5 * (
        (v[1:-1, 1:-1, 2:, 0] - v[1:-1, 1:-1, :-2, 0])
        + (v[1:-1, 2:, 1:-1, 1] - v[1:-1, :-2, 1:-1, 1])
        + (v[2:, 1:-1, 1:-1, 2] - v[:-2, 1:-1, 1:-1, 2])
    )
    return out


def bench(runtime, sizes=None) -> list[dict]:
    """Per grid n^3 and Jacobi sweeps per solve: ms per step (the whole Update: 2 diffusions, 2 projections,
    2 advections, boundaries), cell updates/s (cells x steps/s), and one Jacobi sweep of the pressure solve
    (ProjectStep2 + SetBoundaryP) as sweeps/s and cell updates/s."""
    sizes = sizes or ([64, 128, 256] if runtime.is_gpu else [64, 128])
    rows = []
    for n in sizes:
        for sweeps in (2, 20):
            sim = Simulation(runtime, Params(width=n, height=n, depth=n, gs_iterations=sweeps), seed=0)
            seconds = seconds_per_step(sim, min_seconds=1.0, max_steps=50)
            sweep = seconds_per_call(lambda sim=sim: sim.project_step2(1), runtime.queue, max_calls=200)
            cells = n**3
            rows.append(
                {
                    "grid": f"{n}^3",
                    "gs_iterations": sweeps,
                    "ms/step": seconds * 1e3,
                    "cell updates/s": cells / seconds,
                    "Jacobi sweeps/s": 1.0 / sweep,
                    "Jacobi cell updates/s": cells / sweep,
                }
            )
    return rows


SCENE_DEFAULTS = {"velocity_coef": 10.0}
"""The 3D scene blows 5x harder than the 2D sample's velocityCoef: with 2 the emitter's smoke creeps up at ~0.3
cells per frame under the book's blur (Solver3D had no scene of its own to copy)."""

SCENES = [
    Scene(
        STEM,
        Simulation,
        "Stable fluids in 3D: smoke from an emitter, ray-marched (vol.1 ch.4, the unused Solver3D)",
        SCENE_DEFAULTS,
        view="View",
        preview={"steps": 120},
    )
]
