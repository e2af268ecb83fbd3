"""GPU marching cubes "starting with atmosphere": an animated implicit surface polygonised every frame
(vol.1 ch.7; docs/chapters/07-marching-cubes.md).

Three pulsing metaball spheres stacked on the Y axis (or the twisting "kaiware" radish sprout of Fig 7.6) are a
scalar field on an N^3 grid; every cell classifies its 8 corners against the threshold and emits 0..5 triangles
from the marching-cubes tables (``ugpcl.geometry.marching_cubes_tables``: Bourke's numbering, rows derived there).

Kernel order per frame (``step`` advances the field's time first when ``animate``):
``SampleField`` (the book's Sample at every grid point), then either ``PolygonizeAppend`` (``path=append``: each
cell appends its triangles to a ``Pool`` with ``atomic_inc``; an overflow is counted, the pool grows and the kernel
runs again) or ``ClassifyCells`` -> ``ScanBlocks``/``AddBlockOffsets`` -> ``GenerateTriangles`` (``path=scan``:
triangles written in cell order). ``state()`` sorts the append path's triangles by cell (stable), so both paths
write the same arrays. The viewer draws these triangles as a mesh (``draw_vertices``: ``PackVertices``, then one read
of the frame's triangles); its geometry-shader path (viewer/views/marching_cubes.py) is the book's own.

What differs from the book: the GS evaluates the field 8 times per cell, twice per frame (lit and shadow pass);
here it is evaluated once per grid point. The book's 65535-point meshes wrap around and process z-layers twice
(5 x 65535 > 64^3); every cell runs exactly once here. Edge vertices are interpolated from the edge's lower
corner, so cells sharing an edge agree to the bit and the exported mesh welds exactly. Sphere radii and the
kaiware twist depend on t only and are computed once per frame on the host. Ambiguous faces are resolved the same
way in every cell (see the tables module), so meshes are closed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from ..buffers import Pool
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..resources import Allocation
from ..scene import Animation, AtScale, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

TRIANGLE_DTYPE = np.dtype([("position", "<f4", (3, 3)), ("normal", "<f4", (3, 3)), ("cell", "<u4")])
"""Mirror of ``McTriangle`` in clkernels/include/marching_cubes.h (76 bytes)."""
SHAPES = {"spheres-book": 0, "spheres-repo": 0, "kaiware": 1}
"""Shape name -> SHAPE_* of marching_cubes.cl (both sphere sets are SHAPE_SPHERES with different radii)."""
NORMALS = {"analytic": 0, "grid": 1}
"""Normal mode -> NORMALS_* of marching_cubes.cl."""
SCAN_BLOCK_SIZE = 256
"""Work-group size of ScanBlocks (values scanned per group in __local memory)."""
FIELD_GROUP = 64
"""Work-group width of SampleField (x rows rounded up to it): 4 AVX-512 vectors for PoCL, 2 warps on a GPU."""
CPU_LANES = 8
"""Cells (or grid points) of a row per work-item of the *_cpu kernels (CPU_LANES in marching_cubes.cl)."""
PULSE_RATE = 8.0
"""Angular frequency of the spheres' pulsing, rad/s (book: sin(_Time.y * 8.0 + i * 23.365)): period 2 pi / 8 s."""
PULSE_PHASE = 23.365
"""Phase step between the three spheres, rad (book: i * 23.365)."""
RADII = {"spheres-book": (0.1, 0.025), "spheres-repo": (0.005, 0.125)}
"""(base, amplitude) of the sphere radius base + (0.5 sin(8 t + 23.365 i) + 0.5) * amplitude, in units of the box:
the book's Listing 7.11 and the repository's GPUMarchingCubesRenderStandardMesh.shader."""
KAIWARE_TWIST = 10.0
"""The kaiware twists by 10 * sin(t / 2) radians per unit of height (repository: twistY(p, 10 * _SinTime.z))."""
CAPACITY_PER_FACE_CELL = 4
"""First pool size: this many triangles per cell of one box face (4 N^2); grown on overflow."""
GROWTH = 1.25
"""An overflowing pool is reallocated to GROWTH x the triangles the frame needed (docs/chapters/07-marching-cubes.md,
"Kernels"); the draw's vertex buffers grow the same way."""
VERTEX_FLOATS = 6
"""Floats per vertex of ``draw_vertices`` (PackVertices): position (x, y, z), then normal (x, y, z)."""


