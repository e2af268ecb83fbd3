"""Geometry shaders: the simple pyramid sample and the grass shader (vol.1 ch.6; docs/chapters/06-grass.md).

The chapter has no compute shader. Its two samples are geometry shaders, ported to GLSL in ``viewer/shaders/``
(``grass_pyramid.*``: every triangle of a Quad becomes a triangular pyramid; ``grass.*``: every triangle of a
field of Planes becomes one 7-vertex grass blade shaped by three noise maps and swayed by the wind). The view draws
with those shaders. For headless runs and tests the geometry stage is re-done in OpenCL (``clkernels/grass.cl``):
``GrassExpand`` / ``PyramidExpand`` write every emitted vertex at a fixed slot, in world space; the book's
vertex stage (three ``tex2Dlod`` lookups per vertex) runs once on the host in ``reset`` (the maps and UVs never
change). ``backend=numpy`` runs the same geometry stage in numpy instead. Each step advances the shader's time by
dt and expands again (one step = one rendered frame of the book).

Differences from the book: the three noise textures are seeded procedural stand-ins with the originals' mean and
std (the PNG/JPG files cannot be shipped); a blade whose mean rotation value is exactly 0.5 points along
-(p2 - p0) instead of ``normalize(0)`` = NaN; positions carry w = 1 (the book's float4 arithmetic leaves garbage
in w that Unity ignores); ``plane_resolution`` (cells per Plane side, Unity's Plane has 10) is ours, for density.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pyopencl.cltypes as cltypes

from ..geometry import grass as geo
from ..geometry.mesh import Mesh
from ..geometry.mesh_io import write_mesh
from ..geometry.transforms import euler_matrix, translation
from ..scene import Animation, PreviewCheck, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

GRASS_PARAMS_DTYPE = np.dtype(
    [
        (name, "<f4")
        for name in (
            "height",
            "width",
            "bottom_height",
            "middle_height",
            "top_height",
            "bottom_width",
            "middle_width",
            "top_width",
            "bottom_bend",
            "middle_bend",
            "top_bend",
            "wind_power",
            "time",
            "wind_time_scale",
            "pad0",
            "pad1",
        )
    ]
    + [("top_color", "<f4", 4), ("bottom_color", "<f4", 4)]
)
"""Mirror of ``GrassParams`` in clkernels/include/grass.h (96 bytes)."""
PARAM_FIELDS = tuple(name for name in GRASS_PARAMS_DTYPE.names if name not in ("time", "pad0", "pad1"))
"""GrassParams fields copied from Params under the same name (also grass.geom's uniforms)."""
MAX_BLADES = 1 << 22
"""Cap on planes x triangles per plane: 4M blades = 28M vertices, ~800 MB of positions and colours."""

QUAD_SCALE = 5.0
"""Both quads of the pyramid scene are 5x5 units (docs/chapters/06-grass.md, "What differs from the book")."""
QUAD_X = 4.5
"""The plain quad sits at x = -4.5, the geometry-shader quad at x = +4.5."""
QUAD_EULER = (90.0, 35.0)
"""Rotation of both quads (Unity Euler x, y): local -Z turned to world +Y, then yawed 35 degrees."""


# {{{ grass


@dataclass(frozen=True)
class Params(BaseParams):
    # Ranges keep every coordinate far below float32 overflow (inf * 0 in a rotated model matrix would be NaN).
    planes: tuple[int, int] = param((10, 10), 1, 50)
    """Planes along x and z, 10 units apart (book: PlaneDeployer width, height; inspector range 1-50)."""
    plane_resolution: int = param(10, 1, 1000)
    """Cells per side of each plane, two blades per cell (Unity's built-in Plane: 10; ours, for density)."""
    height: float = param(25.0, 0.0, 1e4, live=True)
    """Overall blade height scale, object units (book: _Height; shader default 80)."""
    width: float = param(0.5, 0.0, 1e3, live=True)
    """Overall blade width scale, object units (book: _Width; shader default 2.5)."""
    bottom_height: float = param(0.3, 0.0, 100.0, live=True)
    """Height of the bottom section, times map height x height (book: _BottomHeight)."""
    middle_height: float = param(0.4, 0.0, 100.0, live=True)
    """Height of the middle section (book: _MiddleHeight)."""
    top_height: float = param(0.5, 0.0, 100.0, live=True)
    """Height of the top section (book: _TopHeight)."""
    bottom_width: float = param(0.5, 0.0, 100.0, live=True)
    """Half-width at the root, times width (book: _BottomWidth)."""
    middle_width: float = param(0.4, 0.0, 100.0, live=True)
    """Half-width at the first joint (book: _MiddleWidth)."""
    top_width: float = param(0.2, 0.0, 100.0, live=True)
    """Half-width at the second joint and offset of the tip (book: _TopWidth)."""
    bottom_bend: float = param(1.0, -100.0, 100.0, live=True)
    """Wind displacement multiplier of the first joint (book: _BottomBend; shader default 1)."""
    middle_bend: float = param(2.0, -100.0, 100.0, live=True)
    """Wind displacement multiplier of the second joint (book: _MiddleBend; shader default 1)."""
    top_bend: float = param(3.0, -100.0, 100.0, live=True)
    """Wind displacement multiplier of the tip (book: _TopBend; shader default 2)."""
    wind_power: float = param(0.75, -1e3, 1e3, live=True)
    """Wind strength, object units along the plane's +X (book: _WindPower; shader default 1)."""
    top_color: tuple[float, float, float, float] = param((0.0, 1.0, 0.29655, 1.0), 0.0, 1.0, live=True)
    """Tip colour, rgba (book: _TopColor; shader default white)."""
    bottom_color: tuple[float, float, float, float] = param((0.0, 0.20766, 0.33088, 1.0), 0.0, 1.0, live=True)
    """Root colour, rgba (book: _BottomColor; shader default black)."""
    wind_time_scale: float = param(0.05, 0.0, 1e3, live=True)
    """Sway phase per second: the book's sin(_Time) keeps only _Time.x = t/20 (faithful 0.05; 1 sways visibly)."""
    start_time: float = param(0.0, -1e6, 1e6, live=True)
    """Shader time at step 0, seconds (Unity's Time.time); each step adds dt (command line: --set start_time=T)."""
    backend: str = param("opencl", choices=("opencl", "numpy"))
    """Who runs the geometry stage headless: the GrassExpand kernel or the numpy port."""

    @property
    def blades(self) -> int:
        """One blade per triangle of every plane: planes x 2 x resolution^2 (book: 100 x 200 = 20,000)."""
        return self.planes[0] * self.planes[1] * 2 * self.plane_resolution**2

    limits = (f"2*planes[0]*planes[1]*plane_resolution**2 <= {MAX_BLADES} blades",)

    def check(self) -> None:
        if self.blades > MAX_BLADES:
            raise self.broken(self.limits[0], f"{self.blades} blades")

    def block(self, time: float) -> np.ndarray:
        """The GrassParams record the kernel reads, for shader time ``time``."""
        record = np.zeros(1, GRASS_PARAMS_DTYPE)
        for name in PARAM_FIELDS:
            record[name] = getattr(self, name)
        record["time"] = time
        return record


class Simulation(BaseSimulation):
    """A field of planes whose triangles grow one blade each: GrassExpand every step."""

    Params = Params
    history = ("blade_pos",)

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        rng = np.random.default_rng(self.seed)
        self.maps = geo.noise_maps(rng)  # book: _HeightMap, _RotationMap, _WindMap
        self.models = geo.plane_models(*p.planes, rng)  # book: PlaneDeployer
        self.program = rt.program("grass")
        self.set_ground(geo.plane_mesh(p.plane_resolution), self.models)

    def set_ground(self, mesh: dict, models: np.ndarray, maps: dict | None = None) -> None:
        """Grow grass on another mesh (pos, nrm, uv, tri) drawn once per model matrix, optionally with other maps
        (height, rot, wind: (H, W) arrays in [0, 1]; a 1x1 map is a constant). Expands at once."""
        self.ground = {k: np.ascontiguousarray(v) for k, v in mesh.items()}
        self.models = np.ascontiguousarray(models, np.float32).reshape(-1, 4, 4)
        if maps is not None:
            self.maps = {name: np.ascontiguousarray(maps[name], np.float32) for name in ("height", "rot", "wind")}
        # the book's vert(): tex2Dlod of each map at the vertex UV (the view's grass.vert does the same on the GPU)
        self.samples = {name: geo.sample_bilinear(image, self.ground["uv"]) for name, image in self.maps.items()}
        self.blades = len(self.models) * len(self.ground["tri"])
        if self.params.backend == "opencl":
            rt = self.runtime
            self.d_tri = rt.to_device(self.ground["tri"].astype(np.uint32))
            self.d_pos = rt.to_device(self.ground["pos"].astype(np.float32))
            self.d_nrm = rt.to_device(self.ground["nrm"].astype(np.float32))
            self.d_samples = [rt.to_device(self.samples[name]) for name in ("height", "rot", "wind")]
            self.d_models = rt.to_device(self.models)
            self.d_params = rt.to_device(self.params.block(self.shader_time))
            self.blade_pos = rt.empty(self.blades * geo.BLADE_VERTICES * 3, np.float32)
            self.blade_col = rt.empty(self.blades * geo.BLADE_VERTICES * 4, np.float32)
            self.blade_means = [rt.empty(self.blades, np.float32) for _ in range(3)]
        self.grass_expand()

    @property
    def shader_time(self) -> float:
        """Unity's Time.time seen by the shader: start_time plus the simulated time."""
        return self.params.start_time + self.time

    # {{{ kernels

    def grass_expand(self, time: float | None = None) -> None:
        """Grass.shader geom() for every triangle of every plane at the shader time of ``time`` (default: now)."""
        p = self.params
        shader_time = self.shader_time if time is None else p.start_time + time
        if p.backend == "numpy":
            self.result = geo.expand_grass(self.ground, self.samples, self.models, p, shader_time)
            return
        self.d_params.set(p.block(shader_time))
        self.program.kernel("GrassExpand")(
            (self.blades,),
            None,
            self.d_tri.data,
            self.d_pos.data,
            self.d_nrm.data,
            *(s.data for s in self.d_samples),
            self.d_models.data,
            np.int32(len(self.ground["tri"])),
            np.int32(self.blades),
            self.d_params.data,
            self.blade_pos.data,
            self.blade_col.data,
            *(m.data for m in self.blade_means),
        )
        self.result = None  # read back on demand

    # }}}

    def _step(self, dt: float) -> None:
        self.grass_expand(self.time + dt)  # the geometry stage draws the frame at the end of this step

    def update(self, **changes) -> None:
        super().update(**changes)
        self.grass_expand()  # live changes show without a step (a reset has expanded already; twice is cheap)

    def blades_state(self) -> dict[str, np.ndarray]:
        """blade_pos (B, 7, 3), blade_col (B, 7, 4), blade_h/rot/wind (B,): the emitted geometry."""
        if self.result is None:
            h, r, w = (m.get() for m in self.blade_means)
            self.result = {
                "blade_pos": self.blade_pos.get().reshape(self.blades, geo.BLADE_VERTICES, 3),
                "blade_col": self.blade_col.get().reshape(self.blades, geo.BLADE_VERTICES, 4),
                "blade_h": h,
                "blade_rot": r,
                "blade_wind": w,
            }
        return self.result

    def state(self) -> dict[str, np.ndarray]:
        return {
            **self.blades_state(),
            "blade_tris": geo.strip_triangles(self.blades),
            "plane_model": self.models,
            "noise_height": self.maps["height"],
            "noise_rot": self.maps["rot"],
            "noise_wind": self.maps["wind"],
            "shader_time": np.float32(self.shader_time),
        }

    def stats(self) -> dict:
        rot = self.blades_state()["blade_rot"]
        return {
            **super().stats(),
            "planes": len(self.models),
            "blades": self.blades,
            "emitted vertices": self.blades * geo.BLADE_VERTICES,
            "triangles": self.blades * 5,
            "blades along +(p2-p0)": f"{float(np.mean(rot > 0.5)):.3f}",
            "shader time": self.shader_time,
            "backend": self.params.backend,
        }

    def mesh(self) -> Mesh:
        """The blades in world space, 7 vertices and 5 strip triangles each; no normals (the book's blades are unlit
        and two-sided). ``self.ground`` is the mesh the grass grows on."""
        return Mesh(self.blades_state()["blade_pos"], geo.strip_triangles(self.blades))

    def export_mesh(self, path) -> None:
        """--mesh: ``mesh()`` as .obj, .ply or .glb."""
        write_mesh(path, self.mesh())


# }}}

# {{{ the simple pyramid shader


@dataclass(frozen=True)
class PyramidParams(BaseParams):
    height: float = param(1.5, -1e4, 1e4, live=True)
    """Apex distance from the triangle along object -Z, object units (book: _Height; shader default 5)."""
    top_color: tuple[float, float, float, float] = param((0.0, 1.0, 0.0, 1.0), 0.0, 1.0, live=True)
    """Apex colour, rgba (book: _TopColor in Material.mat; shader default blue)."""
    bottom_color: tuple[float, float, float, float] = param((0.0, 0.0, 1.0, 1.0), 0.0, 1.0, live=True)
    """Base colour, rgba (book: _BottomColor in Material.mat; shader default red)."""
    backend: str = param("opencl", choices=("opencl", "numpy"), live=True)
    """Who runs the geometry stage headless: the PyramidExpand kernel or the numpy port."""


class PyramidSimulation(BaseSimulation):
    """Two quads: a plain one (fig. 6.2) and one drawn through the pyramid geometry shader (fig. 6.3)."""

    Params = PyramidParams

    def _reset(self) -> None:
        rotation = euler_matrix(*QUAD_EULER) @ np.diag([QUAD_SCALE, QUAD_SCALE, QUAD_SCALE, 1.0])
        self.models = np.array(
            [translation(-QUAD_X, 0.0, 0.0) @ rotation, translation(QUAD_X, 0.0, 0.0) @ rotation], np.float32
        )
        self.program = self.runtime.program("grass")
        self.set_ground(geo.quad_mesh(), self.models[1])

    def set_ground(self, mesh: dict, model: np.ndarray) -> None:
        """Run the pyramid shader on another mesh (pos, tri) with another model matrix (tests). Expands at once."""
        self.ground = {k: np.ascontiguousarray(v) for k, v in mesh.items()}
        self.model = np.ascontiguousarray(model, np.float32).reshape(4, 4)
        self.triangles = len(self.ground["tri"])
        rt = self.runtime
        self.d_tri = rt.to_device(self.ground["tri"].astype(np.uint32))
        self.d_pos = rt.to_device(self.ground["pos"].astype(np.float32))
        self.d_model = rt.to_device(self.model.ravel())
        self.pyr_pos = rt.empty(self.triangles * geo.PYRAMID_VERTICES * 3, np.float32)
        self.pyr_col = rt.empty(self.triangles * geo.PYRAMID_VERTICES * 4, np.float32)
        self.pyramid_expand()

    def pyramid_expand(self) -> None:
        """SimpleGeometryShader geom() for every triangle of the mesh."""
        p = self.params
        if p.backend == "numpy":
            self.result = geo.expand_pyramid(self.ground, self.model, p.height, p.top_color, p.bottom_color)
            return
        self.program.kernel("PyramidExpand")(
            (self.triangles,),
            None,
            self.d_tri.data,
            self.d_pos.data,
            self.d_model.data,
            np.int32(self.triangles),
            np.float32(p.height),
            cltypes.make_float4(*p.top_color),
            cltypes.make_float4(*p.bottom_color),
            self.pyr_pos.data,
            self.pyr_col.data,
        )
        self.result = None

    def _step(self, dt: float) -> None:
        self.pyramid_expand()

    def update(self, **changes) -> None:
        super().update(**changes)
        self.pyramid_expand()

    def state(self) -> dict[str, np.ndarray]:
        if self.result is None:
            self.result = {
                "pyr_pos": self.pyr_pos.get().reshape(self.triangles, geo.PYRAMID_VERTICES, 3),
                "pyr_col": self.pyr_col.get().reshape(self.triangles, geo.PYRAMID_VERTICES, 4),
            }
        return {**self.result, "quad_model": self.models}

    def stats(self) -> dict:
        return {
            **super().stats(),
            "input triangles": self.triangles,
            "output triangles": 4 * self.triangles,
            "backend": self.params.backend,
        }

    def mesh(self) -> Mesh:
        """The pyramids in world space, 12 vertices each as emitted (unwelded), no normals. The book's base runs the
        same way as the sides (it draws with Cull Off); here the base is reversed, and all four triangles where the
        apex lies behind the base, so that each pyramid, welded, is a closed solid wound outwards."""
        pos = self.state()["pyr_pos"]  # (T, 12, 3): p0 p1 p2 | p0 p1 apex | p1 p2 apex | p2 p0 apex
        p0, p1, p2, apex = (pos[:, k].astype(np.float64) for k in (0, 1, 2, 5))
        inward = np.einsum("ij,ij->i", np.cross(p1 - p0, p2 - p0), apex - p0) < 0
        local = np.array([[0, 2, 1], [3, 4, 5], [6, 7, 8], [9, 10, 11]])
        first = geo.PYRAMID_VERTICES * np.arange(len(pos))[:, None, None]
        return Mesh(pos, np.where(inward[:, None, None], local[:, ::-1], local) + first)

    def export_mesh(self, path) -> None:
        """--mesh: ``mesh()`` as .obj, .ply or .glb."""
        write_mesh(path, self.mesh())


# }}}


SCENES = [
    Scene(
        "grass",
        Simulation,
        "Grass shader: a geometry shader grows a blade on every triangle of 10x10 planes (vol.1 ch.6)",
        view="GrassView",
        # sin(30/20) ~ 1: the wind's full lean; 6x6 planes: the whole lawn with its edges fits the book's camera
        preview={"steps": 1, "start_time": 30.0, "planes": (6, 6)},
        preview_check=PreviewCheck(fills_frame="the book's camera sees the default 10x10 lawn run past both sides"),
        animation=Animation(
            "the wind sways the blades, one sway period per loop (wind_time_scale = 2 pi / 1.5 s; the book's 0.05 "
            "sways too slowly to see)",
            every=2,
            # 45 frames x 2 steps x dt 1/60 s = 1.5 s of shader time: one whole period of sin(t * wind_time_scale)
            overrides={"wind_time_scale": round(2 * math.pi / ((45 * 2) / 60), 4)},
        ),
    ),
    Scene(
        "grass_pyramid",
        PyramidSimulation,
        "Simple geometry shader: every triangle of a quad becomes a pyramid (vol.1 ch.6)",
        view="PyramidView",
        preview={"steps": 1},
    ),
]
