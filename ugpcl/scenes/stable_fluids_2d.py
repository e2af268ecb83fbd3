"""Stable fluids in 2D: Stam's grid solver painted with a brush, shown as black ink on white (vol.1 ch.4;
docs/chapters/04-stable-fluids-2d.md).

Kernel order per step (``clkernels/stable_fluids_2d.cl``; +B = the kernel applies the field's boundary rule itself,
as the book's kernels call their SetBoundary* helper at the end):

    AddSourceBrush                                               (brush held: mouse drag or the scripted stroke)
    velocity step (unless density_only):
      [AddSourceVelocity] -> gs x DiffuseVelocity+B -> Project -> SwapVelocity -> AdvectVelocity+B -> Project
    density step:
      [AddSourceDensity] -> gs x DiffuseDensity+B -> SwapDensity -> AdvectDensity+B (AdvectDensityFromExt+B)
    Draw
    DrawTexture                                                  (when a view asks: draw_texture)
    Project = ProjectStep1+B(Divergence) -> gs x ProjectStep2+B(DivPositive) -> ProjectStep3 -> SetBoundaryVelocity

A default step (gs_iterations 2, brush held) is 22 launches. The AddSource kernels run only on frames with the brush
held (the original passes no source texture otherwise), so ``prev`` keeps its leftovers as the book's does.
``solver=vol4`` is the stripped copy of this solver that vol.4 ch.6 (Tessellation) drives: no pressure sweeps (p
stays 0) and no AdvectVelocity (docs/chapters/17-tessellation.md).

Differences from the book: one Jacobi sweep per launch between ping-pong buffers instead of the racy in-place
Gauss-Seidel; the walls are set by extra work-groups past the grid (``SETS_WALLS``), one work-item per wall cell
computing the kernel's value at the cells its rule reads, instead of reading cells other work-items write (the
results of a sweep followed by separate edge and corner passes, bit for bit); guarded global sizes (the original
skips partial 32x32 groups); zero-padded reads where a read may leave the grid; float32 fields (the original: half).
``variant=fixed`` (default) uses Stam's divergence and clamps the back-trace; ``variant=book`` keeps the original's
divergence precedence bug and the unclamped back-trace (docs/chapters/04-stable-fluids-2d.md, "What differs from the
book"). A scripted ``stroke`` replaces the mouse headless.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.array as cla
import pyopencl.cltypes as cltypes

from ..buffers import PingPong, put
from ..resources import Allocation
from ..runtime import fitted_shape
from ..scene import Animation, AtScale, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

STEM = "stable_fluids_2d"
MAX_CELLS = 1 << 24
"""Largest grid accepted (w*h = 16.8M cells: 4096^2, about 800 MB of fields)."""
KERNELS = (
    "AddSourceBrush",
    "AddSourceVelocity",
    "DiffuseVelocity",
    "ProjectStep1",
    "ProjectStep2",
    "ProjectStep2Rows",
    "ProjectStep3",
    "SetBoundaryVelocity",
    "SwapVelocity",
    "AdvectVelocity",
    "AddSourceDensity",
    "DiffuseDensity",
    "SwapDensity",
    "AdvectDensity",
    "AdvectDensityFromExt",
    "Draw",
    "DrawTexture",
    "SetBoundaryDensity",
    "SetBoundaryDivergence",
    "SetBoundaryDivPositive",
)
"""The kernels of stable_fluids_2d.cl in host call order (its header's list); the last three only for set_boundary_*.
ProjectStep2Rows is ProjectStep2 in strips (sweep_kernel), built for the fixed variant only; DrawTexture only for the
view (draw_texture)."""
TEXTURE_FIELDS = {"density": 1, "velocity": 2, "divergence": 1}
"""What draw_texture can write (DrawTexture's ``shown``, in this order) and its half floats a cell."""
ROWS_PER_ITEM = 2
"""Rows of the 4-cell strip one work-item of ProjectStep2Rows sweeps (its ROWS define)."""
ROWS_LOCAL = (64, 2)
"""ProjectStep2Rows' work-group shape, in strips. On the H100 (2026-11-25) a 4096^2 sweep takes 71.2 us with 2 rows
and 64 x 2 strips (97 % of the copy bandwidth; 70.5-71.5 us for 1 or 2 rows and any shape tried, 72.6-77 us with 4
rows), against 84.3 us for ProjectStep2 with 64 x 4 work-items and 101 us with the book's 32 x 32."""
SETS_WALLS = frozenset(
    {"DiffuseVelocity", "ProjectStep1", "ProjectStep2", "AdvectVelocity", "DiffuseDensity", "AdvectDensity"}
    | {"AdvectDensityFromExt"}
)
"""Kernels that apply their field's boundary rule themselves: launched with extra rows of work-items past the grid,
one per wall cell (2(w-2) + 2(h-2) + 4 of them), as stable_fluids_2d.cl's wall_item() expects."""
STROKE_PERIOD = 120
"""Frames of one pass of a scripted stroke (the line takes 120 frames, the circle one turn)."""
STROKES = ("circle", "line", "figure8", "none")


@dataclass(frozen=True)
class Params(BaseParams):
    width: int = param(640, 3, 8192)
    """Screen width in pixels; the grid has width >> lod cells along x (the original: Screen.width)."""
    height: int = param(360, 3, 8192)
    """Screen height in pixels; the grid has height >> lod rows, row 0 at the bottom (the original: Screen.height)."""
    lod: int = param(0, 0, 8)
    """Grid = screen size >> lod (book: lod)."""
    diff: float = param(10.0, 0.0, 1e6, live=True)
    """Density diffusion kappa; a_d = dt*diff*w*h (book: diff; the sample scene's 10, code default 0).
    Up to 1e6: a <= 1.7e13 keeps the Jacobi sums finite in float32."""
    visc: float = param(20.0, 0.0, 1e6, live=True, ignored_when={"density_only": True})
    """Kinematic viscosity nu; a_v = dt*visc*w*h (book: visc; the sample scene's 20, code default 0).
    Up to 1e6: a <= 1.7e13 keeps the Jacobi sums finite in float32."""
    velocity_coef: float = param(2.0, 0.0, 1e4, live=True, ignored_when={"density_only": True})
    """Gain of the brush's velocity, per second (book: velocityCoef, the sample scene's 2; the scene stable_fluids_2d
    blows 30x harder, SCENE_DEFAULTS: with 2 the flow barely moves the ink). Up to 1e4: the sources stay finite in
    float32."""
    density_coef: float = param(2.0, 0.0, 1e4, live=True)
    """Gain of the brush's density, per second (book: densityCoef, the sample scene's 2; the scene stable_fluids_2d
    paints 4x darker, SCENE_DEFAULTS: with 2 a moving brush leaves a faint grey trace). Up to 1e4: the sources stay
    finite in float32."""
    density_only: bool = param(False, live=True)
    """Skip the velocity step; advect the density by the brush's velocity (book: isDensityOnly)."""
    gs_iterations: int = param(2, 1, 100000, live=True)
    """Jacobi sweeps per diffusion and per pressure solve (book: GS_ITERATE; the listing says 4, the code 2)."""
    source_radius: float = param(0.022, 0.0, 1.0, lo_open=True, live=True)
    """Brush radius in uv units of each axis (book: sourceRadius; the sample scene's 0.022, code default 0.03)."""
    mouse_clamp: float = param(1.0, 0.0, 1e4, live=True)
    """Longest brush move per frame in grid cells: the mouse delta is clamped to it (book: MouseSourceProvider).
    Up to 1e4 cells, more than the largest grid's side."""
    ink_gain: float = param(5.0, 0.0, 1e4, live=True)
    """Render only: ink colour = white*(1 - ink_gain*density) (book: Sample.shader). Up to 1e4."""
    variant: str = param("fixed", choices=("fixed", "book"), live=True)
    """fixed: Stam's divergence, back-trace clamped; book: the original's divergence, no clamp, corner typo."""
    solver: str = param("vol1", choices=("vol1", "vol4"), live=True, ignored_when={"density_only": True})
    """vol1: this chapter's step; vol4: the stripped copy in vol.4 ch.6 (no pressure sweeps, no AdvectVelocity)."""
    stroke: str = param("circle", choices=STROKES, live=True)
    """Scripted brush: circle (radius 0.25 around the centre, one turn per 120 frames), line (uv 0.3 -> 0.7 at
    v = 0.5 in 120 frames), figure8, none (not in the book: replaces the mouse headless)."""
    stroke_frames: int = param(120, 0, 1 << 30, live=True, ignored_when={"stroke": "none"})
    """Frames the scripted stroke holds the brush down from its start; 0 = for the whole run. At most 2^30 frames."""
    local_size: tuple[int, int] = param((32, 32), 1, 1024, live=True)
    """Work-group shape of the grid kernels (book: numthreads(32, 32, 1)); halved where the device cannot run it."""

    @property
    def grid(self) -> tuple[int, int]:
        """(w, h) in cells: the screen size >> lod."""
        return self.width >> self.lod, self.height >> self.lod

    limits = ("width >> lod and height >> lod >= 3", f"(width >> lod) * (height >> lod) <= {MAX_CELLS}")
    """The walls need an interior; every field must fit the device."""

    def check(self) -> None:
        w, h = self.grid
        if w < 3 or h < 3:
            raise self.broken(self.limits[0], f"grid {w}x{h}")
        if w * h > MAX_CELLS:
            raise self.broken(self.limits[1], f"{w * h} cells")


class StripSweeps:
    """The pressure sweep's kernel choice, shared by the 2D and 3D simulations: ProjectStep2Rows (strips of 4 cells)
    where ``_configure`` made its launch (variant fixed, a grid width divisible by 4) and the device is a GPU (or
    any device, with ``strips_on_cpu``), else the book's one-cell ProjectStep2; the same pressures bit for bit."""

    _sweep_kernel: str | None = None  # None: the device's choice
    strips_on_cpu = False
    """2D: PoCL vectorises the one-cell ProjectStep2 across work-items, and the strips are slower there (512^2:
    292 against 163 us a sweep, 2026-11-25)."""

    @property
    def sweep_kernel(self) -> str:
        """ProjectStep2Rows on GPUs where it can run, else ProjectStep2. Settable (tests, the bench); None restores
        the device's choice."""
        self._configure()
        rows = "ProjectStep2Rows" in self._launches
        if self._sweep_kernel is None or (self._sweep_kernel == "ProjectStep2Rows" and not rows):
            return "ProjectStep2Rows" if rows and (self.runtime.is_gpu or self.strips_on_cpu) else "ProjectStep2"
        return self._sweep_kernel  # (a ProjectStep2Rows set before a live switch to variant=book falls back above)

    @sweep_kernel.setter
    def sweep_kernel(self, name: str | None) -> None:
        self._configure()
        if name == "ProjectStep2Rows" and "ProjectStep2Rows" not in self._launches:
            raise ValueError(f"sweep_kernel ProjectStep2Rows needs variant=fixed and a grid width divisible by 4, "
                             f"got variant={self.params.variant}, width {int(self.dims[0])}")  # fmt: skip
        if name not in (None, "ProjectStep2", "ProjectStep2Rows"):
            raise ValueError(f"sweep_kernel must be ProjectStep2 or ProjectStep2Rows, got {name!r}")
        self._sweep_kernel = name

    @property
    def rows_local_size(self) -> tuple[int, ...] | None:
        """ProjectStep2Rows' work-group shape in strips; None where it cannot run."""
        self._configure()
        return self._launches["ProjectStep2Rows"][2] if "ProjectStep2Rows" in self._launches else None


class Simulation(StripSweeps, BaseSimulation):
    """Velocity, density and the multiplexed prev field on a w x h grid; one step = the original's Update()."""

    Params = Params
    history = ("density", "kinetic_energy")

    @classmethod
    def allocations(cls, params: Params) -> list[Allocation]:
        cells = params.grid[0] * params.grid[1]
        floats = {"velocity": 2, "velocity (write)": 2, "density": 1, "density (write)": 1, "prev": 4,
                  "prev (write)": 4, "divergence": 1, "pressure": 1, "pressure (write)": 1, "source": 4,
                  "no source": 4, "solver": 4}  # the fields of _reset  # fmt: skip
        fields = [Allocation(f"{name} field", cells * 4 * n, "width") for name, n in floats.items()]
        return [*fields, Allocation("view texture (half floats)", cells * 2 * 2, "width")]

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.w, self.h = p.grid
        self.shape = (self.h, self.w)  # numpy (H, W): row y, column x
        self.dims = (np.int32(self.w), np.int32(self.h))
        self.velocity = PingPong.zeros(rt, (*self.shape, 2), np.float32)  # (u, v)
        self.density = PingPong.zeros(rt, self.shape, np.float32)
        self.prev = PingPong.zeros(rt, (*self.shape, 4), np.float32)  # multiplexed: see the .cl header
        # variant fixed: the pressure solve's own fields (a sweep moves 12 bytes per cell, not prev's 32)
        self.divergence = rt.zeros(self.shape, np.float32)
        self.pressure = PingPong.zeros(rt, self.shape, np.float32)
        self.solving = False  # fixed, between ProjectStep1 and ProjectStep3: p lives in `pressure`, not in prev.x
        self.source = rt.zeros((*self.shape, 4), np.float32)
        self.no_source = rt.zeros((*self.shape, 4), np.float32)  # what AdvectDensityFromExt reads with no brush
        self.solver = rt.zeros((*self.shape, 4), np.float32)
        # draw_texture: the view's half floats (up to 2 a cell: velocity) and their largest magnitude
        self.texture = rt.zeros(self.w * self.h * 2, np.float16)
        self.texture_top = rt.zeros(1, np.int32)
        self.pending_brush: tuple[float, float, float, float] | None = None
        self.last_brush: tuple[float, float, float, float] | None = None
        self.stroke_start = 0
        self._config_key = self._configured_for = None  # sizes and kernels follow the grid, local_size, variant
        self._sweep_kernel = None  # the device's choice (StripSweeps)

    # {{{ programs and launches

    def _configure(self) -> None:
        """Work-group shape, launch shapes and kernels for the current local_size and variant (both live). Called when
        ``params`` is a new object (``update`` replaces it); a pair seen before reuses the runtime's built program."""
        p = self.params
        key = (p.local_size, p.variant)
        if self._config_key != key:
            device = self.runtime.device
            size = self._local = fitted_shape(p.local_size, device)  # the kernels' reqd_work_group_size
            # the kernels that set the walls themselves: rows of work-groups past the grid's, as many as the wall
            # cells fill (one work-item per wall cell)
            walls = 2 * self.w + 2 * self.h - 4
            wall_groups = -(-walls // (size[0] * size[1]))  # ceil
            per_row = -(-self.w // size[0])  # work-groups in a row of the grid
            wall_rows = -(-wall_groups // per_row)  # rows of work-groups the wall cells fill
            with_walls = (self.w, self.h + wall_rows * size[1])
            self._program = self.runtime.program(
                STEM, THREAD_X=size[0], THREAD_Y=size[1], BOOK_VARIANT=p.variant == "book", ROWS=ROWS_PER_ITEM
            )
            self._launches = {  # name: (kernel, work-items, work-group) of Kernel.over
                name: (self._program.kernel(name), with_walls if name in SETS_WALLS else (self.w, self.h), size)
                for name in KERNELS
                if name != "ProjectStep2Rows" and not name.startswith("SetBoundary")  # their own shapes
            }
            if p.variant == "fixed" and self.w % 4 == 0:  # strips of 4 cells x ROWS_PER_ITEM rows, walls included
                kernel = self._program.kernel("ProjectStep2Rows")
                rows_local = fitted_shape(ROWS_LOCAL, device, kernel.work_group_size())
                self._launches["ProjectStep2Rows"] = (kernel, (self.w // 4, -(-self.h // ROWS_PER_ITEM)), rows_local)
            self._config_key = key
        self._configured_for = p

    @property
    def local_size(self) -> tuple[int, int]:
        """The wanted work-group shape, its larger side halved until the device can run it."""
        self._configure()
        return self._local

    @property
    def program(self):
        self._configure()
        return self._program

    def _grid(self, name: str, *args) -> None:
        """Launch a grid kernel over every cell (a SETS_WALLS kernel also over its wall work-groups, ProjectStep2Rows
        over its strips); ``args`` in the kernel's order (buffers, w, h, scalars)."""
        if self.params is not self._configured_for:
            self._configure()
        kernel, shape, group = self._launches[name]
        kernel.over(shape, group, *args)

    def _boundary(self, name: str, field: cla.Array, *args) -> None:
        """SetBoundary<name> on ``field`` (``args`` follow it: DivPositive's stride): one launch over the
        2(w-2) + 2(h-2) edge cells and the 4 corners."""
        self.program.kernel(f"SetBoundary{name}")(2 * self.w + 2 * self.h - 4, None, field, *args, *self.dims)

    # }}}

    # {{{ boundaries on their own (step() has the kernels apply them, as the book's in-kernel SetBoundary* calls)

    def set_boundary_density(self) -> None:
        self._boundary("Density", self.density.read)

    def set_boundary_velocity(self) -> None:
        self._boundary("Velocity", self.velocity.read)

    def set_boundary_divergence(self) -> None:
        self._boundary("Divergence", self.prev.read)

    def set_boundary_div_positive(self) -> None:
        """SetBoundaryDivPositive on p: prev.x, or the pressure field while a fixed projection runs (see solving)."""
        p, stride = (self.pressure.read, 1) if self.solving else (self.prev.read, 4)
        self._boundary("DivPositive", p, np.int32(stride))

    # }}}

    # {{{ kernels, in the book's order

    def add_source_brush(self, u: float, v: float, du: float, dv: float) -> None:
        """AddSourceBrush: the brush at uv (u, v) moving (du, dv) cells this frame, into ``source``."""
        radius = np.float32(self.params.source_radius)
        self._grid(
            "AddSourceBrush", self.source, *self.dims, cltypes.make_float2(u, v), cltypes.make_float2(du, dv), radius
        )

    def add_source_velocity(self, dt: float) -> None:
        """AddSourceVelocity: velocity += source.xy*velocity_coef*dt; prev.xy = the same."""
        coef = np.float32(self.params.velocity_coef)
        self._grid(
            "AddSourceVelocity", self.velocity.read, self.prev.read, self.source, *self.dims, coef, np.float32(dt)
        )

    def diffuse_velocity(self, dt: float, sweeps: int | None = None) -> None:
        """DiffuseVelocity: ``sweeps`` (default gs_iterations) Jacobi sweeps, each setting the walls
        (SetBoundaryVelocity's rule, applied by the kernel)."""
        a = np.float32(dt * self.params.visc * self.w * self.h)  # book: a = dt * visc * w * h
        velocity, prev, (w, h) = self.velocity, self.prev.read, self.dims
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid("DiffuseVelocity", velocity.read, velocity.write, prev, w, h, a)
            velocity.swap()

    def project_step1(self) -> None:
        """ProjectStep1: prev = (0, div, prev.z, 0), the walls' div copied from inside (SetBoundaryDivergence's rule;
        p = 0 everywhere, so SetBoundaryDivPositive's changes nothing)."""
        if self.params.variant == "book":
            self._grid("ProjectStep1", self.velocity.read, self.prev.read, *self.dims)
        else:
            self._grid(
                "ProjectStep1", self.velocity.read, self.prev.read, self.divergence, self.pressure.read, *self.dims
            )
            self.solving = True

    def project_step2(self, sweeps: int | None = None) -> None:
        """ProjectStep2: ``sweeps`` (default gs_iterations) Jacobi sweeps for p, each setting the walls
        (SetBoundaryDivPositive's rule, applied by the kernel). fixed: on the divergence and pressure fields
        ProjectStep1 filled, not on prev."""
        book, (w, h) = self.params.variant == "book", self.dims
        p, extra = (self.prev, ()) if book else (self.pressure, (self.divergence,))
        kernel = self.sweep_kernel  # ProjectStep2, or its strips on GPUs: the same arguments
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid(kernel, p.read, p.write, *extra, w, h)
            p.swap()

    def project_step3(self) -> None:
        """ProjectStep3: velocity -= 0.5*grad p*(w, h) (in place, as the book); SetBoundaryVelocity.
        fixed: p from the pressure field, copied into prev.x."""
        if self.params.variant == "book":
            self._grid("ProjectStep3", self.velocity.read, self.prev.read, *self.dims)
        else:
            self._grid("ProjectStep3", self.velocity.read, self.prev.read, self.pressure.read, *self.dims)
            self.solving = False
        self.set_boundary_velocity()

    def project(self, sweeps: int | None = None) -> None:
        """The book's mass conservation: ProjectStep1, ProjectStep2 (x sweeps), ProjectStep3. vol.4's copy runs no
        sweep, so p stays 0 and only the wall rules change the velocity."""
        if sweeps is None:
            sweeps = self.params.gs_iterations if self.params.solver == "vol1" else 0
        self.project_step1()
        self.project_step2(sweeps)
        self.project_step3()

    def swap_velocity(self) -> None:
        """SwapVelocity: prev.xy = velocity."""
        self._grid("SwapVelocity", self.velocity.read, self.prev.read, *self.dims)

    def advect_velocity(self, dt: float) -> None:
        """AdvectVelocity: velocity = prev.xy at the back-traced point, walls set (SetBoundaryVelocity's rule)."""
        self._grid("AdvectVelocity", self.prev.read, self.velocity.read, *self.dims, self._dfdt(dt))

    def add_source_density(self, dt: float) -> None:
        """AddSourceDensity: density += source.z*density_coef*dt; prev.z = the same."""
        coef = np.float32(self.params.density_coef)
        self._grid("AddSourceDensity", self.density.read, self.prev.read, self.source, *self.dims, coef, np.float32(dt))

    def diffuse_density(self, dt: float, sweeps: int | None = None) -> None:
        """DiffuseDensity: ``sweeps`` (default gs_iterations) Jacobi sweeps, each setting the walls
        (SetBoundaryDensity's rule, applied by the kernel)."""
        a = np.float32(dt * self.params.diff * self.w * self.h)  # book: a = dt * diff * w * h
        density, prev, (w, h) = self.density, self.prev.read, self.dims
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid("DiffuseDensity", density.read, density.write, prev, w, h, a)
            density.swap()

    def swap_density(self) -> None:
        """SwapDensity: prev.z = density."""
        self._grid("SwapDensity", self.density.read, self.prev.read, *self.dims)

    def advect_density(self, dt: float) -> None:
        """AdvectDensity: density = prev.z at the point back-traced by the velocity, walls set (SetBoundaryDensity's
        rule)."""
        self._grid("AdvectDensity", self.velocity.read, self.prev.read, self.density.read, *self.dims, self._dfdt(dt))

    def advect_density_from_ext(self, dt: float, brush: bool = True) -> None:
        """AdvectDensityFromExt: as AdvectDensity, back-traced by the brush's velocity (zero with no brush)."""
        source = self.source if brush else self.no_source
        self._grid("AdvectDensityFromExt", source, self.prev.read, self.density.read, *self.dims, self._dfdt(dt))

    def draw(self) -> None:
        """Draw: solver = (u, v, density, 1)."""
        self._grid("Draw", self.velocity.read, self.density.read, self.solver, *self.dims)

    def draw_texture(self, field: str = "density") -> tuple[np.ndarray, float]:
        """DrawTexture (not in the book; the view's): ``field`` ("density", "velocity" (u, v) or "divergence", the
        central differences of central_divergence) as an (H, W) or (H, W, 2) float16 array, and the largest magnitude
        of its float values (of u and v for velocity; 0 for the density, which no display scales). 2 or 4 bytes a
        cell and 4 cross to the host instead of solver's 16 a cell, into page-locked copies (Runtime.read_back):
        the array is overwritten by the next call."""
        rt, channels = self.runtime, TEXTURE_FIELDS[field]
        cl.enqueue_fill_buffer(rt.queue, self.texture_top.base_data, np.int32(0), 0, self.texture_top.nbytes)
        shown = np.int32(list(TEXTURE_FIELDS).index(field))
        args = (self.velocity.read, self.density.read, self.texture, self.texture_top, shown, *self.dims)
        self._grid("DrawTexture", *args)
        texture = rt.read_back(self.texture, self.w * self.h * channels)
        top = rt.read_back(self.texture_top).view(np.float32)  # non-negative floats' bits (see the kernel)
        return texture.reshape(self.shape if channels == 1 else (*self.shape, channels)), float(top[0])

    def _dfdt(self, dt: float) -> np.float32:
        return np.float32(dt * (self.w + self.h) * 0.5)  # book: dfdt = dt * (w + h) * 0.5, cells per unit velocity

    # }}}

    # {{{ the brush

    def brush(self, u: float, v: float, du: float = 0.0, dv: float = 0.0) -> None:
        """Hold the brush down at uv (u, v) (0..1, v up) for the next step; (du, dv) is how far it moved since the
        last frame in uv units (the mouse delta). It turns into cells, clamped to ``mouse_clamp`` as the book's
        MouseSourceProvider clamps the pixel delta. Overrides the scripted stroke for that step."""
        for name, value in (("u", u), ("v", v), ("du", du), ("dv", dv)):
            if not math.isfinite(value):
                raise ValueError(f"brush {name} must be a finite number, got {value!r}")
        mx, my = du * self.w, dv * self.h
        length = math.hypot(mx, my)
        if length > self.params.mouse_clamp:
            mx, my = mx * self.params.mouse_clamp / length, my * self.params.mouse_clamp / length
        self.pending_brush = (float(u), float(v), mx, my)

    def restart_stroke(self) -> None:
        """Play the scripted stroke again from its first frame."""
        self.stroke_start = self.steps

    def scripted_brush(self, frame: int) -> tuple[float, float, float, float] | None:
        """(u, v, du, dv) of the scripted stroke on ``frame`` frames after its start, or None when it is up."""
        return stroke_brush(self.params.stroke, frame, self.params.stroke_frames)

    def _take_brush(self) -> tuple[float, float, float, float] | None:
        brush = self.pending_brush or self.scripted_brush(self.steps - self.stroke_start)
        self.pending_brush = None
        return brush

    # }}}

    def velocity_step(self, dt: float, brush: bool) -> None:
        if brush:
            self.add_source_velocity(dt)
        self.diffuse_velocity(dt)
        self.project()
        self.swap_velocity()
        if self.params.solver == "vol1":  # vol.4's copy has no AdvectVelocity
            self.advect_velocity(dt)
        self.project()

    def density_step(self, dt: float, brush: bool) -> None:
        if brush:
            self.add_source_density(dt)
        self.diffuse_density(dt)
        self.swap_density()
        if self.params.density_only:
            self.advect_density_from_ext(dt, brush)  # the original binds this kernel but dispatches AdvectDensity
        else:
            self.advect_density(dt)

    def _step(self, dt: float) -> None:
        brush = self._take_brush()
        self.last_brush = brush
        if brush is not None:
            self.add_source_brush(*brush)
        if not self.params.density_only:
            self.velocity_step(dt, brush is not None)
        self.density_step(dt, brush is not None)
        self.draw()

    # {{{ state

    def set_fields(self, velocity=None, density=None, prev=None, source=None) -> None:
        """Overwrite fields (tests, experiments): velocity (H, W, 2), density (H, W), prev and source (H, W, 4)."""
        for name, array, target, channels in (
            ("velocity", velocity, self.velocity.read, (2,)),
            ("density", density, self.density.read, ()),
            ("prev", prev, self.prev.read, (4,)),
            ("source", source, self.source, (4,)),
        ):
            if array is None:
                continue
            array = np.ascontiguousarray(array, np.float32)
            if array.shape != (*self.shape, *channels):
                raise ValueError(f"{name} must have shape {(*self.shape, *channels)}, got {array.shape}")
            target.set(array)

    def solver_field(self) -> np.ndarray:
        """The Draw output (H, W, 4) = (u, v, density, 1): what the view renders."""
        return self.solver.get()

    def state(self) -> dict[str, np.ndarray]:
        velocity = self.velocity.read.get()
        prev = self.prev.read.get()
        if self.solving:  # mid-projection (fixed): prev as the book's would be, p in x
            prev[..., 0] = self.pressure.read.get()
        return {
            "velocity": velocity,
            "density": self.density.read.get(),
            "prev": prev,
            "solver": self.solver.get(),
            "source": self.source.get(),
            "divergence": central_divergence(velocity),
            "kinetic_energy": np.float32(kinetic_energy(velocity)),
        }

    def restore(self, state: dict[str, np.ndarray]) -> None:
        put(self.velocity.read, state["velocity"], "velocity")
        put(self.density.read, state["density"], "density")
        put(self.prev.read, state["prev"], "prev")
        put(self.solver, state["solver"], "solver")
        put(self.source, state["source"], "source")

    def stats(self) -> dict:
        state = self.state()
        speed = np.linalg.norm(state["velocity"], axis=-1)
        return {
            **super().stats(),
            "grid": f"{self.w}x{self.h}",
            "variant": self.params.variant,
            "solver": self.params.solver,
            "local size": self.local_size,
            "sweep kernel": self.sweep_kernel,
            "max density": float(state["density"].max()),
            "total density": float(state["density"].sum(dtype=np.float64)),
            "max speed": float(speed.max()),
            "back-trace cells/frame (max)": float(speed.max() * self._dfdt(self.default_dt)),
            "kinetic energy": float(state["kinetic_energy"]),
            "mean |divergence| (interior)": float(np.abs(state["divergence"][1:-1, 1:-1]).mean()),
        }

    # }}}


def stroke_brush(stroke: str, frame: int, frames: int) -> tuple[float, float, float, float] | None:
    """The scripted brush (u, v, du, dv) on ``frame`` (du, dv: the move in cells, length 1), None once it is up."""
    if stroke == "none" or frame < 0 or (frames and frame >= frames):
        return None
    t = (frame % STROKE_PERIOD) / STROKE_PERIOD
    if stroke == "line":  # left to right through the centre
        return 0.3 + 0.4 * t, 0.5, 1.0, 0.0
    angle = 2.0 * math.pi * t
    if stroke == "circle":  # counter-clockwise, radius 0.25 in uv
        return 0.5 + 0.25 * math.cos(angle), 0.5 + 0.25 * math.sin(angle), -math.sin(angle), math.cos(angle)
    # figure8: a Lissajous curve 1:2, direction = its unit tangent
    dx, dy = 0.3 * math.cos(angle), 0.3 * math.cos(2.0 * angle)
    length = math.hypot(dx, dy) or 1.0
    return 0.5 + 0.3 * math.sin(angle), 0.5 + 0.15 * math.sin(2.0 * angle), dx / length, dy / length


def central_divergence(velocity: np.ndarray) -> np.ndarray:
    """du/dx + dv/dy by central differences over a domain of length 1 per axis: 0.5*(u(x+1) - u(x-1))*w + ...,
    neighbours outside the grid read 0 (as the kernels' ld). The fixed projection drives -0.5*(du/w + dv/h) to 0,
    proportional to this on square grids."""
    v = velocity.astype(np.float64)
    h, w = v.shape[:2]
    padded = np.pad(v, ((1, 1), (1, 1), (0, 0)))
    du = padded[1:-1, 2:, 0] - padded[1:-1, :-2, 0]
    dv = padded[2:, 1:-1, 1] - padded[:-2, 1:-1, 1]
    return (0.5 * (du * w + dv * h)).astype(np.float32)


def kinetic_energy(velocity: np.ndarray) -> float:
    """0.5*|v|^2 averaged over the cells."""
    return float(0.5 * np.mean(np.sum(velocity.astype(np.float64) ** 2, axis=-1)))


SCENE_DEFAULTS = {"velocity_coef": 60.0, "density_coef": 8.0}
"""The scene's brush: 30x the sample scene's velocity gain and 4x its ink gain; the solver (diff, visc, sweeps,
kernels) stays the book's. With the sample's gains (2, 2) the scripted stroke, a brush moving along as a hand drags
the mouse (its velocity clamped to one cell per frame), leaves a faint grey ring (max density 0.035) that the flow
barely moves (a back-trace of 0.27 cells per frame): a short run shows a pale smudge. With these, ten frames paint a
dark stroke and the flow visibly stirs the ink. A hand that holds the mouse still paints dark ink with the book's
gains too; ``--set velocity_coef=2 --set density_coef=2`` runs the sample scene's brush."""
PREVIEW = {"steps": 200, "stroke_frames": 0}
"""docs/img/stable_fluids_2d.png: the circle stroke still painting after 200 frames (fresh dark ink curling over the
older, diffused grey)."""

SCENES = [
    Scene(
        STEM,
        Simulation,
        "Stable fluids in 2D: ink painted by a brush, black on white (vol.1 ch.4)",
        SCENE_DEFAULTS,
        view="View",
        preview=PREVIEW,
        # the brush paints one dab of radius 0.022 (the sample scene's) per frame, moving as a hand drags: what ten
        # frames can cover whatever the gains
        preview_check=PreviewCheck(
            min_subject=0.005,
            sparse="a brush stroke: ten frames of the book's brush (radius 0.022 of the screen, one dab a frame) paint "
            "a dark stroke of 0.6 % of an 800x600 frame; the preview's ring covers 30 %",
        ),
        animation=Animation("the scripted circle stroke stirs the ink round", every=2),
        at_scale=AtScale(gpu={"width": 2048, "height": 2048}, cpu={"width": 256, "height": 256}),
    )
]