@dataclass(frozen=True)
class Params(BaseParams):
    segment_num: int = param(32, 4, 512)
    """Cells per axis N; the object cube [-0.5, 0.5]^3 has N^3 cells of size 1/N (book: segmentNum)."""
    threshold: float = param(0.5, 0.0, 1.0, live=True)
    """Iso value: a corner is outside (its case bit set) when its value <= threshold (book: threshold, _Threashold)."""
    time: float = param(0.0, 0.0, 1e6)
    """Field time at reset, seconds (Unity: _Time.y); each step adds dt while ``animate`` is on.
    Up to 1e6 s: float32 time still resolves 1/16 s."""
    animate: bool = param(True, live=True)
    """Advance the field's time by dt every step (off: every frame polygonises the same field)."""
    shape: str = param("spheres-book", choices=tuple(SHAPES), live=True)
    """The field: three metaballs with the book listing's radii (0.1 + 0.025 pulse) or the repository's (0.005 +
    0.125 pulse), or the twisting kaiware sprout of Fig 7.6."""
    normals: str = param("analytic", choices=tuple(NORMALS), live=True)
    """Vertex normals: the book's resampling of the analytic field at +-1 cell, or the same differences on the grid
    (trilinear), which needs only the field buffer."""
    path: str = param("append", choices=("append", "scan"), live=True)
    """OpenCL path: atomic append to a Pool (order varies, sorted by cell in the state) or classify + scan + generate
    (cell order by construction)."""
    triangle_capacity: int = param(0, 0, 1 << 26)
    """Pool size in triangles at reset; 0 = 4 N^2. The pool grows to 1.25 x the need when a frame overflows it."""
    diffuse_color: tuple[float, float, float] = param((0.0, 1.0, 0.0), 0.0, 1.0, live=True)
    """Albedo, render only (book: DiffuseColor; class default green, Sample.unity (0.3001, 0.5956, 0.2759))."""
    metallic: float = param(0.0, 0.0, 1.0, live=True)
    """Metallic, render only: tints the highlight with the albedo (book: metallic / _Metallic)."""
    glossiness: float = param(0.5, 0.0, 1.0, live=True)
    """Smoothness, render only (book: glossiness / _Glossiness)."""
    emission_color: tuple[float, float, float] = param((0.0, 0.0, 0.0), 0.0, 1.0, live=True)
    """Emission colour, render only (book: EmissionColor)."""
    emission_intensity: float = param(0.0, 0.0, 1e3, live=True)
    """Emission multiplier, render only (book: EmissionIntensity). Up to 1e3."""


def field_constants(shape: str, t: float) -> tuple[tuple[float, float, float], float]:
    """(three sphere radii, kaiware twist) at time t, float64: the only places t enters the field."""
    base, amplitude = RADII.get(shape, RADII["spheres-book"])
    radii = tuple(base + (0.5 * math.sin(PULSE_RATE * t + i * PULSE_PHASE) + 0.5) * amplitude for i in range(3))
    return radii, KAIWARE_TWIST * math.sin(t / 2.0)


