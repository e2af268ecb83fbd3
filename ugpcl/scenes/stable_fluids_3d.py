"""Stable fluids in 3D: Stam's solver on a w x h x d grid with a smoke emitter (vol.1 ch.4;
docs/chapters/04-stable-fluids-3d.md).

The original ships ``Solver3D.compute`` and ``Solver3D.cs`` but no scene that runs them (and they cannot run as
written: the chapter page lists why). This is that solver, with the same kernels and order as the 2D one (+B = the
kernel applies the field's boundary rule itself, as the book's kernels call their SetBoundary* helper at the end):

    AddSourceBrush3D                                   (emitter on)
    velocity step (unless density_only):
      AddSourceVelocity -> gs x DiffuseVelocity+B -> Project -> SwapVelocity -> AdvectVelocity+B -> Project
    density step:
      AddSourceDensity -> gs x DiffuseDensity+B -> SwapDensity -> AdvectDensity+B (AdvectDensityFromExt+B)
    Draw
    Project = ProjectStep1+B(Div) -> gs x ProjectStep2+B(P) -> ProjectStep3 -> SetBoundaryVelocity

The AddSource kernels run only while the source is on (the original passes no source texture otherwise), so
``prev`` keeps its leftovers as the book's does. ``variant=book`` runs these kernels one by one; ``variant=fixed``
runs the same step in fewer, fused launches on ``prev`` split into float fields (``fused_step``):

    gs x DiffuseFields+B -> Project' -> SwapAdvectVelocity+B -> Project' -> SwapAdvectDensity+B
    Project' = ProjectStep1+B(Div) (with the first sweep) -> (gs - 1) x ProjectStep2+B(P) -> ProjectStep3
               -> SetBoundaryVelocity

with the fields bit for bit those of the kernels one by one (tested; 316 instead of 664 bytes a cell at gs 2), the
sweeps in strips along z (DiffuseFieldsRows, ProjectStep2Rows).

Differences from the book: Jacobi sweeps between ping-pong buffers (the original's in-place Gauss-Seidel races); the
walls are set by extra work-groups past the grid (``SETS_WALLS``), one work-item per wall cell computing the kernel's
value at the cells its rule reads, instead of reading cells other work-items write (the results of separate face,
edge and corner passes, bit for bit); a scripted emitter (``emitter``, ``emitter_frames``) replaces the missing
source provider; ``variant=fixed`` (default) uses Stam's divergence, clamps the back-trace and runs the pressure
solve on its own float divergence and pressure fields (12 bytes per cell and sweep instead of the float4 prev's 32;
prev.xy ends as (p, div) all the same), ``variant=book`` keeps the original's divergence precedence bug and
unclamped back-trace. Bugs that would stop Solver3D from running at all are fixed in both variants (guards on
id.x < d, AdvectDensity sampling prev.z, a 2-channel velocity volume, integer uvw, the last corner rule,
diffusion coefficient without d): the 3D solver follows the 2D one's intent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import PingPong, ordered_floats, put
from ..resources import Allocation
from ..runtime import fitted_shape
from ..scene import Animation, AtScale, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation
from .stable_fluids_2d import StripSweeps

STEM = "stable_fluids_3d"
MAX_CELLS = 1 << 25
"""Largest grid accepted (w*h*d): 320^3-ish, 3.5 GB of fields. The GPU bench goes to 256^3 = 16.8M cells."""
KERNELS = (
    "AddSourceBrush3D",
    "AddSourceVelocity",
    "DiffuseVelocity",
    "ProjectStep1",
    "ProjectStep1Rows",
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
    "DiffuseFields",
    "DiffuseFieldsRows",
    "SwapAdvectVelocity",
    "SwapAdvectDensity",
    "Draw",
    "DrawVolume",
    "SetBoundaryDensity",
    "SetBoundaryDiv",
    "SetBoundaryP",
    "RayMarchSmoke",
)
"""The kernels of stable_fluids_3d.cl in host call order (its header's list); the last three only for set_boundary_*.
ProjectStep2Rows is ProjectStep2 in strips (sweep_kernel), DiffuseFieldsRows DiffuseFields in strips
(diffuse_kernel) and ProjectStep1Rows fused_step's ProjectStep1 in strips, built for the fixed variant only, as FUSED;
DrawVolume only for the view (draw_volume), and RayMarchSmoke (ray_march, launched over the picture's pixels)."""
FUSED = frozenset({"DiffuseFields", "DiffuseFieldsRows", "ProjectStep1Rows", "SwapAdvectVelocity", "SwapAdvectDensity"})
"""The kernels of the fixed variant's step() that each do several of the book's (fused_step); fixed builds only."""
ROWS_PER_ITEM = 2
"""Cells along z of the 4-cell strip one work-item of ProjectStep2Rows sweeps (its ROWS define)."""
ROWS_LOCAL = (32, 4, 1)
"""ProjectStep2Rows' work-group shape, in strips. On the H100 (2026-11-25, an exploration run) a 256^3 sweep takes
75.1 us with it and 2 cells along z (74.9-77.6 us for 2 or 4 cells in nine shapes; 92 % of the copy bandwidth),
against 127.1 us for ProjectStep2 in the book's 8 x 8 x 4 groups; 128^3: 16.1 against 19.9 us."""
FIELD_ROWS = 4
"""Cells along z of the strip one work-item of DiffuseFieldsRows and ProjectStep1Rows sweeps (their FIELD_ROWS define):
the planes below and above the strip are read twice, by it and by its neighbour."""
FIELD_ROWS_LOCAL = (64, 4, 1)
"""DiffuseFieldsRows' and ProjectStep1Rows' work-group shape, in strips of one cell across: a GPU warp reads 32 cells
of a row, 512 bytes of velocity, where the book's 8 x 8 x 4 groups read rows of 8."""
SETS_WALLS = frozenset(
    {"DiffuseVelocity", "ProjectStep1", "ProjectStep2", "AdvectVelocity", "DiffuseDensity", "AdvectDensity"}
    | {"AdvectDensityFromExt"}
    | FUSED
)
"""Kernels that apply their field's boundary rule themselves: launched with extra layers of work-groups past the
grid, one work-item per wall cell, as stable_fluids_3d.cl's wall_item() expects."""


@dataclass(frozen=True)
class Params(BaseParams):
    width: int = param(64, 3, 2048)
    """Grid cells along x (this port's default; the original takes Screen.width)."""
    height: int = param(64, 3, 2048)
    """Grid cells along y, y = 0 at the bottom (the original takes Screen.height)."""
    depth: int = param(64, 3, 2048)
    """Grid cells along z (book: depth, a serialized field never set in any scene)."""
    diff: float = param(10.0, 0.0, 1e6, live=True)
    """Density diffusion coefficient kappa; a_d = dt*diff*w*h*d (book: diff; scene 10, code default 0).
    Up to 1e6: a <= 3.4e13 keeps the Jacobi sums finite in float32."""
    visc: float = param(20.0, 0.0, 1e6, live=True, ignored_when={"density_only": True})
    """Kinematic viscosity nu; a_v = dt*visc*w*h*d (book: visc; scene 20, code default 0).
    Up to 1e6: a <= 3.4e13 keeps the Jacobi sums finite in float32."""
    velocity_coef: float = param(2.0, 0.0, 1e4, live=True, ignored_when={"density_only": True})
    """Gain of the source's velocity, per second (book: velocityCoef; 2D sample scene 2; see SCENE_DEFAULTS).
    Up to 1e4: the sources stay finite in float32."""
    density_coef: float = param(2.0, 0.0, 1e4, live=True)
    """Gain of the source's density, per second (book: densityCoef; 2D sample scene 2; see SCENE_DEFAULTS).
    Up to 1e4: the sources stay finite in float32."""
    density_only: bool = param(False, live=True)
    """Skip the velocity step and advect the density by the source's velocity (book: isDensityOnly)."""
    gs_iterations: int = param(2, 1, 4096, live=True)
    """Jacobi sweeps per diffusion and per pressure solve (book: GS_ITERATE = 2 in Solver3D.compute)."""
    emitter: bool = param(True, live=True)
    """Scripted source on: a continuous spherical emitter, headless runs' stand-in for a source (not in the book: its
    sample has no 3D scene)."""
    emitter_frames: int = param(0, 0, 1 << 30, live=True, ignored_when={"emitter": False})
    """Frames the emitter blows from the start; 0 = the whole run (120: a puff, then the smoke drifts).
    At most 2^30 frames."""
    emitter_center: tuple[float, float, float] = param(
        (0.5, 0.15, 0.5), 0.0, 1.0, live=True, ignored_when={"emitter": False}
    )
    """Centre c of the spherical emitter in uvw units, (0, 0, 0) = the grid's bottom-left-front corner."""
    emitter_direction: tuple[float, float, float] = param(
        (0.0, 1.0, 0.0), -1.0, 1.0, live=True, ignored_when={"emitter": False}
    )
    """Velocity the emitter blows (its dir; the 2D brush's clamped mouse delta), before velocity_coef."""
    source_radius: float = param(0.08, 0.0, 1.0, lo_open=True, live=True, ignored_when={"emitter": False})
    """Emitter radius r in uvw units: f = clamp(1 - |(uvw - c)/r|^2, 0, 1) (book 2D: sourceRadius; see
    SCENE_DEFAULTS)."""
    variant: str = param("fixed", choices=("book", "fixed"), live=True)
    """fixed: Stam's divergence, back-trace clamped to the grid; book: the original's divergence and no clamp."""
    local_size: tuple[int, int, int] = param((8, 8, 4), 1, 1024)
    """Work-group shape of the grid kernels (book: numthreads(8, 8, 4)); halved where the device cannot run it."""
    absorption: float = param(80.0, 0.0, 1e6, lo_open=True, live=True)
    """Render only: extinction of the ray-marched smoke per unit density per box length. Up to 1e6."""

    limits = (f"width*height*depth <= {MAX_CELLS}",)

    def check(self) -> None:
        cells = self.width * self.height * self.depth
        if cells > MAX_CELLS:
            raise self.broken(self.limits[0], f"{cells} cells")


class Simulation(StripSweeps, BaseSimulation):
    """Velocity, density and the multiplexed prev field on a w x h x d grid; one step = the original's Update()."""

    strips_on_cpu = True
    """3D: the strips are faster on PoCL too, where the book's 8 x 8 x 4 work-groups, not memory, limit ProjectStep2
    (2 cores, 2026-11-25, best of 3: a 128^3 sweep 2.5 against 8.1 ms, 64^3 0.21 against 1.1 ms)."""

    Params = Params
    history = ("density", "kinetic_energy")

    @classmethod
    def allocations(cls, params: Params) -> list[Allocation]:
        cells = params.width * params.height * params.depth
        floats = {"velocity": 4, "velocity (write)": 4, "density": 1, "density (write)": 1, "prev": 4,
                  "prev (write)": 4, "divergence": 1, "pressure": 1, "pressure (write)": 1, "prev z": 1,
                  "prev density": 1, "source": 4, "no source": 4, "solver": 4}  # the fields of _reset  # fmt: skip
        fields = [Allocation(f"{name} field", cells * 4 * n, "width") for name, n in floats.items()]
        return [*fields, Allocation("view volume (half floats)", cells * 2, "width")]

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.shape = (p.depth, p.height, p.width)  # numpy (D, H, W): row z*h + y, column x
        self.dims = (np.int32(p.width), np.int32(p.height), np.int32(p.depth))
        self.local_size = fitted_shape(p.local_size, rt.device)  # the kernels' reqd_work_group_size
        # SetBoundary*: one work-item per wall cell; the kernels that set the walls themselves get layers of
        # work-groups past the grid's along z, as many as the wall cells fill (stable_fluids_3d.cl, wall_item)
        self._boundary_size = p.width * p.height * p.depth - (p.width - 2) * (p.height - 2) * (p.depth - 2)
        self._walls_shape = self._with_wall_groups(p.depth, self.local_size)
        self.velocity = PingPong.zeros(rt, (*self.shape, 4), np.float32)  # (u, v, w, 0)
        self.density = PingPong.zeros(rt, self.shape, np.float32)
        self.prev = PingPong.zeros(rt, (*self.shape, 4), np.float32)
        # variant fixed: the pressure solve's own fields (a sweep moves 12 bytes per cell, not prev's 32)
        self.divergence = rt.zeros(self.shape, np.float32)
        self.pressure = PingPong.zeros(rt, self.shape, np.float32)
        self.solving = False  # fixed, between ProjectStep1 and ProjectStep3: p lives in `pressure`, not in prev.x
        # fixed's step() (fused_step): prev split into float fields, x = pressure, y = divergence, z and w these two
        self.prev_z = rt.zeros(self.shape, np.float32)
        self.prev_density = rt.zeros(self.shape, np.float32)
        self.prev_split = p.variant == "fixed"  # where prev lives now (all zero: either); _float4_prev, _split_prev
        self.source = rt.zeros((*self.shape, 4), np.float32)
        self.no_source = rt.zeros((*self.shape, 4), np.float32)  # what AdvectDensityFromExt reads with no source
        self.solver = rt.zeros((*self.shape, 4), np.float32)
        # draw_volume: the view's half-float field and the two maxima
        self.volume = rt.zeros(self.shape, np.float16)
        self.maxima = rt.zeros(2, np.int32)
        self.smoke_image = None  # ray_march's picture, made for the size asked
        self.external_source = False
        self._brush_of = None  # the emitter that source holds (add_source_brush3d), None: unknown
        self.solver_stale = False  # solver lags velocity and density: Draw runs once it is read (_step)
        self._built_for = self._configured_for = None  # the program follows local_size and variant (_configure)

    def _with_wall_groups(self, grid_z: int, local: tuple[int, int, int]) -> tuple[int, int, int]:
        """The work-items of a kernel that sets walls itself: the grid's (w x h x ``grid_z``, in work-groups of
        ``local``), then layers of work-groups along z, as many as the wall cells fill."""
        w, h = self.params.width, self.params.height
        wall_groups = -(-self._boundary_size // math.prod(local))  # ceil
        per_layer = math.prod(-(-n // t) for n, t in zip((w, h), local[:2], strict=True))
        layers = -(-wall_groups // per_layer)
        return (w, h, -(-grid_z // local[2]) * local[2] + layers * local[2])

    @property
    def program(self):
        """The program for the work-group shape and the current variant (live: rebuilt from the runtime's cache)."""
        if self.params is not self._configured_for:
            self._configure()
        return self._program

    def _configure(self) -> None:
        """Program and kernels for the current params (``update`` replaces the Params object; variant is live)."""
        tx, ty, tz = self.local_size
        book = self.params.variant == "book"
        if self._built_for != book:
            strips = {"ROWS": ROWS_PER_ITEM, "FIELD_ROWS": FIELD_ROWS}
            self._program = self.runtime.program(
                STEM, THREAD_X=tx, THREAD_Y=ty, THREAD_Z=tz, BOOK_VARIANT=book, **strips
            )
            grid = tuple(int(n) for n in self.dims)
            self._launches = {  # name: (kernel, work-items, work-group) of Kernel.over
                name: (self._program.kernel(name), self._walls_shape if name in SETS_WALLS else grid, self.local_size)
                for name in KERNELS
                if not name.endswith("Rows") and not name.startswith("SetBoundary")  # their own shapes
                if not (book and name in FUSED)
            }
            w, h, d = grid
            if not book:  # strips of 1 x 1 x FIELD_ROWS cells, then the wall groups
                kernel = self._program.kernel("DiffuseFieldsRows")
                local = fitted_shape(FIELD_ROWS_LOCAL, self.runtime.device, kernel.work_group_size())
                shape = self._with_wall_groups(-(-d // FIELD_ROWS), local)
                self._launches["DiffuseFieldsRows"] = (kernel, shape, local)
                kernel = self._program.kernel("ProjectStep1Rows")  # walls included
                local = fitted_shape(FIELD_ROWS_LOCAL, self.runtime.device, kernel.work_group_size())
                self._launches["ProjectStep1Rows"] = (kernel, (w, h, -(-d // FIELD_ROWS)), local)
            if not book and w % 4 == 0:  # strips of 4 x 1 x ROWS_PER_ITEM cells, walls included
                kernel = self._program.kernel("ProjectStep2Rows")
                local = fitted_shape(ROWS_LOCAL, self.runtime.device, kernel.work_group_size())
                self._launches["ProjectStep2Rows"] = (kernel, (w // 4, h, -(-d // ROWS_PER_ITEM)), local)
            self._built_for = book
        self._configured_for = self.params

    _diffuse_kernel = "DiffuseFieldsRows"

    @property
    def diffuse_kernel(self) -> str:
        """The kernel of fused_step's diffusion sweeps (variant fixed): DiffuseFieldsRows on every device, faster on
        PoCL too (2 cores, 2026-11-29, a whole step: 48^3 6.2 against 6.7 ms, 64^3 15.3 against 17.7 ms), or
        DiffuseFields; the same fields bit for bit. Settable (tests, the bench); None restores DiffuseFieldsRows."""
        return self._diffuse_kernel

    @diffuse_kernel.setter
    def diffuse_kernel(self, name: str | None) -> None:
        if name not in (None, "DiffuseFields", "DiffuseFieldsRows"):
            raise ValueError(f"diffuse_kernel must be DiffuseFields or DiffuseFieldsRows, got {name!r}")
        self._diffuse_kernel = name or "DiffuseFieldsRows"

    def _grid(self, name: str, *args) -> None:
        """Launch a grid kernel over every cell (a SETS_WALLS kernel also over its wall work-groups, ProjectStep2Rows
        over its strips); ``args`` in the kernel's order (buffers, w, h, d, scalars)."""
        if self.params is not self._configured_for:
            self._configure()
        kernel, shape, group = self._launches[name]
        kernel.over(shape, group, *args)

    def _boundary(self, name: str, field, *args) -> None:
        """SetBoundary<name> on ``field`` (``args`` follow it: P's stride): one launch, one work-item per wall cell
        (faces, edges and corners)."""
        self.program.kernel(f"SetBoundary{name}")(self._boundary_size, None, field, *args, *self.dims)

    def _place_p(self) -> None:
        """Put p and the divergence where this variant's ProjectStep2/3 read them: the float fields (fixed) or prev.xy
        (book). A no-op inside step(); otherwise (prev set on the host or restored, the variant switched mid-solve)
        a copy through the host."""
        self._float4_prev()
        fixed = self.params.variant == "fixed"
        if fixed == self.solving:
            return
        prev = self.prev.read.get()
        if fixed:
            self.pressure.read.set(np.ascontiguousarray(prev[..., 0]))
            self.divergence.set(np.ascontiguousarray(prev[..., 1]))
        else:
            prev[..., 0] = self.pressure.read.get()
            self.prev.read.set(prev)
        self.solving = fixed

    def _split_fields(self) -> tuple:
        """The float fields prev is split into while prev_split: x, y, z, w."""
        return self.pressure.read, self.divergence, self.prev_z, self.prev_density

    def _prev_array(self) -> np.ndarray:
        """prev (D, H, W, 4) as the book's would be, read back from where it lives now."""
        if self.prev_split:
            return np.stack([field.get() for field in self._split_fields()], -1)
        prev = self.prev.read.get()
        if self.solving:  # mid-projection (fixed): p in x
            prev[..., 0] = self.pressure.read.get()
        return prev

    def _float4_prev(self):
        """prev where the book's kernels read it, the float4 field: joined from the float fields fused_step leaves
        it in (a copy through the host; only where a step() meets the book's kernels one by one). Returns it."""
        if self.prev_split:
            self.prev.read.set(self._prev_array())
            self.prev_split = self.solving = False
        return self.prev.read

    def _split_prev(self) -> None:
        """prev where fused_step reads it, split into float fields (a copy through the host, as _float4_prev)."""
        if not self.prev_split:
            prev = self._prev_array()
            for k, field in enumerate(self._split_fields()):
                field.set(np.ascontiguousarray(prev[..., k]))
            self.prev_split, self.solving = True, False

    # {{{ boundaries on their own (step() has the kernels apply them, as the book's in-kernel SetBoundary* calls)

    def set_boundary_density(self) -> None:
        self._boundary("Density", self.density.read)

    def set_boundary_velocity(self) -> None:
        self._boundary("Velocity", self.velocity.read)

    def set_boundary_div(self) -> None:
        """SetBoundaryDiv on prev.y, and on the divergence field the sweeps read while a fixed projection runs."""
        self._boundary("Div", self._float4_prev(), np.int32(4))
        if self.solving:
            self._boundary("Div", self.divergence, np.int32(1))

    def set_boundary_p(self) -> None:
        """SetBoundaryP on p: prev.x, or the pressure field while a fixed projection runs (see solving)."""
        self._float4_prev()
        p, stride = (self.pressure.read, 1) if self.solving else (self.prev.read, 4)
        self._boundary("P", p, np.int32(stride))

    # }}}

    # {{{ kernels, in the book's order

    def add_source_brush3d(self) -> None:
        """AddSourceBrush3D: the spherical emitter into ``source``."""
        p = self.params
        center = cltypes.make_float4(*p.emitter_center, 0.0)
        direction = cltypes.make_float4(*p.emitter_direction, 0.0)
        self._grid("AddSourceBrush3D", self.source, *self.dims, center, direction, np.float32(p.source_radius))
        self._brush_of = self._emitter()

    def _emitter(self) -> tuple:
        """What AddSourceBrush3D's source follows from (the grid is fixed for a Simulation's buffers)."""
        p = self.params
        return p.emitter_center, p.emitter_direction, p.source_radius

    def add_source_velocity(self, dt: float) -> None:
        """AddSourceVelocity: velocity += source.xyz*velocity_coef*dt; prev.xyz = the same."""
        coef = np.float32(self.params.velocity_coef)
        self._grid(
            "AddSourceVelocity", self.velocity.read, self._float4_prev(), self.source, *self.dims, coef, np.float32(dt)
        )
        self.solving = False  # prev.x overwritten, as the book's p

    def diffuse_velocity(self, dt: float, sweeps: int | None = None) -> None:
        """DiffuseVelocity: ``sweeps`` (default gs_iterations) Jacobi sweeps, each setting the walls
        (SetBoundaryVelocity's rule, applied by the kernel)."""
        velocity, prev, dims = self.velocity, self._float4_prev(), self.dims
        dt32, visc = np.float32(dt), np.float32(self.params.visc)
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid("DiffuseVelocity", velocity.read, prev, velocity.write, *dims, dt32, visc)
            velocity.swap()

    def project_step1(self, write_prev: bool = True) -> None:
        """ProjectStep1: prev = (0, div, prev.z, prev.w), the walls' div copied from inside (SetBoundaryDiv's rule;
        p = 0 everywhere, so SetBoundaryP's changes nothing). fixed: also divergence = div, pressure = 0, and with
        ``write_prev`` False prev is left alone (the step's first projection: SwapVelocity overwrites prev.xyz)."""
        prev = self._float4_prev()
        if self.params.variant == "book":
            self._grid("ProjectStep1", self.velocity.read, prev, *self.dims)
            self.solving = False
        else:
            fields = self.velocity.read, prev, self.divergence, self.pressure.read
            self._grid("ProjectStep1", *fields, *self.dims, np.int32(write_prev), np.int32(0))
            self.solving = True

    def project_step2(self, sweeps: int | None = None) -> None:
        """ProjectStep2: ``sweeps`` (default gs_iterations) Jacobi sweeps for p, each setting the walls
        (SetBoundaryP's rule, applied by the kernel). fixed: on the divergence and pressure fields ProjectStep1 (or
        set_fields/restore) filled, not on prev."""
        self._place_p()
        book, dims = self.params.variant == "book", self.dims
        p, extra = (self.prev, ()) if book else (self.pressure, (self.divergence,))
        kernel = self.sweep_kernel  # ProjectStep2, or its strips on GPUs: the same arguments
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid(kernel, p.read, p.write, *extra, *dims)
            p.swap()

    def project_step3(self, write_prev: bool = True) -> None:
        """ProjectStep3: velocity -= grad p (in place, as the book); SetBoundaryVelocity. fixed: p from the pressure
        field, copied into prev.x unless ``write_prev`` is False."""
        self._place_p()
        if self.params.variant == "book":
            self._grid("ProjectStep3", self.velocity.read, self.prev.read, *self.dims)
        else:
            fields = self.velocity.read, self.prev.read, self.pressure.read
            self._grid("ProjectStep3", *fields, *self.dims, np.int32(write_prev))
        self.solving = False
        self.set_boundary_velocity()

    def project(self, sweeps: int | None = None, write_prev: bool = True) -> None:
        """The book's mass conservation: ProjectStep1, ProjectStep2 (x sweeps), ProjectStep3. ``write_prev`` False
        (fixed only; the book's sweeps solve in prev): prev keeps its values, for a caller that overwrites prev.xyz
        next, as the step's SwapVelocity does (its p and div there are never read)."""
        self.project_step1(write_prev)
        self.project_step2(sweeps)
        self.project_step3(write_prev)

    def swap_velocity(self) -> None:
        """SwapVelocity: prev.xyz = velocity."""
        self._grid("SwapVelocity", self.velocity.read, self._float4_prev(), *self.dims)
        self.solving = False  # prev.x overwritten, as the book's p

    def advect_velocity(self, dt: float) -> None:
        """AdvectVelocity: velocity = prev.xyz at the back-traced point, walls set (SetBoundaryVelocity's rule)."""
        self._grid("AdvectVelocity", self._float4_prev(), self.velocity.read, *self.dims, np.float32(dt))

    def add_source_density(self, dt: float) -> None:
        """AddSourceDensity: density += source.w*density_coef*dt; prev.w = the same."""
        coef = np.float32(self.params.density_coef)
        prev = self._float4_prev()
        self._grid("AddSourceDensity", self.density.read, prev, self.source, *self.dims, coef, np.float32(dt))

    def diffuse_density(self, dt: float, sweeps: int | None = None) -> None:
        """DiffuseDensity: ``sweeps`` (default gs_iterations) Jacobi sweeps, each setting the walls
        (SetBoundaryDensity's rule, applied by the kernel)."""
        density, prev, dims = self.density, self._float4_prev(), self.dims
        dt32, diff = np.float32(dt), np.float32(self.params.diff)
        for _ in range(self.params.gs_iterations if sweeps is None else sweeps):
            self._grid("DiffuseDensity", density.read, prev, density.write, *dims, dt32, diff)
            density.swap()

    def swap_density(self) -> None:
        """SwapDensity: prev.w = density."""
        self._grid("SwapDensity", self.density.read, self._float4_prev(), *self.dims)

    def advect_density(self, dt: float) -> None:
        """AdvectDensity: density = prev.w at the point back-traced by the velocity, walls set (SetBoundaryDensity's
        rule)."""
        prev = self._float4_prev()
        self._grid("AdvectDensity", self.velocity.read, prev, self.density.read, *self.dims, np.float32(dt))

    def advect_density_from_ext(self, dt: float, source: bool = True) -> None:
        """AdvectDensityFromExt: as AdvectDensity, back-traced by source.xyz. With the source off the original binds
        no source texture, whose reads are 0: the density stays put (as the 2D scene)."""
        field = self.source if source else self.no_source
        prev = self._float4_prev()
        self._grid("AdvectDensityFromExt", field, prev, self.density.read, *self.dims, np.float32(dt))

    def draw(self) -> None:
        """Draw: solver = (u, v, w, density). step() leaves it to the first read of solver (solver_stale)."""
        self._grid("Draw", self.velocity.read, self.density.read, self.solver, *self.dims)
        self.solver_stale = False

    def draw_volume(self, field: str = "density") -> tuple[np.ndarray, float, float]:
        """DrawVolume (not in the book; the view's): the shown ``field`` ("density" or "speed", the length of the
        velocity) as a (D, H, W) float16 array, then the largest density and speed over the grid, the values Draw
        writes into solver. 2 bytes a cell and 8 cross to the host instead of solver's 16 a cell, into page-locked
        copies (Runtime.read_back): the array is overwritten by the next call."""
        self._draw_volume_kernel(field)
        return self.runtime.read_back(self.volume), *self._maxima()

    def _draw_volume_kernel(self, field: str) -> None:
        """DrawVolume into volume and maxima (filled with INT_MIN first: the kernel's atomic_max starts there)."""
        rt = self.runtime
        cl.enqueue_fill_buffer(rt.queue, self.maxima.base_data, np.int32(np.iinfo(np.int32).min), 0, self.maxima.nbytes)
        which = np.int32(("density", "speed").index(field))
        self._grid("DrawVolume", self.velocity.read, self.density.read, self.volume, self.maxima, which, *self.dims)

    def _maxima(self) -> tuple[float, float]:
        """The largest density and speed DrawVolume found (8 bytes read back)."""
        max_density, max_speed = ordered_floats(self.runtime.read_back(self.maxima))
        return float(max_density), float(max_speed)

    def ray_march(
        self, inv_view_proj, eye, size: tuple[int, int], field: str = "density", absorption: float | None = None,
        light_dir=(0.0, 1.0, 0.0),
    ) -> tuple[np.ndarray, float, float]:  # fmt: skip
        """RayMarchSmoke (not in the book; the view's smoke): the shown ``field`` ("density" or "speed") ray-marched
        as viewer/shaders/stable_fluids_3d.frag's smoke display does, into a ``size`` = (W, H) picture: (H, W, 4)
        uint8, premultiplied RGBA, row 0 the bottom row (GL's order); then the largest density and speed, as
        draw_volume (DrawVolume runs first: the speed display is scaled by its max). The camera: ``inv_view_proj``
        (4x4, clip -> scene coordinates, where the box is centred on the origin, its largest edge 1) and its ``eye``.
        ``absorption``: extinction per unit value per box length (None: the absorption parameter); ``light_dir``:
        towards the light (unit length). Only the picture (3.7 MB at 1280x720) and 8 bytes cross to the host, into
        page-locked copies (Runtime.read_back): the picture is overwritten by the next call."""
        width, height = size
        if self.smoke_image is None or self.smoke_image.shape != (height, width, 4):
            self.smoke_image = self.runtime.zeros((height, width, 4), np.uint8)
        self._draw_volume_kernel(field)
        matrix = np.asarray(inv_view_proj, np.float64).reshape(16)  # row-major: the kernel's rows
        absorption = self.params.absorption if absorption is None else absorption
        # 8 x 8 pixels a work-group: a GPU warp marches a 8 x 4 tile, whose rays read neighbouring cells
        self.program.kernel("RayMarchSmoke").over(
            (width, height), (8, 8), self.velocity.read, self.density.read, self.maxima, self.smoke_image,
            np.int32(("density", "speed").index(field)), width, height, tuple(matrix), (*eye, 0.0), (*light_dir, 0.0),
            float(absorption), *self.dims,
        )  # fmt: skip
        return self.runtime.read_back(self.smoke_image), *self._maxima()

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
        self.project(write_prev=False)  # SwapVelocity overwrites the p and div it would leave in prev
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

    def fused_step(self, dt: float, source: bool) -> None:
        """The fixed variant's step(): velocity_step and density_step in 12 launches instead of 20 (gs_iterations 2,
        source on), each moving fewer bytes, on prev split into float fields (_split_prev); the fields bit for bit
        those of the book's kernels one by one (stable_fluids_3d.cl's header says which kernel does which)."""
        p, dims, dt32 = self.params, self.dims, np.float32(dt)
        self._split_prev()
        velocity = not p.density_only
        coefs = (np.float32(p.visc), np.float32(p.diff), np.float32(p.velocity_coef), np.float32(p.density_coef))
        diffuse = self.diffuse_kernel
        for sweep in range(p.gs_iterations):  # the first with the source on also adds it (AddSource*)
            self._grid(diffuse, self.velocity.read, self.velocity.write, self.density.read,
                       self.density.write, self.source, *self._split_fields(), *dims, dt32, *coefs,
                       np.int32(velocity), np.int32(source), np.int32(source and sweep == 0))  # fmt: skip
            if velocity:
                self.velocity.swap()
            self.density.swap()
        if velocity:
            self._fused_project()
            self._grid("SwapAdvectVelocity", self.velocity.read, self.velocity.write, self.prev_z, *dims, dt32)
            self.velocity.swap()
            self._fused_project()
        carrier = self.velocity.read if velocity else self.source if source else self.no_source
        self._grid("SwapAdvectDensity", carrier, self.density.read, self.density.write, *dims, dt32)
        copy = self.density.read  # what SwapDensity copies into prev.w: kept as prev_density
        self.density.read, self.density.write, self.prev_density = self.density.write, self.prev_density, copy

    def _fused_project(self) -> None:
        """project() as fused_step runs it: ProjectStep1 also does the first sweep, and prev is left alone (its x and
        y are the pressure and divergence fields themselves): ProjectStep1Rows, its strips."""
        dims = self.dims
        self._grid("ProjectStep1Rows", self.velocity.read, self.divergence, self.pressure.read, *dims)
        kernel = self.sweep_kernel
        for _ in range(self.params.gs_iterations - 1):
            self._grid(kernel, self.pressure.read, self.pressure.write, self.divergence, *dims)
            self.pressure.swap()
        self._grid("ProjectStep3", self.velocity.read, self.prev.read, self.pressure.read, *dims, np.int32(0))
        self.set_boundary_velocity()

    def _step(self, dt: float) -> None:
        source = self.source_active()
        if source and not self.external_source and self._brush_of != self._emitter():
            self.add_source_brush3d()  # the same emitter writes the same source: only when it changed
        if self.params.variant == "fixed":
            self.fused_step(dt, source)
        else:
            if not self.params.density_only:
                self.velocity_step(dt, source)
            self.density_step(dt, source)
        self.solver_stale = True  # Draw, once solver is read: nothing in a step reads it

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
        self._brush_of = None  # the emitter's source is gone
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
            self.solving = self.prev_split = False  # p = prev.x (a projection goes on from it: _place_p)

    def solver_field(self) -> np.ndarray:
        """The Draw output (D, H, W, 4) = (u, v, w, density), drawn first if a step left it stale (the view reads
        the same values through draw_volume)."""
        if self.solver_stale:
            self.draw()
        return self.solver.get()

    def state(self) -> dict[str, np.ndarray]:
        if self.solver_stale:
            self.draw()
        velocity = self.velocity.read.get()[..., :3]
        prev = self._prev_array()
        return {
            "velocity": np.ascontiguousarray(velocity),
            "density": self.density.read.get(),
            "solver": self.solver.get(),
            "prev": prev,
            "source": self.source.get(),
            "divergence": central_divergence(velocity),
            "kinetic_energy": np.float32(0.5 * np.mean(np.sum(velocity.astype(np.float64) ** 2, axis=-1))),
        }

    def restore(self, state: dict[str, np.ndarray]) -> None:
        velocity = np.concatenate([state["velocity"], np.zeros((*self.shape, 1), np.float32)], -1)  # (u, v, w, 0)
        put(self.velocity.read, velocity, "velocity")
        put(self.density.read, state["density"], "density")
        put(self.prev.read, state["prev"], "prev")
        self.solving = self.prev_split = False  # state() put p into prev.x
        put(self.solver, state["solver"], "solver")
        self.solver_stale = False
        put(self.source, state["source"], "source")
        self._brush_of = None  # whatever source the run had

    def stats(self) -> dict:
        state = self.state()
        speed = np.linalg.norm(state["velocity"], axis=-1)
        return {
            **super().stats(),
            "grid": "x".join(str(n) for n in (self.params.width, self.params.height, self.params.depth)),
            "variant": self.params.variant,
            "local size": self.local_size,
            "sweep kernel": self.sweep_kernel,
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


SCENE_DEFAULTS = {"velocity_coef": 10.0, "density_coef": 6.0, "source_radius": 0.12}
"""The 3D scene's emitter (Solver3D had no scene of its own to copy; the solver, diff 10 and visc 20 of the 2D
sample scene, stays the book's): it blows 5x harder than the 2D sample's velocityCoef (with 2 its smoke creeps up at
~0.3 cells per frame under the book's blur), and it is 1.5x wider than the class's 0.08 with 3x the ink, so that a
short run shows a puff of smoke rather than a faint speck (10 frames: a ball about a quarter of the box across)."""

SCENES = [
    Scene(
        STEM,
        Simulation,
        "Stable fluids in 3D: smoke from an emitter, ray-marched (vol.1 ch.4, the unused Solver3D)",
        SCENE_DEFAULTS,
        view="View",
        # thin smoke blown fast and a little sideways: a plume that leans and curls (the scene's diff 10 / visc 20
        # smear it into a ball)
        preview={
            "steps": 120,
            "density_coef": 2.0,
            "source_radius": 0.08,
            "diff": 0.1,
            "visc": 0.1,
            "velocity_coef": 30.0,
            "emitter_direction": (0.4, 1.0, 0.0),
        },
        interactive={"width": 40, "height": 40, "depth": 40},
        at_scale=AtScale(
            gpu={"width": 256, "height": 256, "depth": 256},
            cpu={"width": 48, "height": 48, "depth": 48},
            loop=Animation("smoke rising in a 256^3 grid while the camera swings", every=5, start=20, swing=25.0),
        ),
        preview_check=PreviewCheck(
            min_subject=0.012,
            sparse="smoke from one emitter in a wire box: after ten frames a puff of about 1 % of the frame inside the "
            "box's outline (0.6-0.7 % on its own), the preview's plume 5-6 %",
        ),
        animation=Animation(
            "the plume rising from the emitter while the camera swings (the volume reads better turning)",
            every=5,
            start=20,
            swing=25.0,
        ),
    )
]