class Simulation(BaseSimulation):
    """One polygonised frame per step: SampleField, then the append or the two-pass path."""

    Params = Params
    history = ()

    @classmethod
    def allocations(cls, params: Params) -> list[Allocation]:
        n = params.segment_num
        capacity = params.triangle_capacity or CAPACITY_PER_FACE_CELL * n**2
        return [
            Allocation("field", (n + 1) ** 3 * 4, "segment_num"),
            Allocation("triangle pool", capacity * TRIANGLE_DTYPE.itemsize, "triangle_capacity"),
        ]

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        self.n = p.segment_num
        self.cells = self.n**3
        # CPU devices run the *_cpu kernels (eight cells of a row per work-item in vector lanes: PoCL's vector
        # exp/log and one test per eight empty cells); Oclgrind and GPUs the one-cell kernels. Tests may set either.
        self.cpu_kernels = bool(rt.device.type & cl.device_type.CPU) and not rt.is_oclgrind
        self.field = rt.zeros((self.n + 1) ** 3, np.float32)
        self.pool = Pool(rt, p.triangle_capacity or CAPACITY_PER_FACE_CELL * self.n**2, TRIANGLE_DTYPE, "triangles")
        self.cell_ntri = None  # the two-pass buffers, made on first use
        self.draw_device = None  # draw_vertices' packed triangles, made on first use (a view's, sized to it)
        self.scan_levels: dict[int, tuple] = {}
        self.field_time = p.time
        self.overflowed = False  # whether the last frame needed a bigger pool
        self.overflows = 0
        self.frame_times: list[float] = []
        self.frame_counts: list[int] = []
        self.remesh()

    @property
    def program(self):
        """marching_cubes.cl built for the current shape (a live field: the runtime caches one program per shape)."""
        return self.runtime.program("marching_cubes", SCAN_BLOCK_SIZE=SCAN_BLOCK_SIZE, SHAPE=SHAPES[self.params.shape])

    def _field_args(self) -> tuple:
        p = self.params
        radii, twist = field_constants(p.shape, self.field_time)
        return (np.int32(self.n), cltypes.make_float4(*radii, 0.0), np.float32(twist))

    def _cell_args(self) -> tuple:
        """The leading arguments of both triangle writers (PolygonizeAppend, GenerateTriangles)."""
        p = self.params
        return (self.field.data, np.float32(p.threshold), np.int32(NORMALS[p.normals]), *self._field_args())

    # {{{ kernels, in the book's order

    def _runs(self, points: int) -> tuple[tuple, tuple | None]:
        """(global, local) size of a *_cpu kernel over the points^3 cells (N) or grid points (N + 1): one work-item
        per CPU_LANES of a row."""
        return (-(-points // CPU_LANES), points, points), None

    def sample_field(self) -> None:
        """SampleField: the book's Sample at all (N+1)^3 grid points at the current field time."""
        side = self.n + 1
        if self.cpu_kernels:
            self.program.kernel("SampleField_cpu")(*self._runs(side), self.field.data, *self._field_args())
            return
        self.program.kernel("SampleField").over(
            (side, side, side), (FIELD_GROUP, 1, 1), self.field.data, *self._field_args()
        )

    def polygonize_append(self, pool: Pool | None = None, capacity: int | None = None) -> None:
        """PolygonizeAppend: every cell appends its triangles to ``pool`` (default: the scene's, emptied first).
        ``capacity`` below the pool's size leaves the slots after it untouched (the overflow test's canary)."""
        pool = pool or self.pool
        pool.set_count(0)
        self.program.kernel("PolygonizeAppend_cpu" if self.cpu_kernels else "PolygonizeAppend")(
            *(self._runs(self.n) if self.cpu_kernels else ((self.cells,), None)),
            *self._cell_args(),
            pool.items.data,
            pool.counter.data,
            np.int32(pool.capacity if capacity is None else capacity),
        )

    def classify_cells(self) -> None:
        """ClassifyCells: triangles per cell into ``cell_ntri``."""
        if self.cell_ntri is None:
            self.cell_ntri = self.runtime.zeros(self.cells, np.uint32)
            self.cell_off = self.runtime.zeros(self.cells, np.uint32)
        self.program.kernel("ClassifyCells_cpu" if self.cpu_kernels else "ClassifyCells")(
            *(self._runs(self.n) if self.cpu_kernels else ((self.cells,), None)),
            self.field.data,
            np.float32(self.params.threshold),
            np.int32(self.n),
            self.cell_ntri.data,
        )

    def scan(self, values, out, n: int) -> int:
        """ScanBlocks + AddBlockOffsets: exclusive prefix sum of n uint32 ``values`` into ``out``; returns the total.
        Each level scans SCAN_BLOCK_SIZE values per work-group; the block totals are scanned the same way."""
        groups = -(-n // SCAN_BLOCK_SIZE)
        if n not in self.scan_levels:  # block sums and their scan, kept per level
            self.scan_levels[n] = (self.runtime.empty(groups, np.uint32), self.runtime.empty(groups, np.uint32))
        sums, offsets = self.scan_levels[n]
        self.program.kernel("ScanBlocks").over(n, SCAN_BLOCK_SIZE, values.data, out.data, sums.data, np.int32(n))
        if groups == 1:
            return int(sums.get()[0])
        total = self.scan(sums, offsets, groups)
        self.program.kernel("AddBlockOffsets").over(n, SCAN_BLOCK_SIZE, out.data, offsets.data, np.int32(n))
        return total

    def generate_triangles(self) -> None:
        """GenerateTriangles: every cell writes its triangles at cell_off[cell] (needs ClassifyCells and scan)."""
        self.program.kernel("GenerateTriangles_cpu" if self.cpu_kernels else "GenerateTriangles")(
            *(self._runs(self.n) if self.cpu_kernels else ((self.cells,), None)),
            *self._cell_args(),
            self.cell_ntri.data,
            self.cell_off.data,
            self.pool.items.data,
            np.int32(self.pool.capacity),
        )

    # }}}

    def _grow(self, needed: int) -> None:
        self.pool = Pool(self.runtime, max(1, math.ceil(needed * GROWTH)), TRIANGLE_DTYPE, "triangles")
        self.overflowed = True
        self.overflows += 1

    def polygonize(self) -> None:
        """The chosen OpenCL path on the current field; grows the pool when the frame does not fit."""
        self.overflowed = False
        if self.params.path == "append":
            self.polygonize_append()
            count, refused = self.pool.counts()
            if refused:  # the counter clamped at capacity: count + refused triangles were wanted
                self._grow(count + refused)
                self.polygonize_append()
                count, refused = self.pool.counts()
                assert refused == 0
        else:
            self.classify_cells()
            count = self.scan(self.cell_ntri, self.cell_off, self.cells)
            if count > self.pool.capacity:
                self._grow(count)
            self.generate_triangles()
            self.pool.set_count(count)
        self.frame_times.append(self.field_time)
        self.frame_counts.append(count)

    def remesh(self) -> None:
        """Field and mesh at the current field time (after a parameter change, without advancing time)."""
        self.sample_field()
        self.polygonize()

    def _step(self, dt: float) -> None:
        if self.params.animate:
            self.field_time += dt
        self.remesh()

    # {{{ results

    def triangles(self) -> np.ndarray:
        """The frame's triangles (T,) of TRIANGLE_DTYPE sorted by cell; a cell's own triangles keep table order."""
        items = self.pool.read()
        return items[np.argsort(items["cell"], kind="stable")]

    def draw_vertices(self) -> np.ndarray:
        """The frame's triangles as the viewer's mesh draw reads them: (3 T, VERTEX_FLOATS) float32, each corner's
        position and normal, in pool order (PackVertices). Only the frame's T triangles cross to the host, 72 bytes
        each, into page-locked memory (``Runtime.read_back``): the next call overwrites the result."""
        count = self.frame_counts[-1]  # polygonize read the pool's counter: no second device read
        if self.draw_device is None or len(self.draw_device) < 3 * count:  # grows as the pool does, never past it
            triangles = min(self.pool.capacity, math.ceil(count * GROWTH))
            self.draw_device = self.runtime.empty((3 * triangles, VERTEX_FLOATS), np.float32)
        if count:
            pack = self.program.kernel("PackVertices")
            pack.over(count, FIELD_GROUP, self.pool.items.data, np.int32(count), self.draw_device)
        return self.runtime.read_back(self.draw_device, 3 * count)

    def field_array(self) -> np.ndarray:
        """The sampled field as (N+1, N+1, N+1) float32 indexed [z, y, x]."""
        return self.field.get().reshape((self.n + 1,) * 3)

    def mesh(self, tri: np.ndarray | None = None) -> Mesh:
        """The welded surface in object space, with the field-gradient normals: cells that share an edge compute
        the same float vertex, so equal positions are one vertex (an exact weld, no tolerance)."""
        tri = self.triangles() if tri is None else tri
        corners = tri["position"].reshape(-1, 3)
        vertices, first, inverse = np.unique(corners, axis=0, return_index=True, return_inverse=True)
        normals = tri["normal"].reshape(-1, 3)[first]
        return Mesh(vertices, inverse.reshape(-1, 3), normals)

    def export_mesh(self, path) -> None:
        """--mesh: ``mesh()`` as .obj, .ply or .glb."""
        write_mesh(path, self.mesh())

    def state(self) -> dict[str, np.ndarray]:
        tri = self.triangles()
        mesh = self.mesh(tri)
        return {
            "field": self.field_array(),
            "tri_pos": np.ascontiguousarray(tri["position"]),
            "tri_nrm": np.ascontiguousarray(tri["normal"]),
            "tri_cell": np.ascontiguousarray(tri["cell"]),
            "tri_count": np.int64(len(tri)),
            "counter_overflowed": np.bool_(self.overflowed),
            "tri_count_t": np.asarray(self.frame_counts, np.int64),
            "frame_time": np.asarray(self.frame_times, np.float64),
            "vertices": mesh.vertices,
            "normals": mesh.normals,
            "faces": mesh.faces,
        }

    def stats(self) -> dict:
        return {
            **super().stats(),
            "N": self.n,
            "field time": round(self.field_time, 6),
            "triangles": self.pool.count(),
            "pool capacity": self.pool.capacity,
            "pool overflows": self.overflows,
            "path": self.params.path,
            "kernels": ", ".join(self.frame_kernels()),
        }

    def frame_kernels(self) -> tuple[str, ...]:
        """The kernels a frame runs on this device, in order: the path's, as their *_cpu twins on CPU devices."""
        cpu = "_cpu" if self.cpu_kernels else ""
        if self.params.path == "append":
            return f"SampleField{cpu}", f"PolygonizeAppend{cpu}"
        return f"SampleField{cpu}", f"ClassifyCells{cpu}", "ScanBlocks", "AddBlockOffsets", f"GenerateTriangles{cpu}"

    # }}}


SCENES = [
    Scene(
        "marching_cubes",
        Simulation,
        "GPU marching cubes: three pulsing metaballs polygonised every frame (vol.1 ch.7)",
        defaults={"segment_num": 64, "diffuse_color": (0.3001, 0.5956, 0.2759), "metallic": 0.5},
        preview={"steps": 20},
        animation=Animation(
            "the three metaballs pulse through two periods of the book's sin(8 t) (47 steps each), remeshed every step",
            every=2,
            frames=47,
        ),
        preview_check=PreviewCheck(fills_frame="the floor runs to the horizon"),
        at_scale=AtScale(
            gpu={"segment_num": 256},
            cpu={"segment_num": 48},
            loop=Animation("the three metaballs pulsing on a 256^3 grid, remeshed every step", every=2, frames=47),
        ),
    ),
    Scene(
        "marching_cubes_kaiware",
        Simulation,
        "GPU marching cubes: the twisting kaiware sprout built from distance functions (vol.1 ch.7, Fig 7.6)",
        defaults={"segment_num": 64, "shape": "kaiware", "diffuse_color": (0.3001, 0.5956, 0.2759), "metallic": 0.5},
        preview={"steps": 10},
        interactive={"segment_num": 40},
        preview_check=PreviewCheck(fills_frame="the floor runs to the horizon"),
    ),
]
